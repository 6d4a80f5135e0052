#include "shapesense/core/segment_statistics.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace shapesense {

std::vector<SegmentStatistics> computeSegmentStatistics(const cv::Mat& regions,
                                                        const cv::Mat& depth_mm,
                                                        const CameraIntrinsics& intr) {
  CV_Assert(regions.type() == CV_16UC1 && depth_mm.type() == CV_16UC1 &&
            regions.size() == depth_mm.size());
  struct Acc {
    int n = 0;
    // Sums relative to the region's first point keep the covariance free of cancellation.
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();
    std::array<double, 9> s{};  // x y z xx xy xz yy yz zz
    int u0 = 1 << 30, v0 = 1 << 30, u1 = -1, v1 = -1;
  };
  double max_id = 0;
  cv::minMaxLoc(regions, nullptr, &max_id);
  std::vector<Acc> acc(static_cast<std::size_t>(max_id) + 1);
  std::vector<std::uint16_t> seen;
  for (int v = 0; v < regions.rows; ++v) {
    const auto* r = regions.ptr<std::uint16_t>(v);
    const auto* d = depth_mm.ptr<std::uint16_t>(v);
    for (int u = 0; u < regions.cols; ++u) {
      if (r[u] == 0 || d[u] == 0) continue;
      Acc& a = acc[r[u]];
      const Eigen::Vector3d p = intr.backproject(u, v, d[u] * 1e-3);
      if (a.n == 0) {
        a.origin = p;
        seen.push_back(r[u]);
      }
      const Eigen::Vector3d q = p - a.origin;
      ++a.n;
      a.s[0] += q.x();
      a.s[1] += q.y();
      a.s[2] += q.z();
      a.s[3] += q.x() * q.x();
      a.s[4] += q.x() * q.y();
      a.s[5] += q.x() * q.z();
      a.s[6] += q.y() * q.y();
      a.s[7] += q.y() * q.z();
      a.s[8] += q.z() * q.z();
      a.u0 = std::min(a.u0, u);
      a.u1 = std::max(a.u1, u);
      a.v0 = std::min(a.v0, v);
      a.v1 = std::max(a.v1, v);
    }
  }
  std::sort(seen.begin(), seen.end());
  std::vector<SegmentStatistics> out;
  out.reserve(seen.size());
  for (std::uint16_t id : seen) {
    const Acc& a = acc[id];
    SegmentStatistics s;
    s.id = id;
    s.pixels = a.n;
    const double inv = 1.0 / a.n;
    const Eigen::Vector3d m(a.s[0] * inv, a.s[1] * inv, a.s[2] * inv);
    s.centroid = a.origin + m;
    s.box = cv::Rect(a.u0, a.v0, a.u1 - a.u0 + 1, a.v1 - a.v0 + 1);
    if (a.n >= 3) {
      Eigen::Matrix3d c;
      c << a.s[3] * inv - m.x() * m.x(), a.s[4] * inv - m.x() * m.y(), a.s[5] * inv - m.x() * m.z(),
          0, a.s[6] * inv - m.y() * m.y(), a.s[7] * inv - m.y() * m.z(), 0, 0,
          a.s[8] * inv - m.z() * m.z();
      c(1, 0) = c(0, 1);
      c(2, 0) = c(0, 2);
      c(2, 1) = c(1, 2);
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c);
      Eigen::Vector3d n = es.eigenvectors().col(0);
      if (n.dot(s.centroid) > 0) n = -n;
      s.mean_normal = n.normalized();
      s.plane_rms_m = std::sqrt(std::max(0.0, es.eigenvalues()(0)));
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace shapesense
