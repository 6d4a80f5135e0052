#pragma once
// Child processes: the test binary again with extra environment, e.g. under Debian's fakenect
// library (which replaces libfreenect.so.0.5 for a whole process), and the built daemon.

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

/// Runs the shell command `command` with its output (stdout and stderr) to `log`; its exit code
/// (-1 when it did not exit) and output.
std::pair<int, std::string> runCommand(const std::string& command,
                                       const std::filesystem::path& log);

/// Runs the built shapesensed with `arguments` (shell words) and a --record-root and
/// --object-models in a scratch folder named after the running test, stopped with SIGTERM
/// after `seconds` if it has not exited by then; its exit code (124 when stopped) and output.
std::pair<int, std::string> runShapesensed(const std::string& arguments, int seconds = 20);

}  // namespace shapesense::testing
