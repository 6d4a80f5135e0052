#pragma once
// Bearer tokens and the roles they grant. The daemon reads them from a token file at startup;
// every call then carries `authorization: Bearer TOKEN` and is admitted by CallAuthenticator
// (transport_security.h) according to the token's role.
//
// Token file: one token per line, `NAME ROLE TOKEN` separated by blanks; `#` starts a comment.
// NAME labels the client in the log, ROLE is `read` (queries and streams) or `record` (also
// Record and TeachObject, which write files), TOKEN is at least kMinTokenLength printable
// characters. The file must not be readable by group or others: a token file others can read is
// a leaked token file.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace shapesense {

enum class Role { kRead, kRecord };

const char* toString(Role role);

/// The role a method of shapesense.v1.ShapeSense (or of the health and reflection services)
/// needs, from its full path, e.g. "/shapesense.v1.ShapeSense/Record" -> kRecord.
Role requiredRole(std::string_view method_path);

/// True when `granted` allows what `needed` does (record includes read).
bool allows(Role granted, Role needed);

struct TokenGrant {
  std::string name;
  Role role = Role::kRead;
};

class AccessTokens {
 public:
  static constexpr std::size_t kMinTokenLength = 16;

  /// Reads a token file. Throws std::runtime_error naming the file and line for a file that
  /// cannot be read, is readable by group or others, is empty, or has a malformed line.
  static AccessTokens load(const std::filesystem::path& file);
  /// Parses the text of a token file; `origin` names it in error messages.
  static AccessTokens parse(std::string_view text, const std::string& origin);

  /// The grant of `token`, or nothing. Compares in time independent of where tokens differ.
  std::optional<TokenGrant> find(std::string_view token) const;

  std::size_t size() const { return entries_.size(); }

 private:
  struct Entry {
    TokenGrant grant;
    std::string token;
  };
  std::vector<Entry> entries_;
};

/// The token a client sends: the first line of `file` that is neither blank nor a comment,
/// without surrounding blanks. Throws std::runtime_error naming the file when there is none.
std::string readClientToken(const std::filesystem::path& file);

}  // namespace shapesense
