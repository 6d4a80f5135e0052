#include "shapesense/driver/bounded_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace shapesense {
namespace fs = std::filesystem;
namespace {

// Closes the descriptor on every path out of readRegularFile.
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

std::string fileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string tooLarge(const fs::path& file, std::size_t max_bytes) {
  return file.string() + ": larger than the " + std::to_string(max_bytes) +
         "-byte limit for this kind of file";
}

}  // namespace

std::string readRegularFile(const fs::path& file, std::size_t max_bytes) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer.
  FileDescriptor fd(::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  if (fd.get() < 0) {
    throw InputFileError(file.string() + ": cannot open (" + std::strerror(errno) + ")");
  }
  struct stat info {};
  if (::fstat(fd.get(), &info) != 0) {
    throw InputFileError(file.string() + ": cannot stat (" + std::strerror(errno) + ")");
  }
  if (!S_ISREG(info.st_mode)) {
    throw InputFileError(file.string() + ": is " + fileKind(info.st_mode) + ", not a regular file");
  }
  if (static_cast<std::uintmax_t>(info.st_size) > max_bytes) {
    throw InputFileError(tooLarge(file, max_bytes));
  }
  // The size may change while reading: never read past the limit, whatever stat said.
  std::string data(static_cast<std::size_t>(info.st_size), '\0');
  std::size_t used = 0;
  while (true) {
    if (used == data.size()) {
      if (used > max_bytes) throw InputFileError(tooLarge(file, max_bytes));
      data.resize(std::min(max_bytes + 1, std::max<std::size_t>(2 * used, 4096)));
    }
    const ssize_t got = ::read(fd.get(), data.data() + used, data.size() - used);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw InputFileError(file.string() + ": read error (" + std::strerror(errno) + ")");
    }
    if (got == 0) break;
    used += static_cast<std::size_t>(got);
  }
  data.resize(used);
  return data;
}

bool isPlainRelativePath(const fs::path& relative) {
  if (relative.empty() || relative.has_root_path()) return false;
  // Paths are echoed into logs and statuses: no terminal escapes or other control bytes.
  const std::string& text = relative.native();
  if (std::any_of(text.begin(), text.end(), [](char c) {
        const auto byte = static_cast<unsigned char>(c);
        return byte < 0x20 || byte == 0x7f;
      })) {
    return false;
  }
  for (const auto& part : relative) {
    if (part == "..") return false;
  }
  return true;
}

fs::path pathInside(const fs::path& root, const fs::path& relative) {
  const fs::path joined = root / relative;
  if (!isPlainRelativePath(relative)) {
    throw InputFileError(
        root.string() + ": the path " + quoteExcerpt(relative.string()) +
        " is not a plain path inside the recording (absolute, with '..' or control characters)");
  }
  std::error_code ec;
  const fs::path real_root = fs::weakly_canonical(root, ec);
  const fs::path real = ec ? fs::path() : fs::weakly_canonical(joined, ec);
  if (ec) throw InputFileError(joined.string() + ": cannot resolve (" + ec.message() + ")");
  const fs::path inside = real.lexically_relative(real_root);
  if (inside.empty() || *inside.begin() == "..") {
    throw InputFileError(joined.string() + ": a symlink leads out of the recording (to " +
                         quoteExcerpt(real.string()) + ")");
  }
  return joined;
}

std::string quoteExcerpt(std::string_view text, std::size_t max_chars) {
  std::string out = "'";
  const std::size_t shown = std::min(text.size(), max_chars);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\' && c != '\'') {
      out += static_cast<char>(c);
    } else {
      char escaped[5];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", c);
      out += escaped;
    }
  }
  out += '\'';
  if (shown < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

void forEachLine(std::string_view text,
                 const std::function<void(std::string_view line, int number)>& line_fn) {
  int number = 0;
  while (!text.empty()) {
    const auto end = text.find('\n');
    line_fn(text.substr(0, end), ++number);
    if (end == std::string_view::npos) break;
    text.remove_prefix(end + 1);
  }
}

}  // namespace shapesense
