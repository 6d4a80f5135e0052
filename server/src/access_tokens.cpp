#include "shapesense/server/access_tokens.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace shapesense {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxTokenFileBytes = 1 << 20;

/// Methods a `read` token may call. Anything not listed needs `record`, so a method added
/// later is closed until someone decides it only reads.
constexpr std::array<std::string_view, 16> kReadMethods = {
    "/shapesense.v1.ShapeSense/GetStatus",
    "/shapesense.v1.ShapeSense/ListFrames",
    "/shapesense.v1.ShapeSense/GetFrame",
    "/shapesense.v1.ShapeSense/Watch",
    "/shapesense.v1.ShapeSense/EstimateBox",
    "/shapesense.v1.ShapeSense/GetDetectedBoxes",
    "/shapesense.v1.ShapeSense/GetSegments",
    "/shapesense.v1.ShapeSense/GetPlanes",
    "/shapesense.v1.ShapeSense/GetBowls",
    "/shapesense.v1.ShapeSense/GetScene",
    "/shapesense.v1.ShapeSense/WatchScene",
    "/shapesense.v1.ShapeSense/ListObjectModels",
    "/shapesense.v1.ShapeSense/FindObjects",
    "/grpc.health.v1.Health/Check",
    "/grpc.health.v1.Health/Watch",
    "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
};

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

std::string_view withoutComment(std::string_view line) {
  const auto hash = line.find('#');
  return trim(hash == std::string_view::npos ? line : line.substr(0, hash));
}

bool printableWithoutBlanks(std::string_view s) {
  for (const char c : s) {
    if (c <= ' ' || c == 0x7f) return false;
  }
  return true;
}

/// Equal without an early exit, so the time taken does not reveal how much of a guess matched.
bool constantTimeEqual(std::string_view a, std::string_view b) {
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i) {
    difference |= static_cast<unsigned char>(a[i] ^ (i < b.size() ? b[i] : 0));
  }
  return difference == 0;
}

/// The whole file, read from one descriptor so the checked file is the read file.
std::string readPrivateFile(const fs::path& file, bool require_private) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    throw std::runtime_error("cannot read token file " + file.string() + ": " +
                             std::strerror(errno));
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat info {};
  if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    throw std::runtime_error("token file " + file.string() + " is not a regular file");
  }
  if (require_private && (info.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    std::ostringstream mode;
    mode << std::oct << (info.st_mode & 07777);
    throw std::runtime_error("token file " + file.string() + " has mode " + mode.str() +
                             ": group or others may read it; make it readable only by the "
                             "daemon's user (chmod 600 " +
                             file.string() + ")");
  }
  if (static_cast<std::size_t>(info.st_size) > kMaxTokenFileBytes) {
    throw std::runtime_error("token file " + file.string() + " is larger than 1 MiB");
  }
  std::string text(static_cast<std::size_t>(info.st_size), '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  text.resize(got);
  return text;
}

}  // namespace

const char* toString(Role role) { return role == Role::kRecord ? "record" : "read"; }

Role requiredRole(std::string_view method_path) {
  for (const auto read : kReadMethods) {
    if (method_path == read) return Role::kRead;
  }
  return Role::kRecord;
}

bool allows(Role granted, Role needed) { return granted == Role::kRecord || needed == Role::kRead; }

AccessTokens AccessTokens::load(const fs::path& file) {
  return parse(readPrivateFile(file, /*require_private=*/true), file.string());
}

AccessTokens AccessTokens::parse(std::string_view text, const std::string& origin) {
  AccessTokens tokens;
  std::size_t line_number = 0;
  while (!text.empty()) {
    const auto end = text.find('\n');
    const std::string_view raw = text.substr(0, end);
    text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
    ++line_number;
    const std::string_view line = withoutComment(raw);
    if (line.empty()) continue;
    const auto where = origin + " line " + std::to_string(line_number);
    std::istringstream fields{std::string(line)};
    std::string name, role, token, extra;
    fields >> name >> role >> token;
    if (token.empty() || (fields >> extra)) {
      throw std::runtime_error(where + ": expected NAME ROLE TOKEN");
    }
    Entry entry;
    entry.grant.name = name;
    if (role == "read") {
      entry.grant.role = Role::kRead;
    } else if (role == "record") {
      entry.grant.role = Role::kRecord;
    } else {
      throw std::runtime_error(where + ": role must be read or record, got '" + role + "'");
    }
    if (token.size() < kMinTokenLength || !printableWithoutBlanks(token)) {
      throw std::runtime_error(where + ": a token needs at least " +
                               std::to_string(kMinTokenLength) +
                               " printable characters (e.g. `openssl rand -hex 24`)");
    }
    for (const auto& other : tokens.entries_) {
      if (other.token == token) throw std::runtime_error(where + ": token repeated");
    }
    entry.token = std::move(token);
    tokens.entries_.push_back(std::move(entry));
  }
  if (tokens.entries_.empty()) throw std::runtime_error(origin + " holds no token");
  return tokens;
}

std::optional<TokenGrant> AccessTokens::find(std::string_view token) const {
  std::optional<TokenGrant> found;
  for (const auto& entry : entries_) {
    if (constantTimeEqual(entry.token, token) && !found) found = entry.grant;
  }
  return found;
}

std::string readClientToken(const fs::path& file) {
  const std::string text = readPrivateFile(file, /*require_private=*/false);
  std::string_view rest = text;
  while (!rest.empty()) {
    const auto end = rest.find('\n');
    const std::string_view line = withoutComment(rest.substr(0, end));
    if (!line.empty()) return std::string(line);
    rest = end == std::string_view::npos ? std::string_view{} : rest.substr(end + 1);
  }
  throw std::runtime_error("token file " + file.string() + " holds no token");
}

}  // namespace shapesense
