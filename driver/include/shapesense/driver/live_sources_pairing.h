#pragma once
// Pairs each depth image with the colour image nearest in capture time. The Kinect's depth and
// colour streams both run at 30 Hz but are not synchronised, so the best partner of a depth
// image may arrive after it: a depth image is held until a colour image at or after its time
// has been seen, or until images `max_offset` newer than it have arrived (no later partner can
// then be closer than the allowed offset), and released in order.

#include <chrono>
#include <cstddef>
#include <deque>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/frame.h"

namespace shapesense {

struct StampedImage {
  cv::Mat image;
  TimestampNs capture_ns = 0;
};

struct PairedImages {
  StampedImage depth;
  cv::Mat colour;  ///< empty when no colour image was within max_offset
};

struct PairingParams {
  /// Largest depth/colour capture-time difference that still pairs. Default 20 ms.
  std::chrono::nanoseconds max_offset = std::chrono::milliseconds(20);
  std::size_t colour_history = 8;  ///< colour images kept for pairing. Default 8.
  /// Depth images held at most; the oldest is released (unpaired if need be). Default 4.
  std::size_t max_pending_depth = 4;
};

/// Single-threaded; fed from the thread that receives the device's images.
class DepthColourPairer {
 public:
  explicit DepthColourPairer(PairingParams params = {}) : params_(params) {}

  /// Adds a colour image; returns the depth images it completes.
  std::vector<PairedImages> addColour(StampedImage colour);
  /// Adds a depth image; returns the depth images now complete (possibly this one).
  std::vector<PairedImages> addDepth(StampedImage depth);
  /// Releases everything held (e.g. the colour stream is off or the device was lost).
  std::vector<PairedImages> flush();
  /// Forgets everything (a new device session).
  void reset();

  std::size_t pendingDepth() const { return pending_.size(); }

 private:
  std::vector<PairedImages> release(bool all);
  PairedImages pair(StampedImage depth) const;

  PairingParams params_;
  std::deque<StampedImage> pending_;  // depth, in arrival order
  std::deque<StampedImage> colour_;   // recent colour, in arrival order
  TimestampNs newest_ns_ = 0;
  bool any_ = false;
};

}  // namespace shapesense
