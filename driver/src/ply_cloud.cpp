// PLY point clouds: a bounded reader of the header and the vertex element, over a file or bytes
// in memory, and a binary writer.

#include "shapesense/driver/ply_cloud.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "shapesense/driver/bounded_file.h"

namespace shapesense {
namespace {

static_assert(std::endian::native == std::endian::little,
              "binary_little_endian values are read by copying their bytes");

constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
constexpr std::size_t kMaxHeaderLine = 1024;
constexpr std::size_t kMaxBodyLine = 4096;  // an ascii vertex of 256 properties is far shorter
constexpr std::size_t kMaxElements = 64;
constexpr std::size_t kMaxProperties = 256;
constexpr std::size_t kBufferBytes = 64 * 1024;
constexpr std::size_t kVerticesPerChunk = 4096;

// A name or value from the file, quoted short: a message names two of them at most and stays a
// status line.
std::string shortQuote(std::string_view text) { return quoteExcerpt(text, 40); }

// Where the bytes come from: a file or memory.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// Up to n bytes into dst; 0 at the end.
  virtual std::size_t readSome(char* dst, std::size_t n) = 0;
  /// The bytes still to come, as far as known: counts in the header are checked against it
  /// before anything is allocated for them.
  virtual std::uint64_t remaining() const = 0;
};

class MemorySource final : public ByteSource {
 public:
  explicit MemorySource(std::string_view bytes) : bytes_(bytes) {}
  std::size_t readSome(char* dst, std::size_t n) override {
    n = std::min(n, bytes_.size());
    if (n > 0) std::memcpy(dst, bytes_.data(), n);
    bytes_.remove_prefix(n);
    return n;
  }
  std::uint64_t remaining() const override { return bytes_.size(); }

