// Recordings as untrusted input: every file is read within a size limit, only when regular,
// only from inside the recording, images are checked against camera.json before decoding, and
// problems quote a bad line short. Each test is a defect a recording could trigger before.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <future>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "recording_fixture.h"
#include "shapesense/driver/bounded_file.h"
#include "shapesense/driver/fakenect_dump.h"
#include "shapesense/driver/replay_source.h"
#include "synthetic_frames.h"
#include "test_paths.h"

namespace shapesense {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::RecordingBuilder;
using testing::scratchDir;

// Far longer than any of these reads takes; only a read that blocks reaches it.
constexpr std::chrono::seconds kHangGuard{60};
// A problem quoting a bad line stays a status line, whatever the line's length.
constexpr std::size_t kShortMessage = 400;

ReplayOptions fast() { return ReplayOptions{.pacing = Pacing::kAsFastAsPossible}; }

std::string cameraError(const std::string& name, const std::string& text) {
  const auto dir = scratchDir(name);
  testing::writeTextFile(dir / "camera.json", text);
  try {
    readRecordingCamera(dir);
  } catch (const CameraFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "camera.json").string()));
    return e.what();
  }
  ADD_FAILURE() << "camera.json " << text << " was accepted";
  return {};
}

TEST(BoundedCameraFile, FocalLengthsNoCameraHasAreRefused) {
  // fx = fy = 0.001 made EstimateBox mode 1 allocate gigabytes and crash the daemon.
  EXPECT_THAT(cameraError("camera_fx_milli", R"({"fx": 0.001, "fy": 0.001})"), HasSubstr("fx"));
  EXPECT_THAT(cameraError("camera_fx_tiny", R"({"fx": 1e-300, "fy": 1e-300})"), HasSubstr("fx"));
  EXPECT_THAT(cameraError("camera_fy_milli", R"({"fy": 0.001})"), HasSubstr("fy"));
  EXPECT_THAT(cameraError("camera_fx_huge", R"({"fx": 1e9})"), HasSubstr("fx"));
}

TEST(BoundedCameraFile, SidesMustBeWholeNumbersInRange) {
  // 2^31 does not fit an int: the conversion was undefined behaviour (on x86 it happened to
  // give a negative width, refused only by luck). The error now names the range.
  const auto width_error = cameraError("camera_width_2_31", R"({"width": 2147483648})");
  EXPECT_THAT(width_error, HasSubstr("width"));
  EXPECT_THAT(width_error, HasSubstr("16384"));
  const auto height_error = cameraError("camera_height_huge", R"({"height": 1e300})");
  EXPECT_THAT(height_error, HasSubstr("height"));
  EXPECT_THAT(height_error, HasSubstr("16384"));
  // 640.9 was silently truncated to 640.
  EXPECT_THAT(cameraError("camera_width_fraction", R"({"width": 640.9})"), HasSubstr("640.9"));
  EXPECT_THAT(cameraError("camera_height_negative", R"({"height": -480})"), HasSubstr("height"));
}

TEST(BoundedCameraFile, PrincipalPointAndDepthScaleMustBePhysical) {
  EXPECT_THAT(cameraError("camera_cx_outside", R"({"cx": 5000})"), HasSubstr("cx"));
  EXPECT_THAT(cameraError("camera_cy_negative", R"({"cy": -1})"), HasSubstr("cy"));
  EXPECT_THAT(cameraError("camera_scale_huge", R"({"depth_scale": 1e12})"),
              HasSubstr("depth_scale"));
  EXPECT_THAT(cameraError("camera_scale_tiny", R"({"depth_scale": 1e-9})"),
              HasSubstr("depth_scale"));
}

TEST(BoundedCameraFile, EveryRealRecordingsCameraIsAccepted) {
  for (const char* name :
       {"cape_room", "mosd_learn", "mosd_tabletop", "mosd_test", "pcl_desk_sequence", "pcl_office",
        "pcl_room_sweep", "pcl_tabletop_milk", "tum_fr2_desk"}) {
    const auto dir = testing::realRecording(name);
    if (!fs::exists(dir / "camera.json")) GTEST_SKIP() << "no shared/ recordings here";
    EXPECT_NO_THROW(readRecordingCamera(dir)) << name;
  }
}

