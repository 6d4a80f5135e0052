#pragma once
// The buffers a NormalEstimator keeps between frames (so that same-size frames allocate
// nothing), grouped by the step that fills them. Internal to core/src/normals/.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace shapesense::detail {

/// The input as the estimators read it: a z plane, and either the pixel rays (depth input: the
/// points are z times the rays) or the point image itself.
struct NormalInput {
  int rows = 0, cols = 0;
  std::vector<float> z;       // z of every pixel (contiguous rows), NaN invalid
  std::vector<float> ray_x;   // depth input: (u - cx) / fx per column
  std::vector<float> ray_y;   // depth input: (v - cy) / fy per row
  bool from_depth = false;    // the points are z * (ray_x, ray_y, 1)
  cv::Mat points;             // CV_32FC3; depth input: built on demand by buildPoints()
  bool points_built = false;  // depth input: `points` holds this frame's points

  const float* zRow(int v) const { return z.data() + static_cast<std::size_t>(v) * cols; }
};

/// The depth-step map: one mark per step, and every pixel's distance to the nearest mark.
struct StepMap {
  cv::Mat marks;                       // CV_8UC1, 1 on one pixel of every depth step
  std::vector<std::int16_t> distance;  // chessboard distance to the nearest mark, capped
  std::vector<float> last_z;           // per column: z of the last valid pixel above
  std::vector<int> last_v;             // per column: its row
  std::vector<int> after_hole;         // the pixels of a row that follow a hole
};

/// The covariance mode's integral images.
struct CovarianceBuffers {
  std::vector<std::uint32_t> count;  // integral of the valid count
  std::vector<double> moments;       // integral of (x, y, z, xx, xy, xz, yy, yz, zz)
};

/// The gradient modes' integral-image ring, window-mean cache and per-row scratch.
struct GradientBuffers {
  std::vector<std::uint32_t> packed;          // ring of rows of the packed integral image
  std::vector<std::uint32_t*> integral_rows;  // each integral row's place in `packed`
  std::vector<std::uint32_t> elements;        // point input: one row's fixed-point elements
  std::vector<int> radius;                    // one row of window radii, 0 = no normal
  std::vector<int> min_count;                 // fewest valid pixels per window radius
  std::vector<float> column_bound;            // largest radius the image width allows per column
  std::vector<float> row_normal;              // one row of unnormalised normals (x, y, z planes)
  std::vector<float> inv_count;               // 1 / n for every window pixel count n
  std::vector<float> window_mean;             // window means of three rows of centres, planar
  std::vector<int> window_radius;             // the radius window_mean holds per centre, 0 = none
};

struct NormalWorkspace {
  NormalInput input;
  StepMap steps;
  CovarianceBuffers covariance;
  GradientBuffers gradient;
};

}  // namespace shapesense::detail
