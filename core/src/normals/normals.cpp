#include "shapesense/core/normals/normals.h"

#include <algorithm>
#include <limits>

#include "normals/covariance_estimator.h"
#include "normals/gradient_estimator.h"
#include "normals/normal_input.h"
#include "normals/normal_workspace.h"
#include "normals/step_map.h"
#include "shapesense/core/geometry/disparity_noise.h"

namespace shapesense {
namespace {

// The parameters of this input's depth-step rule: depth_change_noise_sigmas applied to depth
// input.
NormalParams stepParams(const NormalParams& params, const cv::Mat& input) {
  if (params.depth_change_noise_sigmas <= 0.0 || input.type() != CV_16UC1) return params;
  NormalParams out = params;
  const double noise_steps = disparityNoisePx(input, params.noise) / params.noise.disparity_step_px;
  out.depth_change_noise_steps =
      std::max(params.depth_change_noise_steps, params.depth_change_noise_sigmas * noise_steps);
  return out;
}

}  // namespace

NormalEstimator::NormalEstimator(NormalParams params)
    : params_(params), work_(std::make_unique<detail::NormalWorkspace>()) {}

NormalEstimator::NormalEstimator(const NormalEstimator& other) : NormalEstimator(other.params_) {}

NormalEstimator& NormalEstimator::operator=(const NormalEstimator& other) {
  params_ = other.params_;
  return *this;
}

NormalEstimator::NormalEstimator(NormalEstimator&&) noexcept = default;
NormalEstimator& NormalEstimator::operator=(NormalEstimator&&) noexcept = default;
NormalEstimator::~NormalEstimator() = default;

const cv::Mat& NormalEstimator::points() {
  if (!work_) work_ = std::make_unique<detail::NormalWorkspace>();  // a moved-from estimator
  detail::buildPoints(work_->input);
  return work_->input.points;
}

void NormalEstimator::compute(const cv::Mat& input, const CameraIntrinsics& intrinsics,
                              cv::Mat& normals) {
  if (!work_) work_ = std::make_unique<detail::NormalWorkspace>();  // a moved-from estimator
  detail::NormalWorkspace& work = *work_;
  detail::loadInput(input, intrinsics, work.input);
  normals.create(input.rows, input.cols, CV_32FC3);
  if (input.rows == 0 || input.cols == 0) return;  // no pixel (the row scans assume one)
  detail::markDepthSteps(stepParams(params_, input), work.input, work.steps);
  switch (params_.method) {
    case NormalMethod::kCovariance:
      normals.setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
      detail::estimateCovarianceNormals(params_, work, normals);
      break;
    case NormalMethod::kAverage3dGradient:
      detail::estimateGradientNormals(detail::GradientMode::k3dGradient, params_, intrinsics, work,
                                      normals);
      break;
    case NormalMethod::kAverageDepthChange:
      detail::estimateGradientNormals(detail::GradientMode::kDepthChange, params_, intrinsics, work,
                                      normals);
      break;
  }
}

cv::Mat computeNormals(const cv::Mat& points_or_depth, const CameraIntrinsics& intrinsics,
                       const NormalParams& params) {
  NormalEstimator estimator(params);
  cv::Mat normals;
  estimator.compute(points_or_depth, intrinsics, normals);
  return normals;
}

}  // namespace shapesense
