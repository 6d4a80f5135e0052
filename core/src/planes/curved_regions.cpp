#include "planes/curved_regions.h"

#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "shapesense/core/geometry/height_fit.h"

namespace shapesense::labeling {
namespace {

// A region's plane and quadric fits over its own samples, in its plane's frame.
struct OwnFit : HeightFit {
  explicit OwnFit(const HeightSums& s) : HeightFit(fitHeights(s)) {}

  // Whether its quadric bends more than a flat surface can, however little better than the
  // plane it fits.
  bool bends(const PlaneLabelingParams& params) const {
    return reliable() && curvature > params.max_plane_curvature_per_m;
  }
  // Whether the region is curved on its own: it bends and the quadric fits it markedly better.
  bool curved(const PlaneLabelingParams& params) const {
    return bends(params) && planeToQuadricRms() >= params.curved_rms_ratio;
  }
};

// The candidate regions' own sums, the candidate root of each sample (-1 for none) and how
// often two candidates' samples lie within two grid steps of each other along a row or column.
struct RegionSamples {
  std::vector<HeightSums> sums;
  cv::Mat region;  // CV_32SC1, the grid's size
  std::map<std::pair<int, int>, int> contacts;
};

RegionSamples gatherSamples(const PlaneSampleGrid& grid, const cv::Mat& region_labels,
                            const std::vector<int>& root, const std::vector<bool>& candidate,
                            const std::vector<Eigen::Vector3d>& normals) {
  constexpr int kReach = 2;
  const int count = static_cast<int>(root.size());
  const int rows = grid.points.rows, cols = grid.points.cols;
  RegionSamples out;
  out.sums.reserve(normals.size());
  for (const Eigen::Vector3d& n : normals) out.sums.emplace_back(n);
  out.region.create(rows, cols, CV_32SC1);
  out.region.setTo(-1);
  for (int r = 0; r < rows; ++r) {
    const auto* label_row = region_labels.ptr<std::uint16_t>(grid.offset + r * grid.step);
    const auto* point_row = grid.points.ptr<cv::Vec3f>(r);
    auto* region_row = out.region.ptr<int>(r);
    for (int c = 0; c < cols; ++c) {
      const int label = label_row[grid.offset + c * grid.step];
      if (!label || label > count) continue;
      const int k = root[label - 1];
      if (!candidate[k]) continue;
      const cv::Vec3f& x = point_row[c];
      if (!std::isfinite(x[2])) continue;
      out.sums[k].add({x[0], x[1], x[2]});
      region_row[c] = k;
      for (int s = 1; s <= kReach; ++s) {
        const int left = c >= s ? region_row[c - s] : -1;
        const int above = r >= s ? out.region.ptr<int>(r - s)[c] : -1;
        for (const int other : {left, above})
          if (other >= 0 && other != k) ++out.contacts[{std::min(k, other), std::max(k, other)}];
      }
    }
  }
  return out;
}

// Two regions that meet at a shallow angle are two pieces of one curved surface (a bin or a
// column cut into facets) when each bends on its own, and one quadric fits their samples
// together about as well as their two planes fit them, and bends more than a flat surface
// can. Two flat faces at a shallow crease fail the first test even where the sensor's noise
// at range lets a quadric pass for the crease.
bool formOneCurvedSurface(const PlaneSampleGrid& grid, const cv::Mat& sample_region, int a, int b,
                          const OwnFit& fit_a, const OwnFit& fit_b, const Eigen::Vector3d& normal_a,
                          const Eigen::Vector3d& normal_b, const PlaneLabelingParams& params) {
  if (!fit_a.bends(params) || !fit_b.bends(params)) return false;
  if (normal_a.dot(normal_b) < std::cos(params.curved_pair_max_angle_deg * M_PI / 180.0))
    return false;
  HeightSums both((normal_a + normal_b).normalized());
  for (int r = 0; r < sample_region.rows; ++r) {
    const auto* region_row = sample_region.ptr<int>(r);
    const auto* point_row = grid.points.ptr<cv::Vec3f>(r);
    for (int c = 0; c < sample_region.cols; ++c) {
      if (region_row[c] != a && region_row[c] != b) continue;
      const cv::Vec3f& x = point_row[c];
      both.add({x[0], x[1], x[2]});
    }
  }
  const double two_planes_rms =
      std::sqrt((fit_a.plane_residual + fit_b.plane_residual) / (fit_a.count + fit_b.count));
  const HeightFit joint = fitHeights(both);
  return joint.quadricRms() <= params.curved_pair_rms_factor * two_planes_rms &&
         joint.curvature > params.max_plane_curvature_per_m;
}

}  // namespace

std::vector<bool> curvedRegions(const PlaneSampleGrid& grid, const cv::Mat& region_labels,
                                const std::vector<int>& root, const std::vector<bool>& candidate,
                                const std::vector<Eigen::Vector3d>& normals,
                                const PlaneLabelingParams& params) {
  if (params.max_plane_curvature_per_m <= 0.0) return {};
  const std::size_t count = root.size();
  std::vector<Eigen::Vector3d> frame_normals(count, Eigen::Vector3d::UnitZ());
  for (std::size_t k = 0; k < count; ++k)
    if (candidate[k]) frame_normals[k] = normals[k];
  const RegionSamples samples = gatherSamples(grid, region_labels, root, candidate, frame_normals);
  std::vector<OwnFit> fits;
  fits.reserve(count);
  std::vector<bool> curved(count, false);
  for (std::size_t k = 0; k < count; ++k) {
    fits.emplace_back(samples.sums[k]);
    curved[k] = candidate[k] && fits[k].curved(params);
  }
  if (params.curved_pair_rms_factor <= 0.0) return curved;
  constexpr int kMinContacts = 3;
  for (const auto& [pair, contacts] : samples.contacts) {
    const auto [a, b] = pair;
    if (contacts >= kMinContacts &&
        formOneCurvedSurface(grid, samples.region, a, b, fits[a], fits[b], frame_normals[a],
                             frame_normals[b], params))
      curved[a] = curved[b] = true;
  }
  return curved;
}

}  // namespace shapesense::labeling
