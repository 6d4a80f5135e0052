// PLY point clouds as untrusted input: what a writer produces reads back exactly, hand-written
// ascii and binary files with extra properties and elements read, and every malformed file is a
// PlyFileError naming the file and the problem, before anything is allocated for it.

#include "shapesense/driver/ply_cloud.h"

#include <sys/stat.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::scratchDir;

void writeBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << bytes;
  ASSERT_TRUE(out.good()) << file;
}

template <typename T>
void append(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  bytes.append(raw, sizeof(T));
}

// The message of the PlyFileError that loading `file` throws ("" when it loads).
std::string loadError(const fs::path& file, std::size_t max_points = 5'000'000) {
  try {
    loadPlyCloud(file, max_points);
  } catch (const PlyFileError& e) {
    return e.what();
  }
  return "";
}

// The message of the PlyFileError that parsing `bytes` throws ("" when it parses).
std::string parseError(const std::string& bytes, std::size_t max_points = 5'000'000) {
  try {
    parsePlyCloud(bytes, "cloud.ply", max_points);
  } catch (const PlyFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cloud.ply: "));
    return e.what();
  }
  return "";
}

const std::string kXyzHeader =
    "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
    "property float z\nend_header\n";

TEST(PlyCloud, WhatSaveWritesLoadsBackExactly) {
  const fs::path dir = scratchDir("ply_round_trip");
  PointCloudFile cloud;
  for (int i = 0; i < 10'000; ++i) {  // more than one read chunk
    cloud.points.emplace_back(0.001f * i, -1.5f + 1e-7f * i, 3.25f);
    cloud.normals.push_back(Eigen::Vector3f(i, 1, -2).normalized());
  }
  savePlyCloud(dir / "with_normals.ply", cloud);
  const PointCloudFile back = loadPlyCloud(dir / "with_normals.ply");
  EXPECT_EQ(back.points, cloud.points);
  EXPECT_EQ(back.normals, cloud.normals);

  cloud.normals.clear();
  savePlyCloud(dir / "points.ply", cloud);
  const PointCloudFile points = loadPlyCloud(dir / "points.ply");
  EXPECT_EQ(points.points, cloud.points);
  EXPECT_TRUE(points.normals.empty());
  EXPECT_EQ(fs::file_size(dir / "points.ply"),
            fs::file_size(dir / "with_normals.ply") - 10'000 * 12 - 3 * 18);  // 3 lines fewer

  savePlyCloud(dir / "empty.ply", PointCloudFile{});
  EXPECT_TRUE(loadPlyCloud(dir / "empty.ply").points.empty());
}

TEST(PlyCloud, SavingNormalsThatAreNotOnePerPointIsRefused) {
  PointCloudFile cloud;
  cloud.points.resize(3, Eigen::Vector3f::Zero());
  cloud.normals.resize(2, Eigen::Vector3f::UnitZ());
  EXPECT_THROW(savePlyCloud(scratchDir("ply_bad_save") / "c.ply", cloud), std::invalid_argument);
}

TEST(PlyCloud, ReadsAnAsciiFileWrittenByHand) {
  const fs::path file = scratchDir("ply_ascii") / "hand.ply";
  writeBytes(file,
             "ply\r\n"
             "format ascii 1.0\r\n"
             "comment made by hand, with CRLF line ends\r\n"
             "obj_info scanner none\r\n"
             "element vertex 3\r\n"
             "property double x\r\n"
             "property double y\r\n"
             "property double z\r\n"
             "property uchar red\r\n"
             "property float nx\r\n"
             "property float ny\r\n"
             "property float nz\r\n"
             "element face 1\r\n"
             "property list uchar int vertex_indices\r\n"
             "end_header\r\n"
             "0 0 1 255 0 0 -1\r\n"
             "1.5 -2.25e-1 2\t7 0 1 0\r\n"
             "  -3 4 5   9 1 0 0\r\n"
             "3 0 1 2\r\n");
  const PointCloudFile cloud = loadPlyCloud(file);
  ASSERT_EQ(cloud.points.size(), 3u);
  ASSERT_EQ(cloud.normals.size(), 3u);
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(1.5f, -0.225f, 2.0f));
  EXPECT_EQ(cloud.points[2], Eigen::Vector3f(-3, 4, 5));
  EXPECT_EQ(cloud.normals[0], Eigen::Vector3f(0, 0, -1));
  EXPECT_EQ(cloud.normals[1], Eigen::Vector3f(0, 1, 0));
}

