#pragma once
// Depth preprocessing for the bowl detector, as in the seed (D4.6.2 section 3.2): invalid
// pixels are filled by a recursive median filter [Lai11], then depth is mapped linearly from
// [near_m, far_m] to the 8-bit range [low, high] (the seed: 0.5-3 m -> 2..255).
//
// The seed's 8-bit mapping has ~1 cm steps (2.5 m / 253), coarser than the Kinect's own
// quantisation near 1 m (3 mm), so the range is a parameter: a model records the mapping it
// was trained with and the detector applies the same one.

#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

namespace shapesense {

/// Parameters of preprocessDepth. Defaults reproduce the seed.
struct DepthPreprocessParams {
  double near_m = 0.5;  ///< depth mapped to `low` (nearer readings clamp). Default 0.5.
  double far_m = 3.0;   ///< depth mapped to `high` (farther readings clamp). Default 3.0.
  int low = 2;          ///< 8-bit value of near_m. Default 2 (the seed keeps 0-1 free).
  int high = 255;       ///< 8-bit value of far_m. Default 255.
  /// Passes of the recursive median fill (each pass alternates raster direction). A raster
  /// pass already propagates into large holes because filled pixels feed the next ones, so
  /// two passes fill any hole touching a valid pixel. Default 2.
  int fill_passes = 2;
  /// 8-bit value for pixels still invalid after filling (an image with no depth at all):
  /// treated as far. Default 255.
  int unfilled_value = 255;
};

/// Fills the zero (invalid) pixels of a CV_16UC1 depth image in place with the median of the
/// valid (or already filled) values among their 8 neighbours, scanning forward then backward
/// for `passes` passes ("recursive": a pixel filled earlier in a pass is a neighbour like any
/// valid one). Pixels with no valid neighbour in a pass wait for the next pass. Returns the
/// number of pixels still invalid.
int fillInvalidRecursiveMedian(cv::Mat& depth_mm, int passes);

/// The 8-bit mapping of one DepthPreprocessParams as a table over all 65536 depth values, built
/// once: building it costs about as much as mapping a whole 640x480 frame, so a caller that maps
/// every frame with the same parameters (the detector) keeps one instead of rebuilding it.
class DepthTo8BitMap {
 public:
  /// Throws std::invalid_argument for an empty or inverted range.
  explicit DepthTo8BitMap(const DepthPreprocessParams& params);
  /// Maps a CV_16UC1 millimetre depth image to CV_8UC1 (linear, clamped; 0 -> unfilled_value).
  cv::Mat operator()(const cv::Mat& depth_mm) const;
  const DepthPreprocessParams& params() const { return params_; }
  /// The table: element v is the 8-bit value of depth v mm.
  const std::vector<std::uint8_t>& table() const { return lut_; }

 private:
  /// The same mapping in fixed point, run in vectors; found at construction, and only kept
  /// when it gives every value of the table (else null: the table maps).
  struct FixedPoint;
  DepthPreprocessParams params_;
  std::vector<std::uint8_t> lut_;
  std::shared_ptr<const FixedPoint> fixed_point_;
};

/// fillInvalidRecursiveMedian (on a copy, map.params().fill_passes) then the 8-bit mapping. If
/// `filled_mm` is not null it receives the filled millimetre image (used by the detector's depth
/// gate).
cv::Mat preprocessDepth(const cv::Mat& depth_mm, const DepthTo8BitMap& map,
                        cv::Mat* filled_mm = nullptr);

}  // namespace shapesense
