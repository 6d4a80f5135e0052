#pragma once
// Per-pixel surface normals of an organised depth image from integral images (O(1) per pixel
// whatever the window size). Three estimators, as in the SRS "but_segmentation" design and PCL's
// IntegralImageNormalEstimation:
//  - kCovariance: smallest eigenvector of the covariance of the 3D points in a square window
//    (slowest, most precise; robust to holes),
//  - kAverage3dGradient: cross product of the horizontal and vertical 3D gradients of the
//    window-averaged point cloud,
//  - kAverageDepthChange: normal from the window-averaged depth derivatives dz/du, dz/dv and the
//    pinhole model (fastest, least precise: holes bias it).
// The window half-size grows with range (Kinect noise grows with z^2) and is clipped so that the
// window never contains a depth step: a step is a depth change between neighbouring valid pixels
// above max(max_depth_change_factor * z, depth_change_noise_steps *
// KinectNoiseModel::depthStep(z)); pixels within `min_radius_px` of a step, or without depth, get
// NaN normals.

#include <memory>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

enum class NormalMethod { kCovariance, kAverage3dGradient, kAverageDepthChange };

struct NormalParams {
  /// Estimator (see file comment). kAverage3dGradient is the default: within ~1 deg of the
  /// covariance method on planes at a fraction of its cost.
  NormalMethod method = NormalMethod::kAverage3dGradient;
  /// Window half-size in pixels at 1 m range (window is (2r+1)^2 pixels). Default 5.
  double smoothing_radius_px = 5.0;
  /// Scale the half-size linearly with range (r = smoothing_radius_px * z / 1 m) so the noise of
  /// the normal stays roughly constant with range. Default true.
  bool depth_dependent_smoothing = true;
  /// Bounds on the half-size after range scaling; windows smaller than min_radius_px (because a
  /// depth step or the image border is closer) give NaN. Defaults 2 and 20.
  int min_radius_px = 2;
  int max_radius_px = 20;
  /// Relative depth change between neighbouring pixels that counts as a depth step (PCL's
  /// "max depth change factor"): 0.02 = 2 cm per pixel at 1 m. Default 0.02.
  double max_depth_change_factor = 0.02;
  /// ...but never less than this many sensor quantisation steps (KinectNoiseModel), so that the
  /// 2.6 cm disparity steps of a far wall are not taken for depth steps. Default 3.
  double depth_change_noise_steps = 3.0;
  /// ...and, for depth input, never less than this many times the frame's own disparity noise
  /// (disparityNoisePx), in quantisation steps: a fixed rule takes the noise of a noisy sensor
  /// at range for depth steps and leaves most pixels without a normal. Default 0 (the fixed
  /// rule alone); the plane detector's sample normals use 4 (defaultSampleNormalParams).
  double depth_change_noise_sigmas = 0.0;
  /// Steps are also detected across runs of up to this many invalid pixels (Kinect shadows
  /// separate foreground and background by a band of holes). Default 8.
  int max_gap_px = 8;
  /// Minimum fraction of valid pixels in a window. Default 0.3.
  double min_valid_fraction = 0.3;
  /// Sensor noise model used for the step threshold. Default Kinect v1.
  KinectNoiseModel noise{};
};

namespace detail {
struct NormalWorkspace;  // the estimator's reusable buffers (core/src/normals/normal_workspace.h)
}

/// Reusable estimator: keeps its point, step-map and integral-image buffers between frames, so
/// repeated calls on same-size frames allocate nothing. Copies share no buffers (a copy starts
/// with empty ones and the same parameters).
///
/// One call runs: the depth (or point) input to a z plane, the depth-step map (marks, then the
/// chessboard distance of every pixel to the nearest mark), then the estimator of
/// `params().method` over integral images, whose windows are bounded by that distance.
class NormalEstimator {
 public:
  explicit NormalEstimator(NormalParams params = {});
  NormalEstimator(const NormalEstimator& other);
  NormalEstimator& operator=(const NormalEstimator& other);
  NormalEstimator(NormalEstimator&&) noexcept;
  NormalEstimator& operator=(NormalEstimator&&) noexcept;
  ~NormalEstimator();

  const NormalParams& params() const { return params_; }
  void setParams(const NormalParams& params) { params_ = params; }

  /// `input` is a CV_16UC1 depth image in millimetres (0 = no reading) or a CV_32FC3 organised
  /// point cloud in metres (NaN or z <= 0 = invalid). Writes CV_32FC3 unit normals facing the
  /// camera (n . X < 0), NaN where invalid, into `normals` (reallocated only on size change).
  void compute(const cv::Mat& input, const CameraIntrinsics& intrinsics, cv::Mat& normals);

  /// The organised points (CV_32FC3, metres, NaN invalid) of the last compute() call (for depth
  /// input built on the first call after compute(): the gradient modes do not need them). The
  /// image is reused by the next compute(): copy it to keep it.
  const cv::Mat& points();

 private:
  NormalParams params_;
  std::unique_ptr<detail::NormalWorkspace> work_;
};

/// One-shot convenience wrapper around NormalEstimator.
cv::Mat computeNormals(const cv::Mat& points_or_depth, const CameraIntrinsics& intrinsics,
                       const NormalParams& params = {});

}  // namespace shapesense