TEST(PlyCloud, ReadsABinaryFileWithOtherPropertiesAndElements) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\n"
      "element camera 1\nproperty float fx\nproperty uint16 id\n"  // before the vertices
      "element vertex 2\n"
      "property uchar red\nproperty float64 x\nproperty float64 y\nproperty float64 z\n"
      "property int confidence\n"
      "element face 1\nproperty list uchar int vertex_indices\n"
      "end_header\n";
  append(bytes, 525.0f);
  append<std::uint16_t>(bytes, 7);
  for (const double v : {1.0, 2.0}) {
    append<std::uint8_t>(bytes, 200);
    append(bytes, v);
    append(bytes, -v);
    append(bytes, 0.5 * v);
    append<std::int32_t>(bytes, -1);
  }
  append<std::uint8_t>(bytes, 3);  // a face, never read
  const PointCloudFile cloud = parsePlyCloud(bytes, "binary.ply");
  ASSERT_EQ(cloud.points.size(), 2u);
  EXPECT_TRUE(cloud.normals.empty());
  EXPECT_EQ(cloud.points[0], Eigen::Vector3f(1, -1, 0.5f));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3f(2, -2, 1));
}

TEST(PlyCloud, VerticesWithoutAFiniteCoordinateAreLeftOut) {
  const PointCloudFile cloud = parsePlyCloud(kXyzHeader + "nan 0 1\n1 2 3\n", "nan.ply");
  ASSERT_EQ(cloud.points.size(), 1u);
  EXPECT_EQ(cloud.points[0], Eigen::Vector3f(1, 2, 3));
  // A double beyond float's range is not a finite float.
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
      "property double y\nproperty double z\nend_header\n";
  for (const double v : {1e300, 0.0, 0.0}) append(bytes, v);
  EXPECT_TRUE(parsePlyCloud(bytes, "huge.ply").points.empty());
}

TEST(PlyCloud, ATruncatedFileIsAnErrorNamingIt) {
  const fs::path dir = scratchDir("ply_truncated");
  PointCloudFile cloud;
  cloud.points.resize(1000, Eigen::Vector3f(1, 2, 3));
  savePlyCloud(dir / "cut.ply", cloud);
  fs::resize_file(dir / "cut.ply", fs::file_size(dir / "cut.ply") - 6);  // half a vertex short
  const std::string error = loadError(dir / "cut.ply");
  EXPECT_THAT(error, HasSubstr((dir / "cut.ply").string()));
  EXPECT_THAT(error, HasSubstr("truncated"));

  EXPECT_THAT(parseError(kXyzHeader + "1 2 3\n"), HasSubstr("truncated"));
  EXPECT_THAT(parseError(kXyzHeader + "1 2 3\n4 5      \n"), HasSubstr("2 values instead of 3"));
  EXPECT_THAT(parseError("ply\nformat ascii 1.0\nelement vertex 1\n"), HasSubstr("no end_header"));
  EXPECT_THAT(parseError(""), HasSubstr("not a PLY file"));
}

