#include "shapesense/server/recording_root.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <string_view>
#include <system_error>

namespace shapesense {
namespace {

namespace fs = std::filesystem;

bool isInside(const fs::path& path, const fs::path& root) {
  return std::mismatch(root.begin(), root.end(), path.begin(), path.end()).first == root.end();
}

/// EACCES (mode bits), EPERM (an immutable directory, a sandbox, an ACL) and EROFS all mean the
/// daemon's user may not write there: what the client can fix is where it records, or the
/// directory's permissions, so PERMISSION_DENIED; anything else is the machine's state.
bool notPermitted(const std::error_code& error) {
  return error == std::errc::permission_denied || error == std::errc::operation_not_permitted ||
         error == std::errc::read_only_file_system;
}

grpc::Status cannotUse(const std::string& what, const fs::path& dir, const std::error_code& error) {
  if (notPermitted(error)) {
    return {grpc::StatusCode::PERMISSION_DENIED,
            "the daemon may not " + what + " '" + dir.string() + "' (" + error.message() +
                "): check the permissions of its recordings root (shapesensed --record-root)"};
  }
  return {grpc::StatusCode::FAILED_PRECONDITION,
          "cannot " + what + " '" + dir.string() + "' on the daemon's machine: " + error.message()};
}

grpc::Status cannotCreate(const fs::path& dir, const std::error_code& error) {
  return cannotUse("create", dir, error);
}

std::error_code lastError() { return {errno, std::generic_category()}; }

}  // namespace

std::uintmax_t availableBytes(const fs::path& path) { return fs::space(path).available; }

fs::path defaultRecordRoot() {
  if (const char* state = std::getenv("STATE_DIRECTORY"); state && *state) {
    // Several directories are separated by ':'; the first is ours.
    const std::string_view directories(state);
    return fs::path(directories.substr(0, directories.find(':'))) / "recordings";
  }
  if (const char* xdg = std::getenv("XDG_STATE_HOME"); xdg && *xdg) {
    return fs::path(xdg) / "shapesense" / "recordings";
  }
  const char* home = std::getenv("HOME");
  return fs::path(home && *home ? home : "/tmp") / ".local" / "state" / "shapesense" / "recordings";
}

grpc::Status makeRecordingDir(const fs::path& root, const std::string& name, fs::path& dir) {
  if (name.empty()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "dir is empty: name a new directory under the daemon's recordings root"};
  }
  const fs::path relative(name);
  if (relative.has_root_path()) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "dir '" + name +
                "' is absolute: give a name relative to the daemon's recordings root "
                "(shapesensed --record-root), e.g. desk-1"};
  }
  for (const auto& part : relative) {
    if (part == "..") {
      return {grpc::StatusCode::INVALID_ARGUMENT,
              "dir '" + name + "' contains '..': it must stay under the recordings root"};
    }
  }
  std::error_code error;
  const fs::path real_root = fs::canonical(root, error);
  if (error || !fs::is_directory(real_root)) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "the daemon's recordings root " + root.string() +
                " does not exist (shapesensed --record-root)"};
  }
  fs::path current = real_root;
  for (const auto& part : relative) {
    if (part.empty() || part == ".") continue;
    const fs::path next = current / part;
    struct stat info {};
    if (::lstat(next.c_str(), &info) != 0) {
      if (errno != ENOENT) return cannotCreate(next, lastError());
      // mkdir, not create_directories: exactly this one directory, inside the root.
      if (::mkdir(next.c_str(), 0750) != 0 && errno != EEXIST)
        return cannotCreate(next, lastError());
      if (::lstat(next.c_str(), &info) != 0) return cannotCreate(next, lastError());
    }
    fs::path resolved = next;
    if (S_ISLNK(info.st_mode)) {
      resolved = fs::canonical(next, error);
      if (error || !isInside(resolved, real_root)) {
        return {grpc::StatusCode::PERMISSION_DENIED,
                "dir '" + name + "': " + next.string() +
                    " is a symbolic link that leads out of the recordings root"};
      }
    }
    if (!fs::is_directory(resolved, error)) {
      return {grpc::StatusCode::FAILED_PRECONDITION,
              "'" + next.string() + "' exists and is not a directory"};
    }
    current = resolved;
  }
  if (current == real_root) {
    return {grpc::StatusCode::INVALID_ARGUMENT,
            "dir '" + name + "' names the recordings root itself: name a directory under it"};
  }
  const bool empty = fs::is_empty(current, error);
  if (error) return cannotUse("read", current, error);
  if (!empty) {
    return {grpc::StatusCode::FAILED_PRECONDITION,
            "'" + current.string() + "' is not empty: choose a new directory (or empty this one)"};
  }
  // An existing directory the daemon may not write would fail at the first frame, or never
  // (no frame came): refuse it now.
  if (::access(current.c_str(), W_OK | X_OK) != 0)
    return cannotUse("write into", current, lastError());
  dir = current;
  return grpc::Status::OK;
}

}  // namespace shapesense
