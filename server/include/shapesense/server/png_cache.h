#pragma once
// PNG encodings of a frame's images (depth, colour, plane and segment labels), kept for the last
// few asked for. Encoding a VGA image takes a query worker milliseconds, and clients that follow
// the scene ask for the newest processed frame's images many times over; each is encoded once.

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include <opencv2/core/mat.hpp>

namespace shapesense {

/// Which of a frame's images an encoding is of.
enum class FrameImage { kDepth, kRgb, kPlaneLabels, kSegmentLabels };

/// `image` as a PNG at compression level 1: higher levels gain little on depth and labels and
/// cost several times the time.
std::string encodePng(const cv::Mat& image);

class PngCache {
 public:
  static constexpr std::size_t kEntries = 8;

  /// The PNG of `image`, which is the `kind` image of the frame with this sequence and capture
  /// time: the kept encoding when there is one, else encoded now and kept in place of the
  /// encoding asked for least recently. Only for images the frame's key fixes (the frame itself
  /// and the detectors' results), not for ones computed per request.
  std::shared_ptr<const std::string> get(std::uint64_t sequence, std::int64_t timestamp_ns,
                                         FrameImage kind, const cv::Mat& image);

 private:
  struct Entry {
    std::uint64_t sequence = 0;
    std::int64_t timestamp_ns = 0;
    FrameImage kind = FrameImage::kDepth;
    std::shared_ptr<const std::string> png;  ///< null: the entry is free
    std::uint64_t last_used = 0;
  };
  std::mutex mutex_;
  std::array<Entry, kEntries> entries_;
  std::uint64_t uses_ = 0;
};

}  // namespace shapesense
