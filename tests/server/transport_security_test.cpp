// TLS and bearer tokens on a real in-process gRPC server, with certificates made by openssl at
// test time: each way a client can fail to get in ends with its own status code, and the
// listen policy refuses a reachable address without TLS and tokens.

#include "shapesense/server/transport_security.h"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <future>

#include <gmock/gmock.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>

#include "self_exec.h"
#include "server_fixture.h"
#include "shapesense/server/daemon.h"
#include "shapesense/server/rpc_server.h"
#include "test_paths.h"
#include "test_pki.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using ::testing::HasSubstr;
using testing::testPki;

constexpr const char* kReadToken = "read-token-0123456789abcdef";
constexpr const char* kRecordToken = "record-token-0123456789abcdef";

fs::path writeTokenFile(const fs::path& dir) {
  const fs::path file = dir / "tokens";
  std::ofstream(file) << "# NAME ROLE TOKEN\n"
                      << "robot read " << kReadToken << "\n"
                      << "operator record " << kRecordToken << "  # may record\n";
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  return file;
}

/// An RpcServer over an empty cache with the given transport security, on 127.0.0.1.
class SecureServer {
 public:
  explicit SecureServer(const TransportSecurity& security)
      : root_(testing::scratchDir("secure-server-root-" + std::to_string(::getpid()))) {
    RpcServerOptions options;
    if (security.tokens()) {
      options.tokens =
          std::make_shared<const AccessTokens>(AccessTokens::load(security.token_file));
    }
    options.credentials = makeServerCredentials(security, options.tokens);
    options.reflection = security.reflection;
    ServiceContext context{.cache = cache_, .hub = hub_};
    context.frame_tap = &tap_;
    context.record.root = root_;
    server_ = std::make_unique<RpcServer>("127.0.0.1:0", std::move(context), std::move(options));
  }
  ~SecureServer() {
    hub_.closeAll();
    server_->shutdown();
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(server_->port()); }

 private:
  fs::path root_;
  FrameCache cache_{4};
  SummaryHub hub_;
  FrameTap tap_;
  std::unique_ptr<RpcServer> server_;
};

struct ClientOptions {
  bool tls = true;
  fs::path ca = {};  ///< empty: the test CA
  std::string token = {};
  fs::path cert = {};
  fs::path key = {};
};

std::shared_ptr<grpc::Channel> channelTo(const std::string& address, ClientOptions options) {
  if (!options.tls) return grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = testing::readText(options.ca.empty() ? testPki().ca_cert : options.ca);
  if (!options.cert.empty()) {
    ssl.pem_cert_chain = testing::readText(options.cert);
    ssl.pem_private_key = testing::readText(options.key);
  }
  auto credentials = grpc::SslCredentials(ssl);
  if (!options.token.empty()) {
    credentials =
        grpc::CompositeChannelCredentials(credentials, grpc::AccessTokenCredentials(options.token));
  }
  return grpc::CreateChannel(address, credentials);
}

grpc::Status getStatus(const std::shared_ptr<grpc::Channel>& channel) {
  auto stub = v1::ShapeSense::NewStub(channel);
  v1::GetStatusResponse response;
  auto context = testing::clientContext(5000ms);
  return stub->GetStatus(context.get(), {}, &response);
}

grpc::Status record(const std::shared_ptr<grpc::Channel>& channel, const std::string& dir) {
  auto stub = v1::ShapeSense::NewStub(channel);
  v1::RecordRequest request;
  request.set_dir(dir);
  request.set_seconds(0.1);
  auto context = testing::clientContext(5000ms);
  auto reader = stub->Record(context.get(), request);
  v1::RecordProgress progress;
  while (reader->Read(&progress)) {
  }
  return reader->Finish();
}