TEST(PlyCloud, AnAbsurdVertexCountIsRefusedBeforeAnythingIsAllocated) {
  const auto header = [](const std::string& count) {
    return "ply\nformat binary_little_endian 1.0\nelement vertex " + count +
           "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  };
  EXPECT_THAT(parseError(header("18446744073709551615")), HasSubstr("more than the limit"));
  EXPECT_THAT(parseError(header("99999999999999999999999")), HasSubstr("not a number"));
  EXPECT_THAT(parseError(header("-1")), HasSubstr("not a number"));
  // Within the limit, but the file cannot hold them.
  EXPECT_THAT(parseError(header("4000000") + std::string(120, '\0')),
              HasSubstr("4000000 vertices, but only 120 bytes follow"));
  // The caller's limit.
  std::string ten = header("10");
  for (int i = 0; i < 30; ++i) append(ten, 1.0f);
  EXPECT_EQ(parseError(ten, 10), "");
  EXPECT_THAT(parseError(ten, 9), HasSubstr("10 vertices, more than the limit of 9"));
  // An element before the vertices that the file cannot hold either.
  EXPECT_THAT(parseError("ply\nformat binary_little_endian 1.0\nelement junk 4000000000000\n"
                         "property double a\nelement vertex 0\nproperty float x\n"
                         "property float y\nproperty float z\nend_header\n"),
              HasSubstr("truncated"));
}

TEST(PlyCloud, PropertiesOfTheWrongTypeAreRefused) {
  const auto with = [](const std::string& x_line) {
    return "ply\nformat ascii 1.0\nelement vertex 1\n" + x_line +
           "\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
  };
  EXPECT_EQ(parseError(with("property float32 x")), "");
  EXPECT_THAT(parseError(with("property uchar x")), HasSubstr("vertex property x is uchar"));
  EXPECT_THAT(parseError(with("property int32 x")), HasSubstr("must be float or double"));
  EXPECT_THAT(parseError(with("property float16 x")), HasSubstr("unknown property type"));
  EXPECT_THAT(parseError(with("property list uchar float x")), HasSubstr("a list"));
  EXPECT_THAT(parseError(with("property float q")), HasSubstr("lacks x, y or z"));
  EXPECT_THAT(parseError(with("property float y")), HasSubstr("two properties 'y'"));
  EXPECT_THAT(parseError(with("property float x\nproperty float nx")),
              HasSubstr("some of nx, ny, nz"));
  EXPECT_THAT(parseError(kXyzHeader + "1 2 3\n4 abc 6\n"), HasSubstr("'abc' is not a number"));
}

TEST(PlyCloud, MalformedHeadersAreRefused) {
  EXPECT_THAT(parseError("ply\nformat binary_big_endian 1.0\nend_header\n"),
              HasSubstr("binary_big_endian files are not supported"));
  EXPECT_THAT(parseError("ply\nformat ascii 2.0\nend_header\n"), HasSubstr("format"));
  EXPECT_THAT(parseError("ply\nelement vertex 0\nend_header\n"), HasSubstr("no format line"));
  EXPECT_THAT(parseError("ply\nformat ascii 1.0\nproperty float x\nend_header\n"),
              HasSubstr("line 3: a property before any element"));
  EXPECT_THAT(parseError("ply\nformat ascii 1.0\nelement face 0\n"
                         "property list float int vertex_indices\nend_header\n"),
              HasSubstr("count type must be an integer"));
  EXPECT_THAT(parseError("ply\nformat ascii 1.0\nelement face 0\nproperty int a\nend_header\n"),
              HasSubstr("no vertex element"));
  EXPECT_THAT(parseError("ply\nformat ascii 1.0\nvertex 3\nend_header\n"),
              HasSubstr("unknown header line 'vertex 3'"));
  EXPECT_THAT(parseError("ply\ncomment " + std::string(5000, 'x') + "\n"),
              HasSubstr("line 2 is longer than 1024 bytes"));
  EXPECT_THAT(parseError("ply\n" + std::string(100'000, 'x')), HasSubstr("line 2 is longer"));
  std::string long_header = "ply\nformat ascii 1.0\n";
  for (int i = 0; i < 1000; ++i) long_header += "comment " + std::string(100, 'c') + "\n";
  EXPECT_THAT(parseError(long_header), HasSubstr("header is longer than"));
  // A binary file with a list before the vertices: its length is unknown without reading it.
  EXPECT_THAT(parseError("ply\nformat binary_little_endian 1.0\nelement face 1\n"
                         "property list uchar int i\nelement vertex 0\nproperty float x\n"
                         "property float y\nproperty float z\nend_header\n"),
              HasSubstr("list property before the vertex data"));
  // Control bytes in a bad line are quoted escaped.
  EXPECT_THAT(parseError("ply\n\x1b[31mred\n"), HasSubstr("\\x1b[31mred"));
}

TEST(PlyCloud, OnlyRegularFilesAreRead) {
  const fs::path dir = scratchDir("ply_not_regular");
  std::string error = loadError(dir);
  EXPECT_THAT(error, HasSubstr(dir.string()));
  EXPECT_THAT(error, HasSubstr("is a directory"));
  EXPECT_THAT(loadError(dir / "missing.ply"), HasSubstr("cannot open"));
  // A FIFO without a writer is refused at once rather than waited on.
  ASSERT_EQ(::mkfifo((dir / "fifo.ply").c_str(), 0600), 0);
  EXPECT_THAT(loadError(dir / "fifo.ply"), HasSubstr("is a FIFO"));
}

}  // namespace
}  // namespace shapesense
