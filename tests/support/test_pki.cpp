#include "test_pki.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

#include "test_paths.h"

namespace shapesense::testing {
namespace {

namespace fs = std::filesystem;

void run(const fs::path& dir, const std::string& command) {
  const std::string line = "cd '" + dir.string() + "' && " + command + " >>openssl.log 2>&1";
  if (std::system(line.c_str()) != 0) {
    throw std::runtime_error("making test certificates failed: " + command + "\n" +
                             readText(dir / "openssl.log"));
  }
}

void makeKeyAndRequest(const fs::path& dir, const std::string& name, const std::string& subject) {
  run(dir, "openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout " + name +
               ".key -out " + name + ".csr -subj " + subject);
}

void sign(const fs::path& dir, const std::string& name, const std::string& out, int days,
          const std::string& extensions) {
  run(dir, "openssl x509 -req -in " + name +
               ".csr -CA ca.pem -CAkey ca.key -CAcreateserial -days " + std::to_string(days) +
               " -extfile " + extensions + " -out " + out);
}

TestPki makePki() {
  TestPki pki;
  // Per process: ctest runs tests of one binary in parallel processes.
  pki.dir = scratchDir("test-pki-" + std::to_string(::getpid()));
  const fs::path& dir = pki.dir;
  for (const char* ca : {"ca", "other-ca"}) {
    run(dir, std::string("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes ") +
                 "-keyout " + ca + ".key -out " + ca + ".pem -days 30 -subj /CN=shapesense-" + ca);
  }
  std::ofstream(dir / "server.ext") << "subjectAltName=DNS:localhost,IP:127.0.0.1\n"
                                    << "extendedKeyUsage=serverAuth\n";
  std::ofstream(dir / "client.ext") << "extendedKeyUsage=clientAuth\n";
  makeKeyAndRequest(dir, "server", "/CN=localhost");
  sign(dir, "server", "server.pem", 30, "server.ext");
  sign(dir, "server", "server-expired.pem", -1, "server.ext");
  makeKeyAndRequest(dir, "client", "/CN=robot");
  sign(dir, "client", "client.pem", 30, "client.ext");
  sign(dir, "client", "client-expired.pem", -1, "client.ext");
  pki.ca_cert = dir / "ca.pem";
  pki.other_ca_cert = dir / "other-ca.pem";
  pki.server_cert = dir / "server.pem";
  pki.server_key = dir / "server.key";
  pki.expired_server_cert = dir / "server-expired.pem";
  pki.client_cert = dir / "client.pem";
  pki.client_key = dir / "client.key";
  pki.expired_client_cert = dir / "client-expired.pem";
  return pki;
}

}  // namespace

const TestPki& testPki() {
  static std::once_flag once;
  static TestPki pki;
  std::call_once(once, [] { pki = makePki(); });
  return pki;
}

bool certificateExpired(const fs::path& cert) {
  const std::string line = "openssl x509 -checkend 0 -noout -in '" + cert.string() + "' >/dev/null";
  return std::system(line.c_str()) != 0;
}

std::string readText(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace shapesense::testing