/// A unary call of any method with an empty request (health, reflection).
grpc::Status callGeneric(const std::shared_ptr<grpc::Channel>& channel, const std::string& method) {
  grpc::GenericStub stub(channel);
  auto context = testing::clientContext(5000ms);
  grpc::Slice empty("");
  const grpc::ByteBuffer request(&empty, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(context.get(), method, grpc::StubOptions(), &request, &response,
                 [&](grpc::Status status) { done.set_value(std::move(status)); });
  return done.get_future().get();
}

TransportSecurity tlsWithTokens(const std::string& scratch) {
  TransportSecurity security;
  security.tls_cert = testPki().server_cert;
  security.tls_key = testPki().server_key;
  security.token_file = writeTokenFile(testing::scratchDir(scratch));
  return security;
}

#define EXPECT_CODE(status, code) EXPECT_EQ((status).error_code(), code) << (status).error_message()

TEST(TransportSecurity, ACallWithoutATokenIsUnauthenticated) {
  SecureServer server(tlsWithTokens("tokens-none"));
  const grpc::Status status = getStatus(channelTo(server.address(), {}));
  EXPECT_CODE(status, grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("needs a bearer token"));
}

TEST(TransportSecurity, AWrongTokenIsUnauthenticated) {
  SecureServer server(tlsWithTokens("tokens-wrong"));
  for (const std::string& token :
       std::vector<std::string>{"not-a-token-of-this-daemon", "read-token-0123456789abcdeX",
                                "read-token-0123456789abcde", std::string(kReadToken) + "0"}) {
    const grpc::Status status = getStatus(channelTo(server.address(), {.token = token}));
    EXPECT_CODE(status, grpc::StatusCode::UNAUTHENTICATED) << " for " << token;
    EXPECT_THAT(status.error_message(), HasSubstr("not valid"));
  }
  // The same channel setup with a known token gets in.
  EXPECT_TRUE(getStatus(channelTo(server.address(), {.token = kReadToken})).ok());
}

TEST(TransportSecurity, AReadTokenQueriesButOnlyARecordTokenRecords) {
  SecureServer server(tlsWithTokens("tokens-roles"));
  const auto reader = channelTo(server.address(), {.token = kReadToken});
  const auto recorder = channelTo(server.address(), {.token = kRecordToken});
  EXPECT_TRUE(getStatus(reader).ok());
  EXPECT_TRUE(getStatus(recorder).ok());

  const grpc::Status refused = record(reader, "take");
  EXPECT_CODE(refused, grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_THAT(refused.error_message(), HasSubstr("role read"));
  // The record token reaches the handler, which judges the request itself.
  EXPECT_CODE(record(recorder, "../take"), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST(TransportSecurity, TheHealthServiceNeedsATokenToo) {
  SecureServer server(tlsWithTokens("tokens-health"));
  EXPECT_CODE(callGeneric(channelTo(server.address(), {}), "/grpc.health.v1.Health/Check"),
              grpc::StatusCode::UNAUTHENTICATED);
  const grpc::Status with_token = callGeneric(channelTo(server.address(), {.token = kReadToken}),
                                              "/grpc.health.v1.Health/Check");
  EXPECT_TRUE(with_token.ok()) << with_token.error_message();
}

TEST(TransportSecurity, AnExpiredServerCertificateFailsTheHandshake) {
  ASSERT_TRUE(testing::certificateExpired(testPki().expired_server_cert));
  ASSERT_FALSE(testing::certificateExpired(testPki().server_cert));
  TransportSecurity security = tlsWithTokens("tokens-expired");
  security.tls_cert = testPki().expired_server_cert;
  SecureServer server(security);
  EXPECT_CODE(getStatus(channelTo(server.address(), {.token = kReadToken})),
              grpc::StatusCode::UNAVAILABLE);
}

TEST(TransportSecurity, AServerCertificateFromAnotherCaFailsTheHandshake) {
  SecureServer server(tlsWithTokens("tokens-other-ca"));
  EXPECT_CODE(
      getStatus(channelTo(server.address(), {.ca = testPki().other_ca_cert, .token = kReadToken})),
      grpc::StatusCode::UNAVAILABLE);
}

TEST(TransportSecurity, APlainClientCannotTalkToATlsServer) {
  SecureServer server(tlsWithTokens("tokens-plain-client"));
  EXPECT_CODE(getStatus(channelTo(server.address(), {.tls = false})),
              grpc::StatusCode::UNAVAILABLE);
}

TEST(TransportSecurity, ClientCertificatesAreRequiredAndVerifiedWithAClientCa) {
  ASSERT_TRUE(testing::certificateExpired(testPki().expired_client_cert));
  TransportSecurity security = tlsWithTokens("tokens-client-ca");
  security.tls_client_ca = testPki().ca_cert;
  SecureServer server(security);
  const auto& pki = testPki();
  EXPECT_CODE(getStatus(channelTo(server.address(), {.token = kReadToken})),
              grpc::StatusCode::UNAVAILABLE);
  EXPECT_CODE(getStatus(channelTo(
                  server.address(),
                  {.token = kReadToken, .cert = pki.expired_client_cert, .key = pki.client_key})),
              grpc::StatusCode::UNAVAILABLE);
  const grpc::Status good = getStatus(channelTo(
      server.address(), {.token = kReadToken, .cert = pki.client_cert, .key = pki.client_key}));
  EXPECT_TRUE(good.ok()) << good.error_message();
  // A valid certificate does not replace the token.
  EXPECT_CODE(
      getStatus(channelTo(server.address(), {.cert = pki.client_cert, .key = pki.client_key})),
      grpc::StatusCode::UNAUTHENTICATED);
}

TEST(TransportSecurity, ReflectionIsServedOnlyWhenAskedFor) {
  constexpr const char* kReflection =
      "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo";
  {
    SecureServer server(TransportSecurity{});
    EXPECT_CODE(callGeneric(channelTo(server.address(), {.tls = false}), kReflection),
                grpc::StatusCode::UNIMPLEMENTED);
  }
  TransportSecurity security;
  security.reflection = true;
  SecureServer server(security);
  EXPECT_NE(callGeneric(channelTo(server.address(), {.tls = false}), kReflection).error_code(),
            grpc::StatusCode::UNIMPLEMENTED);
}

TEST(ListenPolicy, LoopbackAddresses) {
  for (const char* address : {"127.0.0.1:50551", "127.1.2.3:0", "localhost:50551", "[::1]:50551",
                              "ipv4:127.0.0.1:1", "ipv6:[::1]:1", "unix:/run/shapesense.sock"}) {
    EXPECT_TRUE(isLoopbackAddress(address)) << address;
  }
  for (const char* address :
       {"0.0.0.0:50551", "[::]:50551", "192.168.1.20:50551", ":50551", "robot.local:50551",
        "127.0.0.1.example.com:1", "[::ffff:1.2.3.4]:1", "10.127.0.0:1"}) {
    EXPECT_FALSE(isLoopbackAddress(address)) << address;
  }
}

TEST(ListenPolicy, AReachableAddressNeedsTlsAndTokensOrInsecureRemote) {
  const auto refusal = [](const std::string& listen, const TransportSecurity& security) {
    try {
      checkTransportOptions(listen, security);
      return std::string();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
  };
  TransportSecurity plain;
  EXPECT_EQ(refusal("127.0.0.1:50551", plain), "");
  EXPECT_THAT(refusal("0.0.0.0:50551", plain), HasSubstr("--insecure-remote"));
  EXPECT_THAT(refusal("[::]:50551", plain), HasSubstr("reachable from other machines"));
  TransportSecurity tls_only;
  tls_only.tls_cert = "server.pem";
  tls_only.tls_key = "server.key";
  EXPECT_THAT(refusal("0.0.0.0:50551", tls_only), HasSubstr("--token-file"));
  TransportSecurity both = tls_only;
  both.token_file = "tokens";
  EXPECT_EQ(refusal("0.0.0.0:50551", both), "");
  TransportSecurity insecure;
  insecure.insecure_remote = true;
  EXPECT_EQ(refusal("0.0.0.0:50551", insecure), "");
  EXPECT_TRUE(servesInsecureRemote("0.0.0.0:50551", insecure));
  EXPECT_FALSE(servesInsecureRemote("0.0.0.0:50551", both));
  EXPECT_FALSE(servesInsecureRemote("127.0.0.1:50551", insecure));

  // Options that do not go together, whatever the address.
  TransportSecurity tokens_only;
  tokens_only.token_file = "tokens";
  EXPECT_THAT(refusal("127.0.0.1:1", tokens_only), HasSubstr("never sent in clear text"));
  TransportSecurity cert_only;
  cert_only.tls_cert = "server.pem";
  EXPECT_THAT(refusal("127.0.0.1:1", cert_only), HasSubstr("--tls-key"));
  TransportSecurity client_ca_only;
  client_ca_only.tls_client_ca = "ca.pem";
  EXPECT_THAT(refusal("127.0.0.1:1", client_ca_only), HasSubstr("needs TLS"));
}

TEST(ListenPolicy, TheDaemonRefusesToStartOnAReachableAddressWithoutTlsAndTokens) {
  DaemonOptions options;
  options.source = "synthetic";
  options.listen = "0.0.0.0:0";
  try {
    Daemon daemon(options);
    FAIL() << "the daemon started on 0.0.0.0 without TLS and tokens";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("--insecure-remote"));
  }
}

TEST(ListenPolicy, ShapesensedExitsWithAClearMessage) {
  const auto [code, output] = testing::runShapesensed("--listen 0.0.0.0:0 --bowls off");
  EXPECT_EQ(code, 1) << output;
  EXPECT_THAT(output, HasSubstr("is reachable from other machines"));
  EXPECT_THAT(output, HasSubstr("--insecure-remote"));
}

TEST(ListenPolicy, InsecureRemoteServesButWarns) {
  const auto [code, output] =
      testing::runShapesensed("--listen 0.0.0.0:0 --bowls off --insecure-remote", 2);
  EXPECT_EQ(code, 124) << output;  // still serving when stopped
  EXPECT_THAT(output, HasSubstr("--insecure-remote: 0.0.0.0:0 serves the whole API without "
                                "encryption or authentication"));
}

TEST(TokenFile, ShapesensedRefusesATokenFileOthersCanRead) {
  const fs::path file = writeTokenFile(testing::scratchDir("tokens-mode"));
  fs::permissions(file, fs::perms::group_read, fs::perm_options::add);
  const auto& pki = testPki();
  const auto [code, output] = testing::runShapesensed(
      "--listen 127.0.0.1:0 --bowls off --tls-cert " + pki.server_cert.string() + " --tls-key " +
      pki.server_key.string() + " --token-file " + file.string());
  EXPECT_EQ(code, 1) << output;
  EXPECT_THAT(output, HasSubstr("mode 640: group or others may read it"));
}

}  // namespace
}  // namespace shapesense
