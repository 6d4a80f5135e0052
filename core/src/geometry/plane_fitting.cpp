#include "shapesense/core/geometry/plane_fitting.h"

#include <Eigen/Eigenvalues>

namespace shapesense {

void PlaneMoments::merge(const PlaneMoments& o) {
  if (o.n_ <= 0) return;
  if (!has_ref_) {
    *this = o;
    return;
  }
  // Shift o's moments to this reference: with e = o.ref - ref, sum (p'+e) = s' + n e and
  // sum (p'+e)(p'+e)^T = ss' + s' e^T + e s'^T + n e e^T.
  const Eigen::Vector3d e = o.ref_ - ref_;
  Eigen::Matrix3d oss = o.ss_.selfadjointView<Eigen::Upper>();
  Eigen::Matrix3d shifted =
      oss + o.s_ * e.transpose() + e * o.s_.transpose() + o.n_ * e * e.transpose();
  n_ += o.n_;
  s_ += o.s_ + o.n_ * e;
  ss_ += shifted.triangularView<Eigen::Upper>().toDenseMatrix();
}

void PlaneMoments::transform(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  // Points relative to ref rotate with R; the reference itself moves rigidly.
  Eigen::Matrix3d full = ss_.selfadjointView<Eigen::Upper>();
  full = R * full * R.transpose();
  ss_ = full.triangularView<Eigen::Upper>().toDenseMatrix();
  s_ = R * s_;
  ref_ = R * ref_ + t;
}

double PlaneMoments::meanSquaredDistance(const Eigen::Vector3d& normal, double d) const {
  if (n_ <= 0) return 0.0;
  // Each point is ref + a: (n.ref + d + n.a)^2 summed is k^2 n + 2 k n.s + n^T ss n.
  const double k = normal.dot(ref_) + d;
  const Eigen::Matrix3d ss = ss_.selfadjointView<Eigen::Upper>();
  return (k * k * n_ + 2.0 * k * normal.dot(s_) + normal.dot(ss * normal)) / n_;
}

PlaneFit PlaneMoments::fit(const Eigen::Vector3d& viewpoint) const {
  PlaneFit f;
  f.count = n_;
  if (n_ < 3.0) return f;
  const Eigen::Vector3d mean = s_ / n_;
  Eigen::Matrix3d cov = ss_.selfadjointView<Eigen::Upper>();
  cov = cov / n_ - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  if (es.info() != Eigen::Success) return f;
  Eigen::Vector3d n = es.eigenvectors().col(0).normalized();
  const Eigen::Vector3d c = mean + ref_;
  double d = -n.dot(c);
  if (n.dot(viewpoint) + d < 0) {  // viewpoint must be on the positive side
    n = -n;
    d = -d;
  }
  f.valid = true;
  f.normal = n;
  f.d = d;
  f.rms_m = std::sqrt(std::max(0.0, es.eigenvalues()(0)));
  f.centroid = c;
  return f;
}

}  // namespace shapesense
