#pragma once
// Who may talk to the daemon, and over what. Loopback is plain by default; any other listen
// address needs TLS and bearer tokens (or the operator's explicit --insecure-remote). Tokens are
// checked for every call of every service in one place, CallAuthenticator, which gRPC runs
// before a call reaches its handler: no token or an unknown one is UNAUTHENTICATED, a token
// whose role does not cover the method is PERMISSION_DENIED. Tokens need TLS: a bearer token
// sent in clear text is a token given away.

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include <grpcpp/security/auth_metadata_processor.h>
#include <grpcpp/security/server_credentials.h>

#include "shapesense/server/access_tokens.h"

namespace shapesense {

/// The daemon's transport options (see `shapesensed --help`).
struct TransportSecurity {
  std::filesystem::path tls_cert;       ///< PEM certificate chain; with tls_key turns TLS on
  std::filesystem::path tls_key;        ///< PEM private key
  std::filesystem::path tls_client_ca;  ///< PEM CA bundle: clients must present a cert it signs
  std::filesystem::path token_file;     ///< AccessTokens file; needs TLS
  bool insecure_remote = false;         ///< allow a non-loopback address without TLS and tokens
  bool reflection = false;              ///< serve grpc.reflection (lists the whole API)

  bool tls() const { return !tls_cert.empty(); }
  bool tokens() const { return !token_file.empty(); }
};

/// True for addresses only this machine can reach: 127.0.0.0/8, [::1], localhost, unix:.
bool isLoopbackAddress(std::string_view listen_address);

/// True when the daemon would serve a non-loopback address without TLS and tokens (allowed only
/// with insecure_remote, which then warns periodically).
bool servesInsecureRemote(const std::string& listen_address, const TransportSecurity& security);

/// Checks that the options make sense together and that `listen_address` is allowed with them.
/// Throws std::invalid_argument with a message that says which option to add or drop.
void checkTransportOptions(const std::string& listen_address, const TransportSecurity& security);

/// The token of a call's `authorization: Bearer TOKEN` metadata value; empty when it is not
/// of that form.
std::string_view bearerToken(std::string_view authorization);

/// Admits or refuses each call by its `authorization: Bearer TOKEN` metadata and method. It sets
/// nothing in the auth context, which gRPC shares between the calls of a connection.
class CallAuthenticator final : public grpc::AuthMetadataProcessor {
 public:
  explicit CallAuthenticator(std::shared_ptr<const AccessTokens> tokens)
      : tokens_(std::move(tokens)) {}

  /// Cheap and non-blocking: runs on gRPC's own thread.
  bool IsBlocking() const override { return false; }
  grpc::Status Process(const InputMetadata& auth_metadata, grpc::AuthContext* context,
                       OutputMetadata* consumed_auth_metadata,
                       OutputMetadata* response_metadata) override;

 private:
  std::shared_ptr<const AccessTokens> tokens_;
};

/// Credentials for the listening port: null for plain, else TLS (with client-certificate
/// verification when tls_client_ca is set) checking `tokens` with a CallAuthenticator when
/// there are any (RpcServerOptions::credentials).
/// Reads the PEM files now; throws std::runtime_error naming a file that cannot be used.
std::shared_ptr<grpc::ServerCredentials> makeServerCredentials(
    const TransportSecurity& security, std::shared_ptr<const AccessTokens> tokens);

}  // namespace shapesense
