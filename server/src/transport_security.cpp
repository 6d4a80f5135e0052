#include "shapesense/server/transport_security.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include <spdlog/spdlog.h>

namespace shapesense {
namespace {

std::string readPem(const std::filesystem::path& file, const char* what) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in || text.str().find("-----BEGIN") == std::string::npos) {
    throw std::runtime_error("cannot use " + file.string() + " as " + what +
                             ": not a readable PEM file");
  }
  return text.str();
}

/// The host part of HOST:PORT, [V6]:PORT, ipv4:HOST:PORT, ipv6:[V6]:PORT or dns:HOST:PORT.
std::string_view hostOf(std::string_view address) {
  for (const std::string_view scheme : {"ipv4:", "ipv6:", "dns:"}) {
    if (address.starts_with(scheme)) address.remove_prefix(scheme.size());
  }
  if (address.starts_with('[')) {
    const auto close = address.find(']');
    return close == std::string_view::npos ? address : address.substr(1, close - 1);
  }
  const auto colon = address.rfind(':');
  return colon == std::string_view::npos ? address : address.substr(0, colon);
}

}  // namespace

bool isLoopbackAddress(std::string_view listen_address) {
  if (listen_address.starts_with("unix:") || listen_address.starts_with("unix-abstract:")) {
    return true;
  }
  const std::string_view host = hostOf(listen_address);
  if (host == "localhost" || host == "::1") return true;
  // 127.0.0.0/8, written as a dotted quad.
  if (!host.starts_with("127.")) return false;
  int dots = 0;
  for (const char c : host) {
    if (c == '.') {
      ++dots;
    } else if (c < '0' || c > '9') {
      return false;
    }
  }
  return dots == 3;
}

bool servesInsecureRemote(const std::string& listen_address, const TransportSecurity& security) {
  return !isLoopbackAddress(listen_address) && !(security.tls() && security.tokens());
}

void checkTransportOptions(const std::string& listen_address, const TransportSecurity& security) {
  if (security.tls_cert.empty() != security.tls_key.empty()) {
    throw std::invalid_argument("--tls-cert and --tls-key go together: give both or neither");
  }
  if (!security.tls_client_ca.empty() && !security.tls()) {
    throw std::invalid_argument("--tls-client-ca needs TLS: add --tls-cert and --tls-key");
  }
  if (security.tokens() && !security.tls()) {
    throw std::invalid_argument(
        "--token-file needs TLS (--tls-cert and --tls-key): bearer tokens are never sent in "
        "clear text");
  }
  if (servesInsecureRemote(listen_address, security) && !security.insecure_remote) {
    throw std::invalid_argument(
        "--listen " + listen_address +
        " is reachable from other machines: serve it with TLS and tokens (--tls-cert, "
        "--tls-key, --token-file), listen on loopback (127.0.0.1:PORT), or accept an open, "
        "unencrypted API with --insecure-remote");
  }
}

std::string_view bearerToken(std::string_view authorization) {
  constexpr std::string_view kScheme = "Bearer ";
  if (!authorization.starts_with(kScheme)) return {};
  return authorization.substr(kScheme.size());
}

grpc::Status CallAuthenticator::Process(const InputMetadata& auth_metadata, grpc::AuthContext*,
                                        OutputMetadata*, OutputMetadata*) {
  const auto path = auth_metadata.find(":path");
  const std::string_view method = path == auth_metadata.end()
                                      ? std::string_view{}
                                      : std::string_view(path->second.data(), path->second.size());
  const auto header = auth_metadata.find("authorization");
  if (header == auth_metadata.end()) {
    spdlog::info("refused {}: no token", method);
    return {grpc::StatusCode::UNAUTHENTICATED,
            "this daemon needs a bearer token (shapesense --token-file FILE)"};
  }
  const auto grant =
      tokens_->find(bearerToken(std::string_view(header->second.data(), header->second.size())));
  if (!grant) {
    spdlog::info("refused {}: unknown token", method);
    return {grpc::StatusCode::UNAUTHENTICATED, "the token is not valid for this daemon"};
  }
  // Without the method the role cannot be checked: refuse rather than guess.
  const Role needed = method.empty() ? Role::kRecord : requiredRole(method);
  if (!allows(grant->role, needed)) {
    spdlog::info("refused {} for {}: role {} cannot", method, grant->name, toString(grant->role));
    return {grpc::StatusCode::PERMISSION_DENIED,
            "the token of " + grant->name + " has role " + toString(grant->role) + "; " +
                std::string(method) + " needs role " + toString(needed)};
  }
  return grpc::Status::OK;
}

std::shared_ptr<grpc::ServerCredentials> makeServerCredentials(
    const TransportSecurity& security, std::shared_ptr<const AccessTokens> tokens) {
  if (!security.tls()) return nullptr;
  grpc::SslServerCredentialsOptions options(
      security.tls_client_ca.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                                     : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  options.pem_key_cert_pairs.push_back(
      {readPem(security.tls_key, "--tls-key"), readPem(security.tls_cert, "--tls-cert")});
  if (!security.tls_client_ca.empty()) {
    options.pem_root_certs = readPem(security.tls_client_ca, "--tls-client-ca");
  }
  auto credentials = grpc::SslServerCredentials(options);
  if (tokens) {
    credentials->SetAuthMetadataProcessor(std::make_shared<CallAuthenticator>(std::move(tokens)));
  }
  return credentials;
}

}  // namespace shapesense
