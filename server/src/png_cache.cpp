#include "shapesense/server/png_cache.h"

#include <algorithm>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace shapesense {

std::string encodePng(const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
  return {bytes.begin(), bytes.end()};
}

std::shared_ptr<const std::string> PngCache::get(std::uint64_t sequence, std::int64_t timestamp_ns,
                                                 FrameImage kind, const cv::Mat& image) {
  {
    std::lock_guard lock(mutex_);
    for (Entry& entry : entries_) {
      if (entry.png && entry.sequence == sequence && entry.timestamp_ns == timestamp_ns &&
          entry.kind == kind) {
        entry.last_used = ++uses_;
        return entry.png;
      }
    }
  }
  // Encoded without the lock, so other frames' requests are not held up; two workers asking for
  // the same new image at once may both encode it, and the second copy replaces nothing useful.
  auto png = std::make_shared<const std::string>(encodePng(image));
  std::lock_guard lock(mutex_);
  Entry& slot =
      *std::min_element(entries_.begin(), entries_.end(),
                        [](const Entry& a, const Entry& b) { return a.last_used < b.last_used; });
  slot = Entry{sequence, timestamp_ns, kind, png, ++uses_};
  return png;
}

}  // namespace shapesense
