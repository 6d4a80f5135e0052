#include "shapesense/core/segmentation/segment_statistics.h"

#include <algorithm>
#include <climits>
#include <vector>

#include "shapesense/core/geometry/moment_sums.h"
#include "shapesense/core/geometry/plane_fitting.h"

namespace shapesense {
namespace {

struct RegionAccumulator {
  // Reference: the region's first point, so the sums of a far region keep their precision.
  PlaneMoments moments;
  int u0 = INT_MAX, v0 = INT_MAX, u1 = -1, v1 = -1;
};

// Adds the pixels with depth in drow[u0, u1) (one region, image row v) to `region`.
void addRun(const std::uint16_t* drow, int u0, int u1, int v, const double* xr, double yr,
            RegionAccumulator& region) {
  int first = u0;
  while (first < u1 && drow[first] == 0) ++first;
  if (first == u1) return;
  int last = u1 - 1;
  while (drow[last] == 0) --last;
  if (region.moments.count() == 0) {
    const double z = drow[first] * 1e-3;
    region.moments = PlaneMoments(Eigen::Vector3d(xr[first] * z, yr * z, z));
  }
  const Eigen::Vector3d& o = region.moments.reference();
  // Summed in locals along the run, added to the region once.
  MomentSums run;
  for (int u = first; u <= last; ++u) {
    if (drow[u] == 0) continue;
    const double z = drow[u] * 1e-3;
    run.addOffset(xr[u] * z - o.x(), yr * z - o.y(), z - o.z());
  }
  run.addTo(region.moments);
  region.u0 = std::min(region.u0, first);
  region.u1 = std::max(region.u1, last);
  region.v0 = std::min(region.v0, v);
  region.v1 = std::max(region.v1, v);
}

}  // namespace

std::vector<SegmentStatistics> computeSegmentStatistics(const cv::Mat& regions,
                                                        const cv::Mat& depth_mm,
                                                        const CameraIntrinsics& intr) {
  CV_Assert(regions.type() == CV_16UC1 && depth_mm.type() == CV_16UC1 &&
            regions.size() == depth_mm.size());
  double max_id = 0;
  cv::minMaxLoc(regions, nullptr, &max_id);
  std::vector<RegionAccumulator> acc(static_cast<std::size_t>(max_id) + 1);
  std::vector<double> xr(static_cast<std::size_t>(regions.cols));
  for (int u = 0; u < regions.cols; ++u) xr[u] = (u - intr.cx) / intr.fx;
  for (int v = 0; v < regions.rows; ++v) {
    const auto* r = regions.ptr<std::uint16_t>(v);
    const auto* d = depth_mm.ptr<std::uint16_t>(v);
    const double yr = (v - intr.cy) / intr.fy;
    for (int u = 0; u < regions.cols;) {
      const std::uint16_t id = r[u];
      int end = u + 1;
      while (end < regions.cols && r[end] == id) ++end;
      if (id != 0) addRun(d, u, end, v, xr.data(), yr, acc[id]);
      u = end;
    }
  }
  std::vector<SegmentStatistics> out;
  for (std::size_t id = 1; id < acc.size(); ++id) {
    const RegionAccumulator& a = acc[id];
    if (a.moments.count() == 0) continue;
    SegmentStatistics s;
    s.id = static_cast<std::uint16_t>(id);
    s.pixels = static_cast<int>(a.moments.count());
    s.centroid = a.moments.centroid();
    s.box = cv::Rect(a.u0, a.v0, a.u1 - a.u0 + 1, a.v1 - a.v0 + 1);
    // fit() orients the normal towards the camera centre (n . centroid < 0).
    const PlaneFit fit = a.moments.fit();
    if (fit.valid) {
      s.mean_normal = fit.normal;
      s.plane_rms_m = fit.rms_m;
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace shapesense