 private:
  std::string_view bytes_;
};

std::string fileKind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

class FileSource final : public ByteSource {
 public:
  explicit FileSource(const std::filesystem::path& file) : name_(file.string()) {
    // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer.
    fd_ = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd_ < 0) throw PlyFileError(name_ + ": cannot open (" + std::strerror(errno) + ")");
    struct stat info {};
    if (::fstat(fd_, &info) != 0) fail(std::string("cannot stat (") + std::strerror(errno) + ")");
    if (!S_ISREG(info.st_mode)) fail("is " + fileKind(info.st_mode) + ", not a regular file");
    size_ = static_cast<std::uint64_t>(info.st_size);
  }
  ~FileSource() override { ::close(fd_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;

  std::size_t readSome(char* dst, std::size_t n) override {
    while (true) {
      const ssize_t got = ::read(fd_, dst, n);
      if (got >= 0) {
        consumed_ += static_cast<std::uint64_t>(got);
        return static_cast<std::size_t>(got);
      }
      if (errno != EINTR) throw PlyFileError(name_ + ": read error (" + std::strerror(errno) + ")");
    }
  }
  std::uint64_t remaining() const override { return size_ > consumed_ ? size_ - consumed_ : 0; }

 private:
  [[noreturn]] void fail(const std::string& problem) {
    ::close(fd_);
    throw PlyFileError(name_ + ": " + problem);
  }

  std::string name_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
  std::uint64_t consumed_ = 0;
};

// Lines and byte runs from a source, through a buffer of fixed size.
class Reader {
 public:
  Reader(ByteSource& source, std::string name)
      : source_(source), name_(std::move(name)), buffer_(kBufferBytes) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw PlyFileError(name_ + ": " + problem);
  }
  [[noreturn]] void failAtLine(const std::string& problem) const {
    fail("line " + std::to_string(line_number_) + ": " + problem);
  }

  std::uint64_t remaining() const { return (end_ - pos_) + source_.remaining(); }

  /// The next line without its "\n" or "\r\n"; nullopt at the end of the bytes. Valid until the
  /// next call.
  std::optional<std::string_view> line(std::size_t max_length) {
    std::size_t scanned = 0;  // bytes after pos_ known to hold no '\n'
    while (true) {
      const char* begin = buffer_.data() + pos_;
      const auto* newline =
          static_cast<const char*>(std::memchr(begin + scanned, '\n', end_ - pos_ - scanned));
      if (newline != nullptr) return take(static_cast<std::size_t>(newline - begin), 1, max_length);
      scanned = end_ - pos_;
      if (scanned > max_length) lineTooLong(max_length);
      if (!fill()) {
        if (scanned == 0) return std::nullopt;
        return take(scanned, 0, max_length);
      }
    }
  }

  /// Exactly n bytes into dst.
  void bytes(char* dst, std::size_t n, const std::string& what) {
    const std::size_t buffered = std::min(n, end_ - pos_);
    if (buffered > 0) std::memcpy(dst, buffer_.data() + pos_, buffered);
    pos_ += buffered;
    for (std::size_t done = buffered; done < n;) {
      const std::size_t got = source_.readSome(dst + done, n - done);
      if (got == 0) fail("truncated: the file ends inside " + what);
      done += got;
    }
  }

 private:
  std::optional<std::string_view> take(std::size_t length, std::size_t terminator,
                                       std::size_t max_length) {
    if (length > max_length) lineTooLong(max_length);
    ++line_number_;
    std::string_view text(buffer_.data() + pos_, length);
    pos_ += length + terminator;
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    return text;
  }

  [[noreturn]] void lineTooLong(std::size_t max_length) {
    fail("line " + std::to_string(line_number_ + 1) + " is longer than " +
         std::to_string(max_length) + " bytes");
  }

  // Moves the unread bytes to the front and reads more behind them; false when none came.
  bool fill() {
    std::memmove(buffer_.data(), buffer_.data() + pos_, end_ - pos_);
    end_ -= pos_;
    pos_ = 0;
    if (end_ == buffer_.size()) return false;  // never: lines are far shorter than the buffer
    const std::size_t got = source_.readSome(buffer_.data() + end_, buffer_.size() - end_);
    end_ += got;
    return got > 0;
  }

  ByteSource& source_;
  std::string name_;
  std::vector<char> buffer_;
  std::size_t pos_ = 0;
  std::size_t end_ = 0;
  std::size_t line_number_ = 0;
};

// ---- The header ----

enum class Format { kAscii, kBinaryLittleEndian };

struct ScalarType {
  std::string_view name;
  std::size_t size;
  bool floating;
};

constexpr std::array<ScalarType, 16> kScalarTypes = {{
    {"char", 1, false},
    {"int8", 1, false},
    {"uchar", 1, false},
    {"uint8", 1, false},
    {"short", 2, false},
    {"int16", 2, false},
    {"ushort", 2, false},
    {"uint16", 2, false},
    {"int", 4, false},
    {"int32", 4, false},
    {"uint", 4, false},
    {"uint32", 4, false},
    {"float", 4, true},
    {"float32", 4, true},
    {"double", 8, true},
    {"float64", 8, true},
}};

struct Property {
  std::string name;
  ScalarType type;
  bool list = false;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  std::optional<Format> format;
  std::vector<Element> elements;
};

std::vector<std::string_view> tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

const ScalarType& scalarType(const Reader& r, std::string_view name) {
  for (const ScalarType& t : kScalarTypes)
    if (t.name == name) return t;
  r.failAtLine("unknown property type " + shortQuote(name));
}

void parseFormat(const Reader& r, const std::vector<std::string_view>& t, Header& header) {
  if (header.format) r.failAtLine("a second format line");
  if (t.size() != 3 || t[2] != "1.0") r.failAtLine("expected 'format <encoding> 1.0'");
  if (t[1] == "ascii") {
    header.format = Format::kAscii;
  } else if (t[1] == "binary_little_endian") {
    header.format = Format::kBinaryLittleEndian;
  } else if (t[1] == "binary_big_endian") {
    r.failAtLine("binary_big_endian files are not supported (ascii and binary_little_endian are)");
  } else {
    r.failAtLine("unknown format " + shortQuote(t[1]));
  }
}

void parseElement(const Reader& r, const std::vector<std::string_view>& t, Header& header) {
  if (t.size() != 3) r.failAtLine("expected 'element <name> <count>'");
  if (header.elements.size() == kMaxElements)
    r.failAtLine("more than " + std::to_string(kMaxElements) + " elements");
  Element element;
  element.name = std::string(t[1]);
  const auto [end, ec] = std::from_chars(t[2].data(), t[2].data() + t[2].size(), element.count);
  if (ec != std::errc() || end != t[2].data() + t[2].size())
    r.failAtLine("the count of element " + shortQuote(t[1]) +
                 " is not a number below 2^64: " + shortQuote(t[2]));
  header.elements.push_back(std::move(element));
}

void parseProperty(const Reader& r, const std::vector<std::string_view>& t, Header& header) {
  if (header.elements.empty()) r.failAtLine("a property before any element");
  Element& element = header.elements.back();
  if (element.properties.size() == kMaxProperties)
    r.failAtLine("more than " + std::to_string(kMaxProperties) + " properties in element " +
                 shortQuote(element.name));
  Property property;
  if (t.size() == 5 && t[1] == "list") {
    if (scalarType(r, t[2]).floating) r.failAtLine("a list's count type must be an integer type");
    property = {std::string(t[4]), scalarType(r, t[3]), true};
  } else if (t.size() == 3) {
    property = {std::string(t[2]), scalarType(r, t[1]), false};
  } else {
    r.failAtLine("expected 'property <type> <name>' or 'property list <type> <type> <name>'");
  }
  for (const Property& p : element.properties)
    if (p.name == property.name)
      r.failAtLine("element " + shortQuote(element.name) + " has two properties " +
                   shortQuote(property.name));
  element.properties.push_back(std::move(property));
}

Header readHeader(Reader& r) {
  const std::optional<std::string_view> magic = r.line(kMaxHeaderLine);
  if (!magic || *magic != "ply") r.fail("not a PLY file (the first line is not 'ply')");
  Header header;
  std::size_t header_bytes = magic->size() + 1;
  while (true) {
    const std::optional<std::string_view> line = r.line(kMaxHeaderLine);
    if (!line) r.fail("the header has no end_header line");
    header_bytes += line->size() + 1;
    if (header_bytes > kMaxHeaderBytes)
      r.fail("the header is longer than " + std::to_string(kMaxHeaderBytes) + " bytes");
    const std::vector<std::string_view> t = tokens(*line);
    if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "end_header" && t.size() == 1) break;
    if (t[0] == "format") {
      parseFormat(r, t, header);
    } else if (t[0] == "element") {
      parseElement(r, t, header);
    } else if (t[0] == "property") {
      parseProperty(r, t, header);
    } else {
      r.failAtLine("unknown header line " + shortQuote(*line));
    }
  }
  if (!header.format) r.fail("the header has no format line");
  return header;
}