TEST(BoundedCameraFile, WholeNumberWrittenAsFloatIsAccepted) {
  const auto dir = scratchDir("camera_width_float_whole");
  testing::writeTextFile(dir / "camera.json", R"({"width": 640.0, "height": 480.0})");
  EXPECT_EQ(readRecordingCamera(dir).intrinsics.width, 640);
}

// Runs `read` on another thread; if it blocks on `fifo`, opens the FIFO's write end so the read
// ends (and the test fails instead of hanging).
template <typename Read>
void expectNoHangOnFifo(const fs::path& fifo, Read read) {
  auto result = std::async(std::launch::async, read);
  if (result.wait_for(kHangGuard) != std::future_status::ready) {
    ADD_FAILURE() << "reading blocked on the FIFO " << fifo;
    const int writer = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (writer >= 0) ::close(writer);
  }
  result.get();
}

TEST(BoundedIndexFile, FifoDepthIndexIsRefusedWithoutBlocking) {
  const auto dir = scratchDir("index_fifo");
  ASSERT_EQ(::mkfifo((dir / "depth.txt").c_str(), 0600), 0);
  expectNoHangOnFifo(dir / "depth.txt", [&] {
    try {
      readTumIndex(dir);
      ADD_FAILURE() << "a FIFO depth.txt was read";
    } catch (const std::runtime_error& e) {
      EXPECT_THAT(e.what(), HasSubstr((dir / "depth.txt").string()));
      EXPECT_THAT(e.what(), HasSubstr("FIFO"));
    }
  });
}

TEST(BoundedIndexFile, FifoCameraFileIsRefusedWithoutBlocking) {
  const auto dir = scratchDir("camera_fifo");
  ASSERT_EQ(::mkfifo((dir / "camera.json").c_str(), 0600), 0);
  expectNoHangOnFifo(dir / "camera.json",
                     [&] { EXPECT_THROW(readRecordingCamera(dir), CameraFileError); });
}

TEST(BoundedIndexFile, IndexLinkedToDevZeroIsRefused) {
  const auto dir = scratchDir("index_dev_zero");
  fs::create_symlink("/dev/zero", dir / "depth.txt");
  try {
    readTumIndex(dir);
    ADD_FAILURE() << "depth.txt -> /dev/zero was read";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr((dir / "depth.txt").string()));
    EXPECT_THAT(e.what(), HasSubstr("character device"));
  }
}

TEST(BoundedIndexFile, IndexPastItsSizeLimitIsRefused) {
  const auto dir = scratchDir("index_too_large");
  {
    std::ofstream out(dir / "depth.txt");
    out << "# depth\n";
  }
  fs::resize_file(dir / "depth.txt", kMaxIndexFileBytes + 1);  // sparse: costs no disk
  try {
    readTumIndex(dir);
    ADD_FAILURE() << "an index past the limit was read";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("limit"));
  }
}

TEST(BoundedIndexFile, HugeLineIsQuotedShort) {
  // A 50 MB line used to go into the problems, GetStatus and the log whole.
  const auto dir = scratchDir("index_huge_line");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("1600000000.000000");
  builder.rawDepthLine("1600000000.100000 depth/" + std::string(50'000'000, 'x') + ".png");
  builder.finish();
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.problems.size(), 1u);
  EXPECT_LT(index.problems[0].size(), kShortMessage);
  EXPECT_THAT(index.problems[0], HasSubstr((dir / "depth.txt").string() + ":4"));
  EXPECT_THAT(index.problems[0], HasSubstr("bytes"));
  EXPECT_EQ(index.depth.size(), 1u);
}

TEST(BoundedIndexFile, ControlCharactersInABadLineAreEscaped) {
  const auto dir = scratchDir("index_escape");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("1600000000.000000");
  builder.rawDepthLine("\x1b[2Jnot a stamp");
  builder.finish();
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.problems.size(), 1u);
  EXPECT_THAT(index.problems[0], HasSubstr("\\x1b[2J"));
  EXPECT_EQ(index.problems[0].find('\x1b'), std::string::npos);
}

