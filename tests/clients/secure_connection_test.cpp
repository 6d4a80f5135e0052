// The CLI against a daemon that takes TLS and tokens: its --tls-ca and --token-file options
// get it in with the role the token grants, and each missing piece fails with a clear error.

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "commands.h"
#include "shapesense/server/daemon.h"
#include "test_paths.h"
#include "test_pki.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class SecureConnection : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = testing::scratchDir(
        "cli_secure_connection_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    const auto& pki = testing::testPki();
    std::ofstream(dir / "tokens") << "robot read read-token-0123456789abcdef\n"
                                  << "operator record record-token-0123456789abcdef\n";
    fs::permissions(dir / "tokens", fs::perms::owner_read | fs::perms::owner_write);
    std::ofstream(dir / "read-token") << "read-token-0123456789abcdef\n";
    std::ofstream(dir / "wrong-token") << "# not this daemon's\nwrong-token-0123456789abcdef\n";
    DaemonOptions options;
    options.source = "synthetic";
    options.listen = "127.0.0.1:0";
    options.detectors.bowls = false;
    options.security.tls_cert = pki.server_cert;
    options.security.tls_key = pki.server_key;
    options.security.token_file = dir / "tokens";
    options.record.root = dir / "recordings";
    daemon = std::make_unique<Daemon>(options);
    server = "127.0.0.1:" + std::to_string(daemon->port());
  }

  /// Runs `shapesense ARGS` as main() sets it up; what it printed.
  std::string run(std::vector<std::string> args) {
    cli::GlobalOptions global;
    CLI::App app;
    app.require_subcommand(1);
    cli::addGlobalOptions(app, global);
    cli::addStatusCommand(app, global);
    cli::addRecordCommand(app, global);
    std::reverse(args.begin(), args.end());  // CLI11 takes a reversed vector
    ::testing::internal::CaptureStdout();
    try {
      app.parse(args);
    } catch (...) {
      ::testing::internal::GetCapturedStdout();
      throw;
    }
    return ::testing::internal::GetCapturedStdout();
  }

  /// The gRPC status code the command failed with.
  grpc::StatusCode failure(const std::vector<std::string>& args) {
    try {
      run(args);
    } catch (const cli::RpcError& e) {
      return e.code();
    }
    return grpc::StatusCode::OK;
  }

  fs::path dir;
  std::unique_ptr<Daemon> daemon;
  std::string server;
};

TEST_F(SecureConnection, TlsCaAndTokenFileGetTheCliIn) {
  const std::string ca = testing::testPki().ca_cert.string();
  const std::string out = run({"--server", server, "--tls-ca", ca, "--token-file",
                               (dir / "read-token").string(), "status"});
  EXPECT_THAT(out, HasSubstr("synthetic"));
}

TEST_F(SecureConnection, EachMissingPieceFailsWithItsCode) {
  const std::string ca = testing::testPki().ca_cert.string();
  const std::string read_token = (dir / "read-token").string();
  EXPECT_EQ(failure({"--server", server, "status"}), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(failure({"--server", server, "--tls-ca", ca, "status"}),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(failure({"--server", server, "--tls-ca", ca, "--token-file",
                     (dir / "wrong-token").string(), "status"}),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(failure({"--server", server, "--tls-ca", ca, "--token-file", read_token, "record",
                     "--out", "take", "--seconds", "1"}),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_FALSE(fs::exists(dir / "recordings" / "take"));
}

TEST_F(SecureConnection, ATokenIsNeverSentWithoutTls) {
  try {
    run({"--server", server, "--token-file", (dir / "read-token").string(), "status"});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("--token-file needs --tls-ca"));
  }
}

}  // namespace
}  // namespace shapesense