// ---- The vertex element ----

// Where x, y, z (and nx, ny, nz) are among the vertex's properties.
struct VertexLayout {
  std::array<std::size_t, 6> property{};  ///< indices of x, y, z, nx, ny, nz
  bool normals = false;
  std::vector<std::size_t> offsets;  ///< binary: byte offset of each property in a vertex
  std::size_t stride = 0;            ///< binary: bytes per vertex
};

std::optional<std::size_t> findProperty(const Element& e, std::string_view name) {
  for (std::size_t i = 0; i < e.properties.size(); ++i)
    if (e.properties[i].name == name) return i;
  return std::nullopt;
}

std::size_t fixedStride(const Reader& r, const Element& e) {
  std::size_t stride = 0;
  for (const Property& p : e.properties) {
    if (p.list)
      r.fail("element " + shortQuote(e.name) +
             " has a list property before the vertex data of a binary file (not supported)");
    stride += p.type.size;
  }
  return stride;
}

VertexLayout vertexLayout(const Reader& r, const Element& vertex) {
  VertexLayout layout;
  constexpr std::array<std::string_view, 6> kNames = {"x", "y", "z", "nx", "ny", "nz"};
  std::array<std::optional<std::size_t>, 6> found;
  for (std::size_t i = 0; i < 6; ++i) {
    found[i] = findProperty(vertex, kNames[i]);
    if (!found[i]) continue;
    const Property& p = vertex.properties[*found[i]];
    if (p.list || !p.type.floating)
      r.fail("vertex property " + std::string(kNames[i]) + " is " +
             (p.list ? std::string("a list") : std::string(p.type.name)) +
             "; x, y, z, nx, ny, nz must be float or double");
  }
  if (!found[0] || !found[1] || !found[2]) r.fail("the vertex element lacks x, y or z");
  const int normals =
      static_cast<int>(found[3].has_value()) + found[4].has_value() + found[5].has_value();
  if (normals != 0 && normals != 3) r.fail("the vertex element has some of nx, ny, nz, not all");
  layout.normals = normals == 3;
  for (std::size_t i = 0; i < (layout.normals ? 6u : 3u); ++i) layout.property[i] = *found[i];
  for (const Property& p : vertex.properties) {
    if (p.list) r.fail("the vertex element has a list property (not supported)");
    layout.offsets.push_back(layout.stride);
    layout.stride += p.type.size;
  }
  return layout;
}

