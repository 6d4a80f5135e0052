#pragma once
// Where the Record RPC may write, and how much. Every recording is a directory under one root
// (--record-root; the unit's StateDirectory). A client names it relative to the root; the name
// cannot climb out (`..`), start elsewhere (an absolute path) or pass through a symbolic link
// that leads out, and only directories inside the root are ever created.

#include <cstdint>
#include <filesystem>
#include <string>

#include <grpcpp/support/status.h>

namespace shapesense {

/// std::filesystem::space(path).available; throws std::filesystem::filesystem_error.
std::uintmax_t availableBytes(const std::filesystem::path& path);

struct RecordLimits {
  /// The recordings root; empty: this daemon does not record (Record answers
  /// FAILED_PRECONDITION).
  std::filesystem::path root;
  /// A recording stops (RESOURCE_EXHAUSTED) when the root's file system has less free space;
  /// none starts below it.
  std::uint64_t min_free_bytes = 1024ull << 20;
  /// Longest recording a client may ask for.
  double max_seconds = 600.0;
  /// Bytes available to the daemon on the file system holding a path; tests replace it.
  std::uintmax_t (*free_bytes)(const std::filesystem::path&) = &availableBytes;
};

/// The recordings root when --record-root is not given: $STATE_DIRECTORY/recordings under
/// systemd (StateDirectory=), else $XDG_STATE_HOME or ~/.local/state, /shapesense/recordings.
std::filesystem::path defaultRecordRoot();

/// Resolves the client's `name` under `root` and creates the directories it names that do not
/// exist yet (inside the root only). On OK `dir` is the recording's directory, absolute,
/// existing and empty. INVALID_ARGUMENT: name empty, absolute, with a `..` component, or naming
/// the root itself; PERMISSION_DENIED: a symbolic link on the way leads out of the root, or the
/// daemon's user may not create, read or write a directory on the way (EACCES, EPERM, EROFS);
/// FAILED_PRECONDITION: the root is missing, or something on the way exists and is not a
/// directory, or the directory is not empty, or another file-system error.
grpc::Status makeRecordingDir(const std::filesystem::path& root, const std::string& name,
                              std::filesystem::path& dir);

}  // namespace shapesense
