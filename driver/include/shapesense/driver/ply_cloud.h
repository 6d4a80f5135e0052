#pragma once
// Point clouds in PLY files (object models, scans from other tools), read as untrusted input.
//
// Read: `format ascii 1.0` and `format binary_little_endian 1.0`; the element "vertex" with
// properties x, y, z and optionally nx, ny, nz (all three), each float or double (float32 /
// float64); its other properties (colour, confidence, ...) and every other element (faces,
// edges) are skipped. Elements after "vertex" are not read at all; one before it is skipped,
// which in a binary file needs it to have no list property. Big-endian files are refused.
//
// Bounded: only regular files (a directory, FIFO or device is refused before reading), a header
// of at most 64 KiB in lines of at most 1 KiB, at most `max_points` vertices, and no allocation
// for more vertices than the file's remaining bytes can hold. Anything malformed - an unknown
// format or type, a vertex count past the limit, x given as an integer, a line with too few or
// too many values, a body shorter than the header announces - throws PlyFileError naming the
// file and the problem; a file is never partly read into a result.
//
// Vertices with a non-finite coordinate (NaN marks a missing reading in organised scans) are
// left out, with their normals; every point returned is finite. Normals are returned as stored
// (not renormalised; a missing normal may be NaN).

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace shapesense {

/// A PLY file that cannot be read (or written); the message names the file and the problem.
class PlyFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PointCloudFile {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;  ///< one per point, or empty when the file has none
};

/// The vertex positions (and normals) of the PLY file at `file`, within the limits above.
/// Throws PlyFileError.
PointCloudFile loadPlyCloud(const std::filesystem::path& file, std::size_t max_points = 5'000'000);

/// The same reading of a file's bytes held in memory; `name` stands for the file in messages.
PointCloudFile parsePlyCloud(std::string_view bytes, const std::string& name,
                             std::size_t max_points = 5'000'000);

/// Writes `cloud` as binary little-endian PLY (float x, y, z and, when it has normals, float nx,
/// ny, nz), replacing `file`. Throws std::invalid_argument when normals are neither empty nor
/// one per point, PlyFileError when the file cannot be written.
void savePlyCloud(const std::filesystem::path& file, const PointCloudFile& cloud);

}  // namespace shapesense