// The vertex count against the bytes that can hold it, before anything is allocated for it.
void checkVertexBytes(const Reader& r, const Element& vertex, const VertexLayout& layout,
                      Format format) {
  // An ascii value takes at least a digit and a separator (the last line may lack its '\n').
  const bool ascii = format == Format::kAscii;
  const std::uint64_t min_bytes = ascii ? 2 * vertex.properties.size() : layout.stride;
  if (vertex.count > (r.remaining() + (ascii ? 1 : 0)) / min_bytes)
    r.fail("truncated: the header announces " + std::to_string(vertex.count) +
           " vertices, but only " + std::to_string(r.remaining()) + " bytes follow");
}

void skipElement(Reader& r, const Element& e, Format format) {
  if (format == Format::kAscii) {
    for (std::uint64_t i = 0; i < e.count; ++i)
      if (!r.line(kMaxBodyLine))
        r.fail("truncated: the file ends inside element " + shortQuote(e.name));
    return;
  }
  const std::size_t stride = fixedStride(r, e);
  if (stride > 0 && e.count > r.remaining() / stride)
    r.fail("truncated: element " + shortQuote(e.name) + " needs more bytes than follow");
  std::vector<char> scratch(std::min<std::uint64_t>(kBufferBytes, e.count * stride));
  for (std::uint64_t left = e.count * stride; left > 0;) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, scratch.size()));
    r.bytes(scratch.data(), n, "element " + shortQuote(e.name));
    left -= n;
  }
}

// Adds the vertex unless a coordinate is not finite (as a float).
void addVertex(const std::array<double, 6>& v, bool normals, PointCloudFile& cloud) {
  const Eigen::Vector3f point(static_cast<float>(v[0]), static_cast<float>(v[1]),
                              static_cast<float>(v[2]));
  if (!point.allFinite()) return;
  cloud.points.push_back(point);
  if (normals)
    cloud.normals.emplace_back(static_cast<float>(v[3]), static_cast<float>(v[4]),
                               static_cast<float>(v[5]));
}

void readAsciiVertices(Reader& r, const Element& vertex, const VertexLayout& layout,
                       PointCloudFile& cloud) {
  std::vector<double> values(vertex.properties.size());
  for (std::uint64_t i = 0; i < vertex.count; ++i) {
    const std::optional<std::string_view> line = r.line(kMaxBodyLine);
    if (!line)
      r.fail("truncated: " + std::to_string(i) + " of " + std::to_string(vertex.count) +
             " vertices");
    const std::vector<std::string_view> t = tokens(*line);
    if (t.size() != values.size())
      r.failAtLine("a vertex of " + std::to_string(t.size()) + " values instead of " +
                   std::to_string(values.size()));
    for (std::size_t k = 0; k < t.size(); ++k) {
      const auto [end, ec] = std::from_chars(t[k].data(), t[k].data() + t[k].size(), values[k]);
      if (ec != std::errc() || end != t[k].data() + t[k].size())
        r.failAtLine(shortQuote(t[k]) + " is not a number");
    }
    std::array<double, 6> v{};
    for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) v[k] = values[layout.property[k]];
    addVertex(v, layout.normals, cloud);
  }
}