TEST(RecordingPaths, EntriesOutsideTheRecordingAreProblemsNotFiles) {
  const auto dir = scratchDir("index_outside") / "recording";
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("1600000000.000000");
  builder.rawDepthLine("1600000000.100000 /etc/passwd");
  builder.rawDepthLine("1600000000.200000 ../outside.png");
  builder.rawDepthLine("1600000000.300000 depth/../../outside.png");
  builder.rawDepthLine("1600000000.400000 depth/\x1b[31mred.png");
  builder.finish();
  const TumIndex index = readTumIndex(dir);
  ASSERT_EQ(index.problems.size(), 4u);
  EXPECT_THAT(index.problems[0], HasSubstr("/etc/passwd"));
  for (const auto& problem : index.problems) EXPECT_THAT(problem, HasSubstr("not a plain path"));
  EXPECT_EQ(index.depth.size(), 1u);
}

TEST(RecordingPaths, SymlinkOutOfTheRecordingIsNotFollowed) {
  const auto root = scratchDir("image_symlink_outside");
  const auto dir = root / "recording";
  RecordingBuilder builder(dir);
  builder.writeCamera();
  testing::writePng(root / "outside.png", testing::patternDepthUnits(8, 6, 1));
  fs::create_symlink(root / "outside.png", builder.depthPath("1600000000.000000"));
  builder.listDepthOnly("1600000000.000000");
  builder.finish();
  ReplaySource source(dir, fast());
  std::stop_source stop;
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_THAT(std::get<SourceError>(event).message, HasSubstr("out of the recording"));
}

TEST(RecordingPaths, SymlinkInsideTheRecordingIsFollowed) {
  const auto dir = scratchDir("image_symlink_inside");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  const cv::Mat units = testing::patternDepthUnits(8, 6, 1);
  testing::writePng(dir / "depth" / "store.png", units);
  fs::create_symlink("store.png", builder.depthPath("1600000000.000000"));
  builder.listDepthOnly("1600000000.000000");
  builder.finish();
  ReplaySource source(dir, fast());
  std::stop_source stop;
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<Frame>(event));
  EXPECT_EQ(std::get<Frame>(event).depth.size(), units.size());
}

TEST(RecordingImages, DepthLinkedToDevZeroIsAnErrorNotAnAllocation) {
  const auto dir = scratchDir("image_dev_zero");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  fs::create_symlink("/dev/zero", builder.depthPath("1600000000.000000"));
  builder.listDepthOnly("1600000000.000000");
  builder.finish();
  ReplaySource source(dir, fast());
  std::stop_source stop;
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_THAT(std::get<SourceError>(event).message,
              HasSubstr(builder.depthPath("1600000000.000000").string()));
}

TEST(RecordingImages, FifoDepthImageIsRefusedWithoutBlocking) {
  const auto dir = scratchDir("image_fifo");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  const auto fifo = builder.depthPath("1600000000.000000");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  builder.listDepthOnly("1600000000.000000");
  builder.finish();
  ReplaySource source(dir, fast());
  expectNoHangOnFifo(fifo, [&] {
    std::stop_source stop;
    auto event = source.next(stop.get_token());
    ASSERT_TRUE(std::holds_alternative<SourceError>(event));
    EXPECT_THAT(std::get<SourceError>(event).message, HasSubstr("FIFO"));
  });
}

// A real PNG header (with CRC) claiming width x height 16-bit grey, and one tiny IDAT: what a
// 2 MB file of a 32768 x 32768 image starts with, without writing 2 MB.
std::string pngClaiming(std::uint32_t width, std::uint32_t height) {
  std::string out("\x89PNG\r\n\x1a\n", 8);
  const auto chunk = [&](const std::string& type, const std::string& data) {
    const auto be32 = [&](std::uint32_t v) {
      for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((v >> shift) & 0xff);
    };
    be32(static_cast<std::uint32_t>(data.size()));
    const std::string typed = type + data;
    out += typed;
    be32(static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(typed.data()), static_cast<uInt>(typed.size()))));
  };
  std::string header;
  for (std::uint32_t v : {width, height}) {
    for (int shift = 24; shift >= 0; shift -= 8) header += static_cast<char>((v >> shift) & 0xff);
  }
  header += std::string("\x10\x00\x00\x00\x00", 5);  // 16-bit, greyscale, deflate, no interlace
  chunk("IHDR", header);
  const std::string zeros(4096, '\0');
  uLongf packed_size = compressBound(zeros.size());
  std::string packed(packed_size, '\0');
  compress(reinterpret_cast<Bytef*>(packed.data()), &packed_size,
           reinterpret_cast<const Bytef*>(zeros.data()), zeros.size());
  packed.resize(packed_size);
  chunk("IDAT", packed);
  chunk("IEND", "");
  return out;
}

