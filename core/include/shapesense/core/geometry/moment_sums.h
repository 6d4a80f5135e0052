#pragma once
// PlaneMoments for loops over many points: the sums kept in locals (registers), handed to a
// PlaneMoments once per run.

#include <cassert>
#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "shapesense/core/geometry/plane_fitting.h"

namespace shapesense {

/// The sums of PlaneMoments (w = 1) in locals, for loops over many points: the additions
/// PlaneMoments::add makes, in the same order, so moments() equals the PlaneMoments the same
/// add() calls give (PlaneMoments keeps them in an Eigen vector and matrix, which a loop cannot
/// hold in registers). Needs a reference (the first point, as add() takes it, or the caller's).
class MomentSums {
 public:
  MomentSums() = default;
  explicit MomentSums(const Eigen::Vector3d& ref) { setReference(ref); }
  bool hasReference() const { return has_ref_; }
  void setReference(const Eigen::Vector3d& ref) {
    ref_ = ref;
    has_ref_ = true;
  }
  /// Needs a reference (the constructor's or setReference's): without one the sums would be
  /// taken relative to (0, 0, 0), unlike PlaneMoments::add.
  void add(float x, float y, float z) {
    assert(has_ref_);
    addOffset(x - ref_.x(), y - ref_.y(), z - ref_.z());
  }
  void add(const cv::Vec3f& p) { add(p[0], p[1], p[2]); }
  /// Adds a point given by its offset (a, b, c) from the reference, which the caller took.
  void addOffset(double a, double b, double c) {
    n_ += 1.0;
    s_[0] += a, s_[1] += b, s_[2] += c;
    ss_[0] += a * a, ss_[1] += a * b, ss_[2] += a * c;
    ss_[3] += b * b, ss_[4] += b * c, ss_[5] += c * c;
  }
  double count() const { return n_; }
  /// The least-squares slopes (g_a, g_b) of c = g_a a + g_b b + const over the offsets (a, b, c):
  /// the tilt of a surface given as heights c over the (a, b) plane, which needs no eigenvectors.
  /// nullopt when the points' (a, b) lie on a line or are fewer than three.
  std::optional<Eigen::Vector2d> heightSlopes() const {
    if (n_ < 3.0) return std::nullopt;
    const double caa = ss_[0] - s_[0] * s_[0] / n_, cab = ss_[1] - s_[0] * s_[1] / n_;
    const double cbb = ss_[3] - s_[1] * s_[1] / n_;
    const double cac = ss_[2] - s_[0] * s_[2] / n_, cbc = ss_[4] - s_[1] * s_[2] / n_;
    const double det = caa * cbb - cab * cab;
    if (!(det > 1e-12 * (caa + cbb) * (caa + cbb))) return std::nullopt;
    return Eigen::Vector2d((cbb * cac - cab * cbc) / det, (caa * cbc - cab * cac) / det);
  }
  /// Adds these sums to `moments`, whose reference must be this one's.
  void addTo(PlaneMoments& moments) const {
    moments.addSums(n_, Eigen::Vector3d(s_[0], s_[1], s_[2]), upperSquares());
  }
  /// PlaneMoments() when no reference was set.
  PlaneMoments moments() const {
    if (!has_ref_) return PlaneMoments();
    return PlaneMoments::fromSums(ref_, n_, Eigen::Vector3d(s_[0], s_[1], s_[2]), upperSquares());
  }

 private:
  Eigen::Matrix3d upperSquares() const {
    Eigen::Matrix3d sq;
    sq << ss_[0], ss_[1], ss_[2], 0.0, ss_[3], ss_[4], 0.0, 0.0, ss_[5];
    return sq;
  }

  Eigen::Vector3d ref_ = Eigen::Vector3d::Zero();
  bool has_ref_ = false;
  double n_ = 0.0;
  double s_[3] = {0, 0, 0};
  double ss_[6] = {0, 0, 0, 0, 0, 0};  // a a, a b, a c, b b, b c, c c
};

}  // namespace shapesense
