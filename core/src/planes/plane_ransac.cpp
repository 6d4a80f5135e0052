#include "shapesense/core/planes/plane_ransac.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "shapesense/core/planes/plane_labeling.h"

namespace shapesense {

PlaneDetection detectPlanesRansac(const cv::Mat& depth_mm, const CameraIntrinsics& K,
                                  const cv::Mat& bgr, const RansacPlaneParams& P) {
  CV_Assert(depth_mm.type() == CV_16UC1);
  PlaneSampleGrid grid;
  grid.build(depth_mm, K, P.labeling.sample_step);
  const int R = grid.points.rows, C = grid.points.cols;
  const auto* pts = grid.points.ptr<cv::Vec3f>(0);
  cv::Mat labels(R, C, CV_32SC1, cv::Scalar(-1));
  int* lab = labels.ptr<int>(0);

  // Remaining samples as structure of arrays; `slot` maps a sample to its position (or -1).
  std::vector<int> idx;
  std::vector<float> x, y, z, tol;
  std::vector<int> slot(static_cast<std::size_t>(R) * C, -1);
  for (int i = 0; i < R * C; ++i) {
    if (!(pts[i][2] > 0)) continue;
    slot[i] = static_cast<int>(idx.size());
    idx.push_back(i);
    x.push_back(pts[i][0]);
    y.push_back(pts[i][1]);
    z.push_back(pts[i][2]);
    tol.push_back(static_cast<float>(P.labeling.tolerance.at(pts[i][2])));
  }
  std::mt19937_64 rng(P.seed);
  std::vector<PlaneHypothesis> planes;
  std::vector<std::uint8_t> removed(idx.size(), 0);
  std::size_t remaining = idx.size();
  const int W = std::max(0, P.neighbourhood_samples);

  auto countInliers = [&](float nx, float ny, float nz, float d) {
    int n = 0;
    for (std::size_t k = 0; k < idx.size(); ++k)
      n += !removed[k] && std::fabs(nx * x[k] + ny * y[k] + nz * z[k] + d) <= tol[k];
    return n;
  };
  // A random remaining sample near sample i (or anywhere when W == 0); -1 when none was hit.
  auto nearSample = [&](int i) {
    for (int attempt = 0; attempt < 8; ++attempt) {
      int j;
      if (W == 0) {
        j = idx[std::uniform_int_distribution<std::size_t>(0, idx.size() - 1)(rng)];
      } else {
        const int r = std::clamp(i / C + std::uniform_int_distribution<int>(-W, W)(rng), 0, R - 1);
        const int c = std::clamp(i % C + std::uniform_int_distribution<int>(-W, W)(rng), 0, C - 1);
        j = r * C + c;
      }
      if (j != i && slot[j] >= 0 && !removed[slot[j]]) return j;
    }
    return -1;
  };

  while (static_cast<int>(planes.size()) < P.max_planes &&
         remaining >= static_cast<std::size_t>(P.min_plane_samples)) {
    int best = 0;
    Eigen::Vector3d bn;
    double bd = 0;
    for (int it = 0; it < P.iterations; ++it) {
      std::size_t k0;
      do k0 = std::uniform_int_distribution<std::size_t>(0, idx.size() - 1)(rng);
      while (removed[k0]);
      const int i0 = idx[k0], i1 = nearSample(i0), i2 = nearSample(i0);
      if (i1 < 0 || i2 < 0 || i1 == i2) continue;
      const Eigen::Vector3d a(pts[i0][0], pts[i0][1], pts[i0][2]),
          b(pts[i1][0], pts[i1][1], pts[i1][2]), c(pts[i2][0], pts[i2][1], pts[i2][2]);
      Eigen::Vector3d n = (b - a).cross(c - a);
      if (n.norm() < 1e-9) continue;
      n.normalize();
      double d = -n.dot(a);
      if (d < 0) {
        n = -n;
        d = -d;
      }
      const int cnt = countInliers(static_cast<float>(n.x()), static_cast<float>(n.y()),
                                   static_cast<float>(n.z()), static_cast<float>(d));
      if (cnt > best) {
        best = cnt;
        bn = n;
        bd = d;
      }
    }
    if (best < P.min_plane_samples) break;
    // Least-squares refinement on the inliers (twice: the refit can gain a few at the margins).
    for (int pass = 0; pass < 2; ++pass) {
      PlaneMoments m;
      for (std::size_t k = 0; k < idx.size(); ++k)
        if (!removed[k] && std::fabs(bn.x() * x[k] + bn.y() * y[k] + bn.z() * z[k] + bd) <= tol[k])
          m.add(x[k], y[k], z[k]);
      const PlaneFit f = m.fit();
      if (!f.valid) break;
      bn = f.normal;
      bd = f.d;
    }
    const int id = static_cast<int>(planes.size());
    int taken = 0;
    for (std::size_t k = 0; k < idx.size(); ++k) {
      if (removed[k] || std::fabs(bn.x() * x[k] + bn.y() * y[k] + bn.z() * z[k] + bd) > tol[k])
        continue;
      removed[k] = 1;
      lab[idx[k]] = id;
      ++taken;
    }
    remaining -= static_cast<std::size_t>(taken);
    planes.push_back({bn, bd});
    if (taken < P.min_plane_samples) break;
  }
  return labelPlanes(depth_mm, K, bgr, grid, labels, planes, P.labeling);
}

}  // namespace shapesense