TEST(RecordingImages, HugeImageIsRefusedFromItsHeaderBeforeDecoding) {
  // cv::imread of a 32768 x 32768 PNG allocated 2 GB before the size check.
  const auto dir = scratchDir("image_huge_header");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  testing::writeTextFile(builder.depthPath("1600000000.000000"), pngClaiming(32768, 32768));
  builder.listDepthOnly("1600000000.000000");
  builder.finish();
  ReplaySource source(dir, fast());
  std::stop_source stop;
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_THAT(std::get<SourceError>(event).message, HasSubstr("32768x32768"));
  EXPECT_THAT(std::get<SourceError>(event).message, HasSubstr("8x6"));
}

TEST(RecordingImages, ImageFileLargerThanItsCameraAllowsIsRefused) {
  const auto dir = scratchDir("image_too_large");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("1600000000.000000");
  fs::resize_file(builder.depthPath("1600000000.000000"), 8 * 1024 * 1024);
  builder.finish();
  ReplaySource source(dir, fast());
  std::stop_source stop;
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_THAT(std::get<SourceError>(event).message, HasSubstr("limit"));
}

TEST(ReplayTime, DepthStampsThatGoBackOrRepeatAreSkippedForEveryReplayer) {
  const auto dir = scratchDir("index_time_back");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  for (const char* stamp : {"1600000000.000000", "1600000000.200000", "1600000000.100000",
                            "1600000000.200000", "1600000000.300000"}) {
    builder.addDepth(stamp);
  }
  builder.finish();
  const TumIndex index = readTumIndex(dir);
  // Line 5 goes back; line 6 repeats the kept 0.2 (the daemon's cache refuses both).
  ASSERT_EQ(index.problems.size(), 2u);
  EXPECT_THAT(index.problems[0], HasSubstr("depth.txt:5"));
  EXPECT_THAT(index.problems[1], HasSubstr("depth.txt:6"));
  EXPECT_THAT(index.problems[1], HasSubstr("not after the kept line's 1600000000.200000"));
  ASSERT_EQ(index.depth.size(), 3u);
  EXPECT_EQ(index.depth[2].seconds_text, "1600000000.300000");
  ReplaySource source(dir, fast());
  EXPECT_EQ(source.frameCount(), 3u);
}

TEST(ReplayTime, LoopingPastTheClockEndsWithOneError) {
  // Stamps wrapped to the past, and the daemon logged every refused frame, forever.
  const auto dir = scratchDir("loop_clock_end");
  RecordingBuilder builder(dir);
  builder.writeCamera();
  builder.addDepth("9223372035.400000");
  builder.addDepth("9223372035.900000");
  builder.finish();
  ReplaySource source(dir, ReplayOptions{.pacing = Pacing::kAsFastAsPossible, .loop = true});
  std::stop_source stop;
  int frames = 0, errors = 0;
  TimestampNs last = std::numeric_limits<TimestampNs>::min();
  for (int i = 0; i < 100; ++i) {
    auto event = source.next(stop.get_token());
    if (std::holds_alternative<EndOfStream>(event)) break;
    if (auto* error = std::get_if<SourceError>(&event)) {
      ++errors;
      EXPECT_THAT(error->message, HasSubstr("end of the 64-bit nanosecond clock"));
      continue;
    }
    const TimestampNs stamp = std::get<Frame>(event).timestamp_ns;
    EXPECT_GT(stamp, last);
    last = stamp;
    ++frames;
  }
  // A pass (1 s long), then 9223372036.4; 9223372036.9 is past 9223372036.854775807.
  EXPECT_EQ(frames, 2 + 1);
  EXPECT_EQ(errors, 1);
  EXPECT_TRUE(std::holds_alternative<EndOfStream>(source.next(stop.get_token())));
}

