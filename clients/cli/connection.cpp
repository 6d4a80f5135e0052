#include "connection.h"

#include <fstream>
#include <sstream>

#include <google/protobuf/util/json_util.h>

#include "commands.h"
#include "shapesense/server/access_tokens.h"

namespace shapesense::cli {
namespace {

std::string readFile(const std::string& file, const char* option) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in) throw std::runtime_error(std::string("cannot read ") + option + " " + file);
  return text.str();
}

}  // namespace

void addGlobalOptions(CLI::App& app, GlobalOptions& global) {
  app.add_option("--server", global.server, "Daemon address")->capture_default_str();
  app.add_option("--timeout", global.timeout_s, "Seconds to wait for an answer")
      ->capture_default_str();
  app.add_option("--tls-ca", global.tls_ca,
                 "Connect with TLS, trusting daemon certificates this PEM CA bundle signed");
  app.add_option("--tls-cert", global.tls_cert,
                 "With --tls-ca: this client's PEM certificate, for a daemon started with "
                 "--tls-client-ca");
  app.add_option("--tls-key", global.tls_key, "With --tls-cert: this client's PEM private key");
  app.add_option("--token-file", global.token_file,
                 "Send the bearer token on this file's first line with every call (needs "
                 "--tls-ca)");
}

grpc::ChannelArguments freshStreamArguments() {
  grpc::ChannelArguments args;
  // The window the client grants the server: the smallest gRPC allows, never grown by
  // bandwidth probing (which would let the server push seconds of summaries ahead).
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 1);
  return args;
}

std::shared_ptr<grpc::Channel> makeChannel(const GlobalOptions& options,
                                           const grpc::ChannelArguments& args) {
  if (options.tls_ca.empty()) {
    if (!options.tls_cert.empty()) {
      throw std::runtime_error("--tls-cert needs --tls-ca (the CA of the daemon's certificate)");
    }
    if (!options.token_file.empty()) {
      throw std::runtime_error(
          "--token-file needs --tls-ca: a token is never sent in clear text (the daemon takes "
          "tokens only over TLS)");
    }
    return grpc::CreateCustomChannel(options.server, grpc::InsecureChannelCredentials(), args);
  }
  if (options.tls_cert.empty() != options.tls_key.empty()) {
    throw std::runtime_error("--tls-cert and --tls-key go together: give both or neither");
  }
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = readFile(options.tls_ca, "--tls-ca");
  if (!options.tls_cert.empty()) {
    ssl.pem_cert_chain = readFile(options.tls_cert, "--tls-cert");
    ssl.pem_private_key = readFile(options.tls_key, "--tls-key");
  }
  auto credentials = grpc::SslCredentials(ssl);
  if (!options.token_file.empty()) {
    // Sent as `authorization: Bearer TOKEN`, the form the daemon's CallAuthenticator reads.
    credentials = grpc::CompositeChannelCredentials(
        credentials, grpc::AccessTokenCredentials(readClientToken(options.token_file)));
  }
  return grpc::CreateCustomChannel(options.server, credentials, args);
}

RpcError::RpcError(const grpc::Status& status)
    : std::runtime_error(statusCodeName(status.error_code()) + ": " + status.error_message()),
      code_(status.error_code()) {}

Connection::Connection(const GlobalOptions& options)
    : options_(options), stub_(v1::ShapeSense::NewStub(makeChannel(options))) {}

std::unique_ptr<grpc::ClientContext> Connection::context() const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<long>(options_.timeout_s * 1000)));
  return context;
}

std::unique_ptr<grpc::ClientContext> Connection::streamContext() {
  return std::make_unique<grpc::ClientContext>();
}

void Connection::check(const grpc::Status& status) {
  if (!status.ok()) throw RpcError(status);
}

std::string toJson(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

std::int64_t Connection::newestProcessedFrame() {
  v1::ListFramesResponse frames;
  check(stub().ListFrames(context().get(), {}, &frames));
  for (auto it = frames.frames().rbegin(); it != frames.frames().rend(); ++it) {
    if (it->processed()) return it->timestamp_ns();
  }
  return 0;
}

}  // namespace shapesense::cli
