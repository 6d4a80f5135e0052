#pragma once
// Reading files of recordings, which may come from anywhere: regular files only, within a size
// limit, and inside the recording's folder. A FIFO, a device (/dev/zero), a directory, a file
// past its limit or a path leading out of the recording is an error naming the file, never a
// hang or an allocation past the limit.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace shapesense {

/// A recording file that cannot be read safely; the message names the file.
class InputFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The contents of `file` (symlinks followed), which must be a regular file of at most
/// `max_bytes`. Opening never blocks (a FIFO without a writer is refused at once). Throws
/// InputFileError naming the file otherwise.
std::string readRegularFile(const std::filesystem::path& file, std::size_t max_bytes);

/// Whether `relative` is a non-empty relative path without ".." components (lexically inside
/// whatever folder it is resolved against) and without control characters.
bool isPlainRelativePath(const std::filesystem::path& relative);

/// `root` / `relative`, checked to stay inside `root` once symlinks are resolved: throws
/// InputFileError when `relative` is not a plain relative path, or an existing symlink on the
/// way (or the file itself) leads out of `root`.
std::filesystem::path pathInside(const std::filesystem::path& root,
                                 const std::filesystem::path& relative);

/// `text` quoted for a log or status line: at most `max_chars` characters of it, control and
/// non-ASCII bytes escaped as \xNN, with the total length when it was cut. A malformed input line
/// may be megabytes long or hold terminal escapes; messages quote it only through this.
std::string quoteExcerpt(std::string_view text, std::size_t max_chars = 60);

/// Calls `line_fn(line, number)` for each line of `text` (1-based numbers, '\n' ends a line and
/// is not passed; a last line without '\n' counts, an empty text has no line), as std::getline
/// would split it.
void forEachLine(std::string_view text,
                 const std::function<void(std::string_view line, int number)>& line_fn);

}  // namespace shapesense
