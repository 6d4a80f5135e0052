#include "segmentation/object_shapes.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "shapesense/core/geometry/units.h"

namespace shapesense::segmentation {
namespace {

// The two faces of an object region that is two faces meeting at a crease, if it is: its two
// planes (`two`) each fit their points within crease_face_rms_steps depth steps RMS
// (`tolerance`) and at least twice as well as one plane (`one`) fits them all, together better
// than the region's quadric does (a quadric bends smoothly: it fits a tin's side better than two
// planes, and a crease worse), and their normals lie crease_min_angle_deg or more apart.
std::optional<TwoPlanes> creaseFaces(const TwoPlaneFit& two, const PlaneFit& one,
                                     const HeightFit& quadric, double tolerance,
                                     const PlanesAndObjectsParams& p) {
  constexpr double kMinFacePoints = 20;
  constexpr double kMinGain = 2.0;
  const TwoPlanes& best = two.planes;
  if (!two.facesHoldAtLeast(kMinFacePoints) || best.a.rms_m > tolerance ||
      best.b.rms_m > tolerance || one.rms_m < kMinGain * std::max(best.a.rms_m, best.b.rms_m) ||
      two.rms() >= quadric.quadricRms() ||
      std::abs(best.a.normal.dot(best.b.normal)) > std::cos(degToRad(p.crease_min_angle_deg)))
    return std::nullopt;
  return best;
}

}  // namespace

ObjectShapes objectShapes(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                          const RowRuns& runs, int plane_count, int label_count,
                          const PlanesAndObjectsParams& p) {
  const auto count = static_cast<std::size_t>(label_count) + 1;
  ObjectShapes shapes;
  shapes.points.resize(count);
  const int step = std::max(1, p.curved_sample_step_px);
  const auto first_sample = [step](int u) { return (u + step - 1) / step * step; };
  std::vector<std::size_t> samples(count, 0);  // an upper bound: some have no depth
  for (int v = 0; v < static_cast<int>(runs.size()); v += step)
    for (const LabelRun& run : runs[static_cast<std::size_t>(v)])
      if (run.label > plane_count && run.end > first_sample(run.begin))
        samples[static_cast<std::size_t>(run.label)] +=
            static_cast<std::size_t>((run.end - 1 - first_sample(run.begin)) / step + 1);
  for (std::size_t label = 0; label < count; ++label) shapes.points[label].reserve(samples[label]);
  for (int v = 0; v < static_cast<int>(runs.size()); v += step) {
    const auto* z = depth_mm.ptr<std::uint16_t>(v);
    for (const LabelRun& run : runs[static_cast<std::size_t>(v)]) {
      if (run.label <= plane_count) continue;
      auto& points = shapes.points[static_cast<std::size_t>(run.label)];
      for (int u = first_sample(run.begin); u < run.end; u += step)
        if (z[u]) points.push_back(intrinsics.backproject(u, v, z[u] * 1e-3));
    }
  }
  shapes.moments.resize(count);
  shapes.normal.assign(count, Eigen::Vector3d::UnitZ());
  shapes.fit.resize(count);
  shapes.curved.assign(count, false);
  shapes.surface.resize(count);
  shapes.faces.resize(count);
  for (std::size_t label = static_cast<std::size_t>(plane_count) + 1; label < count; ++label) {
    const auto& points = shapes.points[label];
    if (points.size() < 3) continue;
    PlaneMoments& moments = shapes.moments[label];
    for (const Eigen::Vector3d& x : points) moments.add(x);
    const PlaneFit plane = moments.fit();
    if (plane.valid) shapes.normal[label] = plane.normal;
    HeightSums heights(shapes.normal[label]);
    for (const Eigen::Vector3d& x : points) heights.add(x);
    const HeightFit fit = fitHeights(heights);
    shapes.fit[label] = fit;
    // Regions flat within the crease tolerance are one face; two planes are fitted to the rest.
    constexpr std::size_t kMinTwoPlanePoints = 60;
    const Eigen::Vector3d centroid = moments.centroid();
    const double depth_step = p.continuity.noise.depthStep(centroid.z());
    const double crease_tolerance = p.crease_face_rms_steps * depth_step;
    std::optional<TwoPlaneFit> two;
    if (plane.valid && plane.rms_m > crease_tolerance && points.size() >= kMinTwoPlanePoints)
      two = bestTwoPlanes(points, centroid);
    if (p.split_creased_objects && two)
      shapes.faces[label] = creaseFaces(*two, plane, fit, crease_tolerance, p);
    if (shapes.faces[label] || !fit.reliable()) continue;
    const bool bends = fit.curvature > p.curved_min_curvature_per_m &&
                       fit.planeToQuadricRms() >= p.curved_rms_ratio;
    const bool no_plane = fit.planeRms() >= p.curved_surface_min_plane_rms_steps * depth_step;
    // The surface can make a region curved only where a two-plane fit exists to compare it to.
    if (!bends && !(no_plane && two)) continue;
    const QuadricSurfaceFit& surface = shapes.surface[label] = fitQuadricSurface({points});
    // Two faces at a crease lie on one quadric too (a pair of planes is one): the surface must
    // also fit better than two planes do.
    shapes.curved[label] =
        bends ||
        (surface.reliable() && fit.planeRms() >= p.curved_surface_rms_ratio * surface.rms_m &&
         two && two->rms() >= p.curved_surface_two_plane_ratio * surface.rms_m);
  }
  return shapes;
}

bool oneQuadricFitsBoth(const ObjectShapes& shapes, int a, int b, const PlanesAndObjectsParams& p) {
  HeightSums both((shapes.normal[a] + shapes.normal[b]).normalized());
  for (const int label : {a, b})
    for (const Eigen::Vector3d& x : shapes.points[static_cast<std::size_t>(label)]) both.add(x);
  const HeightFit& fa = shapes.fit[a];
  const HeightFit& fb = shapes.fit[b];
  const double own_rms =
      std::sqrt((fa.quadric_residual + fb.quadric_residual) / std::max(fa.count + fb.count, 1));
  if (fitHeights(both).quadricRms() <= p.join_quadric_rms_factor * own_rms) return true;
  const QuadricSurfaceFit& sa = shapes.surface[a];
  const QuadricSurfaceFit& sb = shapes.surface[b];
  if (!sa.reliable() || !sb.reliable()) return false;
  const QuadricSurfaceFit one = fitQuadricSurface({shapes.points[a], shapes.points[b]});
  const double own_surface_rms = std::sqrt(
      (sa.rms_m * sa.rms_m * sa.count + sb.rms_m * sb.rms_m * sb.count) / (sa.count + sb.count));
  const double farther =
      std::max(shapes.moments[a].centroid().z(), shapes.moments[b].centroid().z());
  const double half_step = 0.5 * p.continuity.noise.depthStep(farther);
  return one.reliable() &&
         one.rms_m <= p.join_surface_rms_factor * std::max(own_surface_rms, half_step);
}

}  // namespace shapesense::segmentation