TEST(BoundedFakenect, HugeIndexLineIsQuotedShort) {
  const auto dir = scratchDir("fakenect_huge_line");
  testing::writeTextFile(dir / "INDEX.txt", "d-" + std::string(50'000'000, '1') + "\n");
  const FakenectIndex index = readFakenectIndex(dir);
  ASSERT_EQ(index.problems.size(), 1u);
  EXPECT_LT(index.problems[0].size(), kShortMessage);
  const auto problems = validateFakenectDump(dir);
  ASSERT_FALSE(problems.empty());
  EXPECT_LT(problems[0].size(), kShortMessage);
}

TEST(BoundedFakenect, NamesOutOfTheDumpAreProblems) {
  const auto dir = scratchDir("fakenect_outside");
  testing::writeTextFile(dir / "INDEX.txt",
                         "d-1.0-5/../../../etc/passwd\nd-1.1-6.pgm\n/d-1.2-7.pgm\n");
  const FakenectIndex index = readFakenectIndex(dir);
  EXPECT_EQ(index.entries.size(), 1u);
  ASSERT_EQ(index.problems.size(), 2u);
  EXPECT_THAT(index.problems[0], HasSubstr("not a plain path inside the dump"));
  EXPECT_THAT(index.problems[1], HasSubstr("INDEX.txt:3"));
}

TEST(BoundedFakenect, DepthLinkedToDevZeroIsAnErrorNotAGrowingRead) {
  // The running daemon's memory grew without bound reading it.
  const auto dir = scratchDir("fakenect_dev_zero");
  writeFakenectDump(dir, testing::syntheticFrames(7, 1));
  const auto index = readFakenectIndex(dir);
  const fs::path depth = dir / index.entries.front().file_name;
  fs::remove(depth);
  fs::create_symlink("/dev/zero", depth);
  try {
    readFakenectDepth(depth);
    ADD_FAILURE() << "a depth file linked to /dev/zero was read";
  } catch (const InputFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("character device"));
  }
  FakenectDumpSource source(dir, FakenectDumpOptions{.pacing = Pacing::kAsFastAsPossible});
  std::stop_source stop;
  auto event = source.next(stop.get_token());
  ASSERT_TRUE(std::holds_alternative<SourceError>(event));
  EXPECT_THAT(std::get<SourceError>(event).message, HasSubstr(depth.string()));
  EXPECT_THAT(validateFakenectDump(dir), ::testing::Contains(HasSubstr(depth.string())));
}

TEST(BoundedFakenect, FifoIndexIsRefusedWithoutBlocking) {
  const auto dir = scratchDir("fakenect_fifo");
  ASSERT_EQ(::mkfifo((dir / "INDEX.txt").c_str(), 0600), 0);
  expectNoHangOnFifo(dir / "INDEX.txt", [&] {
    EXPECT_THROW(readFakenectIndex(dir), InputFileError);
    EXPECT_THAT(validateFakenectDump(dir), ::testing::ElementsAre(HasSubstr("FIFO")));
  });
}

TEST(QuoteExcerpt, CutsAndEscapes) {
  EXPECT_EQ(quoteExcerpt("abc"), "'abc'");
  EXPECT_EQ(quoteExcerpt("a\tb'\\"), "'a\\x09b\\x27\\x5c'");
  EXPECT_EQ(quoteExcerpt(std::string(100, 'x'), 3), "'xxx'... (100 bytes)");
}

TEST(ReadRegularFile, ReadsWithinTheLimitAndRefusesPastIt) {
  const auto dir = scratchDir("read_regular");
  testing::writeTextFile(dir / "f", "12345");
  EXPECT_EQ(readRegularFile(dir / "f", 5), "12345");
  EXPECT_THROW(readRegularFile(dir / "f", 4), InputFileError);
  EXPECT_THROW(readRegularFile(dir, 100), InputFileError);
  EXPECT_THROW(readRegularFile(dir / "missing", 100), InputFileError);
}

}  // namespace
}  // namespace shapesense
