#pragma once
// Certificates for TLS tests, made with the openssl command line tool at test time (P-256
// keys): a CA, a server certificate for localhost and 127.0.0.1, a client certificate, and an
// expired twin of each (end date before start date: `openssl x509 -days -1`). Made once per
// test process, in a directory of its own under the build tree.

#include <filesystem>

namespace shapesense::testing {

struct TestPki {
  std::filesystem::path dir;
  std::filesystem::path ca_cert;
  std::filesystem::path server_cert, server_key, expired_server_cert;
  std::filesystem::path client_cert, client_key, expired_client_cert;
  /// A second CA that signed nothing above.
  std::filesystem::path other_ca_cert;
};

/// The certificates; throws std::runtime_error (with openssl's output) when they cannot be made.
const TestPki& testPki();

/// True when openssl says `cert` has expired.
bool certificateExpired(const std::filesystem::path& cert);

/// The text of a file.
std::string readText(const std::filesystem::path& file);

}  // namespace shapesense::testing
