// systemd/shapesensed.service as systemd itself judges it: `systemd-analyze verify` accepts it
// (run on a copy whose ExecStart names the binary just built, since verify checks that it
// exists) and `systemd-analyze security --offline=true` scores its sandbox at most 2.0. Both
// work without a running systemd (in a container too); systemd-analyze comes with Debian's
// systemd package (scripts/deps). The unit's systemd/shapesensed.toml starts the daemon: every
// key is one of its options.

#include <cstdlib>
#include <fstream>
#include <regex>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "self_exec.h"
#include "test_paths.h"
#include "test_pki.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

/// The unit with ExecStart pointing at the built daemon, as <scratch>/shapesensed.service.
fs::path unitUnderTest(const std::string& scratch_name) {
  const fs::path dir = testing::scratchDir(scratch_name);
  std::string unit =
      testing::readText(fs::path(SHAPESENSE_SOURCE_DIR) / "systemd" / "shapesensed.service");
  const std::string installed = "/usr/local/bin/shapesensed";
  const std::string built = std::string(SHAPESENSE_BINARY_DIR) + "/server/shapesensed";
  for (auto at = unit.find(installed); at != std::string::npos; at = unit.find(installed, at)) {
    unit.replace(at, installed.size(), built);
    at += built.size();
  }
  const fs::path copy = dir / "shapesensed.service";
  std::ofstream(copy) << unit;
  return copy;
}

TEST(SystemdUnit, IsANotifyServiceWithAWatchdog) {
  const std::string unit =
      testing::readText(fs::path(SHAPESENSE_SOURCE_DIR) / "systemd" / "shapesensed.service");
  EXPECT_THAT(unit, HasSubstr("\nType=notify\n"));
  EXPECT_TRUE(std::regex_search(unit, std::regex("\nWatchdogSec=[1-9][0-9]*\n"))) << unit;
  EXPECT_THAT(unit, HasSubstr("\nStateDirectory=shapesense\n"));
}

TEST(SystemdUnit, SystemdAnalyzeVerifyAcceptsIt) {
  const fs::path unit = unitUnderTest("systemd_unit_verify");
  const auto [code, output] = testing::runCommand("systemd-analyze verify '" + unit.string() + "'",
                                                  unit.parent_path() / "verify.log");
  EXPECT_EQ(code, 0) << output;
  // Unknown or misspelt settings are only warnings for verify; none are allowed here.
  EXPECT_THAT(output, Not(HasSubstr("shapesensed.service"))) << output;
}

TEST(SystemdUnit, SandboxExposureIsAtMostTwo) {
  const fs::path unit = unitUnderTest("systemd_unit_security");
  const std::string output =
      testing::runCommand("systemd-analyze security --offline=true '" + unit.string() + "'",
                          unit.parent_path() / "security.log")
          .second;
  std::smatch match;
  ASSERT_TRUE(std::regex_search(output, match,
                                std::regex("Overall exposure level for shapesensed\\.service: "
                                           "([0-9]+\\.[0-9])")))
      << "systemd-analyze security said:\n"
      << output;
  const double exposure = std::stod(match[1].str());
  EXPECT_LE(exposure, 2.0) << output;
}

TEST(SystemdConfig, TheShippedConfigStartsTheDaemon) {
  const fs::path config = fs::path(SHAPESENSE_SOURCE_DIR) / "systemd" / "shapesensed.toml";
  // Its own port may be taken on a test machine: the one the system picks instead.
  const auto [code, output] =
      testing::runShapesensed("--config '" + config.string() + "' --listen 127.0.0.1:0", 3);
  EXPECT_EQ(code, 124) << output;  // still serving when stopped
  EXPECT_THAT(output, HasSubstr("serving")) << output;
}

TEST(SystemdConfig, AMisspeltKeyIsRefusedNamingIt) {
  const fs::path dir = testing::scratchDir("systemd-config-misspelt");
  const fs::path config = dir / "shapesensed.toml";
  std::ofstream(config) << testing::readText(fs::path(SHAPESENSE_SOURCE_DIR) / "systemd" /
                                             "shapesensed.toml")
                        << "taught-searches-per-frames = 2\n";
  const auto [code, output] =
      testing::runShapesensed("--config '" + config.string() + "' --listen 127.0.0.1:0", 10);
  EXPECT_NE(code, 0) << output;
  EXPECT_NE(code, 124) << output;  // refused at start, not left serving
  EXPECT_THAT(output, HasSubstr("taught-searches-per-frames")) << output;
}

TEST(SystemdConfig, TaughtSearchesPerFrameOutOfRangeIsRefusedNamingTheOption) {
  const auto [code, output] = testing::runShapesensed(
      "--listen 127.0.0.1:0 --taught-objects on --taught-searches-per-frame -1", 10);
  EXPECT_NE(code, 0) << output;
  EXPECT_NE(code, 124) << output;  // refused at start, not left serving
  EXPECT_THAT(output, HasSubstr("--taught-searches-per-frame")) << output;
}

}  // namespace
}  // namespace shapesense
