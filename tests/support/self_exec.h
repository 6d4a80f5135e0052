#pragma once
// Running the test binary again in a child process with extra environment, e.g. under Debian's
// fakenect library (which replaces libfreenect.so.0.5 for a whole process).

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace shapesense::testing {

/// Where Debian installs fakenect's libfreenect.so.0.5 (<multiarch libdir>/fakenect), if it is.
std::optional<std::filesystem::path> fakenectLibraryDir();

/// Runs this binary again with `env` ("NAME=value") added and --gtest_filter=`filter`, output to
/// `log`; kills it after `limit`. Returns (exit code, or -1 on timeout; the output).
std::pair<int, std::string> runSelf(const std::string& filter, const std::vector<std::string>& env,
                                    const std::filesystem::path& log, std::chrono::seconds limit);

/// The environment for a child under fakenect replaying `dump` (plus `inner_flag`=1).
std::vector<std::string> fakenectEnvironment(const std::filesystem::path& library_dir,
                                             const std::filesystem::path& dump,
                                             const std::string& inner_flag);

}  // namespace shapesense::testing