double binaryValue(const char* p, const Property& property) {
  if (property.type.size == 4) {
    float f;
    std::memcpy(&f, p, sizeof f);
    return f;
  }
  double d;
  std::memcpy(&d, p, sizeof d);
  return d;
}

void readBinaryVertices(Reader& r, const Element& vertex, const VertexLayout& layout,
                        PointCloudFile& cloud) {
  std::vector<char> chunk(std::min<std::uint64_t>(vertex.count, kVerticesPerChunk) * layout.stride);
  for (std::uint64_t done = 0; done < vertex.count;) {
    const std::size_t n =
        static_cast<std::size_t>(std::min<std::uint64_t>(vertex.count - done, kVerticesPerChunk));
    r.bytes(chunk.data(), n * layout.stride,
            "vertex " + std::to_string(done) + " of " + std::to_string(vertex.count));
    for (std::size_t i = 0; i < n; ++i) {
      const char* base = chunk.data() + i * layout.stride;
      std::array<double, 6> v{};
      for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) {
        const std::size_t p = layout.property[k];
        v[k] = binaryValue(base + layout.offsets[p], vertex.properties[p]);
      }
      addVertex(v, layout.normals, cloud);
    }
    done += n;
  }
}

PointCloudFile read(ByteSource& source, const std::string& name, std::size_t max_points) {
  Reader r(source, name);
  const Header header = readHeader(r);
  const Format format = *header.format;
  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) r.fail("the header has no vertex element");
  const VertexLayout layout = vertexLayout(r, *vertex);
  if (vertex->count > max_points)
    r.fail("the header announces " + std::to_string(vertex->count) +
           " vertices, more than the limit of " + std::to_string(max_points));
  for (auto e = header.elements.begin(); e != vertex; ++e) skipElement(r, *e, format);
  checkVertexBytes(r, *vertex, layout, format);
  PointCloudFile cloud;
  cloud.points.reserve(vertex->count);
  if (layout.normals) cloud.normals.reserve(vertex->count);
  if (format == Format::kAscii) {
    readAsciiVertices(r, *vertex, layout, cloud);
  } else {
    readBinaryVertices(r, *vertex, layout, cloud);
  }
  return cloud;
}

}  // namespace

PointCloudFile loadPlyCloud(const std::filesystem::path& file, std::size_t max_points) {
  FileSource source(file);
  return read(source, file.string(), max_points);
}

PointCloudFile parsePlyCloud(std::string_view bytes, const std::string& name,
                             std::size_t max_points) {
  MemorySource source(bytes);
  return read(source, name, max_points);
}

void savePlyCloud(const std::filesystem::path& file, const PointCloudFile& cloud) {
  const bool normals = !cloud.normals.empty();
  if (normals && cloud.normals.size() != cloud.points.size())
    throw std::invalid_argument("savePlyCloud: " + std::to_string(cloud.normals.size()) +
                                " normals for " + std::to_string(cloud.points.size()) + " points");
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw PlyFileError(file.string() + ": cannot open for writing");
  out << "ply\nformat binary_little_endian 1.0\ncomment written by shapesense\nelement vertex "
      << cloud.points.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) out << "property float nx\nproperty float ny\nproperty float nz\n";
  out << "end_header\n";
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    out.write(reinterpret_cast<const char*>(cloud.points[i].data()), 3 * sizeof(float));
    if (normals)
      out.write(reinterpret_cast<const char*>(cloud.normals[i].data()), 3 * sizeof(float));
  }
  out.flush();
  if (!out) throw PlyFileError(file.string() + ": write error");
}

}  // namespace shapesense
