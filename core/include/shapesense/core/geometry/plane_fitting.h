#pragma once
// Least-squares plane fitting from accumulated moments, and the range-dependent inlier
// tolerance of a Kinect-class sensor. Shared by the Hough detector, the RANSAC baseline and the
// plane accumulator.

#include <cmath>
#include <cstddef>

#include <Eigen/Core>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

/// Result of a total-least-squares plane fit.
struct PlaneFit {
  bool valid = false;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit, towards the camera (d >= 0)
  double d = 0.0;                                    ///< n.X + d = 0
  double rms_m = 0.0;                                ///< RMS orthogonal residual (m)
  double count = 0.0;                                ///< (weighted) number of points
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();

  /// Orthogonal distance of x from the plane.
  double distance(const Eigen::Vector3d& x) const { return std::abs(normal.dot(x) + d); }
};

/// First and second moments of a point set, relative to a reference point so that sums of
/// millions of points at metres of range keep their precision in doubles.
class PlaneMoments {
 public:
  PlaneMoments() = default;
  explicit PlaneMoments(const Eigen::Vector3d& reference) : ref_(reference), has_ref_(true) {}

  void add(double x, double y, double z, double w = 1.0) {
    if (!has_ref_) {
      ref_ = {x, y, z};
      has_ref_ = true;
    }
    const double a = x - ref_.x(), b = y - ref_.y(), c = z - ref_.z();
    n_ += w;
    s_ += w * Eigen::Vector3d(a, b, c);
    ss_(0, 0) += w * a * a;
    ss_(0, 1) += w * a * b;
    ss_(0, 2) += w * a * c;
    ss_(1, 1) += w * b * b;
    ss_(1, 2) += w * b * c;
    ss_(2, 2) += w * c * c;
  }
  void add(const Eigen::Vector3d& p, double w = 1.0) { add(p.x(), p.y(), p.z(), w); }
  /// Adds the sums of a point set taken relative to this set's reference (as in fromSums; only
  /// the upper triangle of sum_sq is read): for loops that keep raw sums in registers.
  void addSums(double n, const Eigen::Vector3d& sum, const Eigen::Matrix3d& sum_sq) {
    n_ += n;
    s_ += sum;
    ss_ += sum_sq.triangularView<Eigen::Upper>().toDenseMatrix();
  }
  /// The moments of a point set of total weight n whose offsets from `reference` sum to `sum`
  /// and whose offsets' outer products sum to `sum_sq`: for loops that keep raw sums in
  /// registers instead of calling add() per point.
  static PlaneMoments fromSums(const Eigen::Vector3d& reference, double n,
                               const Eigen::Vector3d& sum, const Eigen::Matrix3d& sum_sq) {
    PlaneMoments m(reference);
    m.n_ = n;
    m.s_ = sum;
    m.ss_ = sum_sq.triangularView<Eigen::Upper>().toDenseMatrix();
    return m;
  }
  /// Adds another set's moments (any reference).
  void merge(const PlaneMoments& other);
  /// Multiplies the weight of every point so far by f (exponential forgetting).
  void scale(double f) {
    n_ *= f;
    s_ *= f;
    ss_ *= f;
  }
  /// Rigidly moves the point set: every point X becomes R X + t.
  void transform(const Eigen::Matrix3d& R, const Eigen::Vector3d& t);
  double count() const { return n_; }
  /// Mean of the points (the reference when there are none).
  Eigen::Vector3d centroid() const { return n_ > 0 ? Eigen::Vector3d(ref_ + s_ / n_) : ref_; }
  /// The point the sums are taken relative to (see addSums).
  const Eigen::Vector3d& reference() const { return ref_; }
  void clear() { *this = PlaneMoments(); }

  /// Total-least-squares plane (smallest eigenvector of the covariance). The normal is oriented
  /// towards `viewpoint` (the camera centre by default). Invalid with < 3 points.
  PlaneFit fit(const Eigen::Vector3d& viewpoint = Eigen::Vector3d::Zero()) const;
  /// Mean squared signed distance n.X + d of the points to the plane (unit `normal`, `d`);
  /// 0 with no points.
  double meanSquaredDistance(const Eigen::Vector3d& normal, double d) const;

 private:
  Eigen::Vector3d ref_ = Eigen::Vector3d::Zero();
  bool has_ref_ = false;
  double n_ = 0.0;
  Eigen::Vector3d s_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ss_ = Eigen::Matrix3d::Zero();  // upper triangle used
};

/// How far (orthogonally, metres) a measured point may lie from its plane at range z:
/// max(floor_m, noise_steps * KinectNoiseModel::depthStep(z)). With the defaults: 9 mm at 1 m,
/// 2.6 cm at 2 m, 5.9 cm at 3 m (Kinect noise and quantisation are ~0.6 step sigma + a step).
struct PlaneTolerance {
  double noise_steps = 3.0;  ///< tolerance in sensor depth steps. Default 3.
  double floor_m = 0.004;    ///< never tighter than this (m). Default 0.004.
  KinectNoiseModel noise{};  ///< sensor model. Default Kinect v1.

  double at(double z) const { return std::max(floor_m, noise_steps * noise.depthStep(z)); }
};

}  // namespace shapesense
