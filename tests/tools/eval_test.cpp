// The evaluation's scoring: a perfect answer scores perfectly, a merged or a missing plane is
// counted where it belongs, and the splits never share a scene.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "shapesense/core/geometry/units.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/eval/box_eval.h"
#include "shapesense/eval/plane_eval.h"
#include "shapesense/eval/scene_splits.h"
#include "shapesense/eval/segment_eval.h"

namespace shapesense::eval {
namespace {

synthetic::RenderedFrame clutteredFrame() {
  synthetic::SceneParams p;
  p.seed = 11;
  p.bowls_min = p.bowls_max = 2;
  p.tins_min = p.tins_max = 1;
  p.render_colour = false;
  return synthetic::SyntheticScene(p).render(0, 0);
}

// The truth planes as the detector's answer: the planes with the truth's (n, d).
std::vector<DetectedPlane> truthPlanes(const synthetic::TruthFrame& truth) {
  std::vector<DetectedPlane> planes;
  for (const auto& s : truth.surfaces) {
    if (s.kind != synthetic::SurfaceKind::kPlane) continue;
    DetectedPlane p;
    p.id = s.id;
    p.normal = s.plane.head<3>();
    p.d = s.plane[3];
    planes.push_back(p);
  }
  return planes;
}

TEST(PlaneEval, TheTruthScoresEveryPlaneCorrectWithNoError) {
  const auto f = clutteredFrame();
  const PlaneScore s = scorePlanes(planarTruth(f.truth), truthPlanes(f.truth), f.truth);
  ASSERT_GT(s.truth_regions, 5);
  EXPECT_EQ(s.correct, s.truth_regions);
  EXPECT_EQ(s.spurious, 0);
  int binned = 0;
  for (const auto& bin : s.by_size) {
    EXPECT_EQ(bin.correct, bin.total());
    binned += bin.total();
  }
  EXPECT_EQ(binned, s.truth_regions);
  ASSERT_EQ(s.angle_deg.size(), static_cast<std::size_t>(s.correct));
  EXPECT_LT(median(s.angle_deg), 1e-6);
  EXPECT_LT(median(s.dist_m), 1e-9);
}

TEST(PlaneEval, TwoPlanesReportedAsOneAreMergedAndACurvedPlaneIsSpurious) {
  const auto f = clutteredFrame();
  cv::Mat labels = planarTruth(f.truth);
  // The two largest truth planes become one reported plane.
  std::vector<std::pair<std::size_t, int>> by_size;
  for (const auto& s : f.truth.surfaces)
    if (s.kind == synthetic::SurfaceKind::kPlane) by_size.emplace_back(s.pixel_count, s.id);
  std::sort(by_size.rbegin(), by_size.rend());
  const int keep = by_size[0].second, gone = by_size[1].second;
  labels.setTo(keep, labels == gone);
  // A plane reported on the curved surfaces (bowls, tin sides).
  const int curved_id = 60000;
  for (const auto& s : f.truth.surfaces)
    if (s.kind == synthetic::SurfaceKind::kCurved && s.pixel_count > 0)
      labels.setTo(curved_id, f.truth.surface_labels == s.id);
  auto planes = truthPlanes(f.truth);
  const PlaneScore s = scorePlanes(labels, planes, f.truth);
  int merged = 0;
  for (const auto& bin : s.by_size) merged += bin.merged;
  EXPECT_EQ(merged, 2);
  EXPECT_EQ(s.correct, s.truth_regions - 2);
  EXPECT_EQ(s.spurious, 1);
  EXPECT_EQ(s.spurious_on_curved, 1);
}

// Relabels the first `count` pixels (row by row) of truth surface `id` in `labels` as `label`.
void relabelPixelsOf(const synthetic::TruthFrame& truth, int id, int count, int label,
                     cv::Mat& labels) {
  for (int v = 0; v < labels.rows && count > 0; ++v)
    for (int u = 0; u < labels.cols && count > 0; ++u)
      if (truth.surface_labels.at<std::uint16_t>(v, u) == id) {
        labels.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(label);
        --count;
      }
}

// Two of the truth's planes of at least `min_pixels` whose normals make an angle within
// [min_deg, max_deg] and whose distances differ by at least `min_offset_m`; {0, 0} if none.
std::pair<int, int> planePair(const synthetic::TruthFrame& truth, std::size_t min_pixels,
                              double min_deg, double max_deg, double min_offset_m) {
  for (const auto& a : truth.surfaces)
    for (const auto& b : truth.surfaces) {
      if (a.id >= b.id || a.kind != synthetic::SurfaceKind::kPlane ||
          b.kind != synthetic::SurfaceKind::kPlane || a.pixel_count < min_pixels ||
          b.pixel_count < min_pixels)
        continue;
      const double angle = angleDegOfCosine(a.plane.head<3>().dot(b.plane.head<3>()));
      if (angle >= min_deg && angle <= max_deg && std::abs(a.plane[3] - b.plane[3]) >= min_offset_m)
        return {a.id, b.id};
    }
  return {0, 0};
}

TEST(PlaneEval, ASpuriousPlaneIsCountedByTheSurfacesItCovers) {
  const auto f = clutteredFrame();
  const auto crease = planePair(f.truth, 2000, 80.0, 100.0, 0.0);
  const auto parallel = planePair(f.truth, 2000, 0.0, 5.0, 0.05);
  ASSERT_NE(crease.first, 0);
  ASSERT_NE(parallel.first, 0);
  // Patches of 150 pixels of both planes of a pair reported as one plane: neither a part of
  // one truth plane (it holds half of two) nor related to one.
  const auto scoreOnePlaneOver = [&](std::pair<int, int> pair) {
    cv::Mat labels = planarTruth(f.truth);
    relabelPixelsOf(f.truth, pair.first, 150, 60001, labels);
    relabelPixelsOf(f.truth, pair.second, 150, 60001, labels);
    return scorePlanes(labels, truthPlanes(f.truth), f.truth);
  };
  const PlaneScore across = scoreOnePlaneOver(crease);
  EXPECT_EQ(across.spurious, 1);
  EXPECT_EQ(across.spurious_across_crease, 1);
  const PlaneScore stacked = scoreOnePlaneOver(parallel);
  EXPECT_EQ(stacked.spurious, 1);
  EXPECT_EQ(stacked.spurious_parallel, 1);
}

// On the detector's planes of training scenes, every spurious plane is counted under one kind.
TEST(PlaneEval, EverySpuriousPlaneHasOneKind) {
  HoughPlaneDetector hough;
  PlaneScore s;
  for (int index = 0; index < 8; ++index) {
    const EvalScene scene = evalScene(Split::kTrain, index);
    const synthetic::RenderedFrame f =
        synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
    const PlaneDetection planes = hough.detect(f.frame.depth, f.frame.intrinsics);
    s.add(scorePlanes(planes.labels, planes.planes, f.truth));
  }
  ASSERT_GT(s.spurious, 0);
  EXPECT_EQ(s.spurious_on_curved + s.spurious_across_crease + s.spurious_parallel +
                s.spurious_coplanar + s.spurious_other,
            s.spurious);
}

TEST(SegmentEval, CurvedObjectsAreOneRegionAndPlanarFacesStayApart) {
  const auto f = clutteredFrame();
  const cv::Mat truth = segmentTruth(f.truth);
  for (const auto& o : f.truth.objects) {
    if (o.pixel_count == 0) continue;
    std::set<int> regions;
    for (int v = 0; v < truth.rows; ++v)
      for (int u = 0; u < truth.cols; ++u)
        if (f.truth.object_labels.at<std::uint16_t>(v, u) == o.id)
          regions.insert(truth.at<std::uint16_t>(v, u));
    if (o.kind == "bowl" || o.kind == "tin") {
      EXPECT_EQ(regions.size(), 1u) << o.name;
    } else if (o.kind == "box") {
      EXPECT_GE(regions.size(), 2u) << o.name;
    }
  }
  EXPECT_EQ(scoreSegments(truth, f.truth).correct_fraction, 1.0);
}

TEST(SegmentEval, RealObjectsMergedWithTheTableAreNotKeptApart) {
  // OSD labels: 1 the table, 20 and 30 two objects; 60 x 40 pixels, all with depth.
  cv::Mat labels(40, 60, CV_16UC1, cv::Scalar(1));
  labels(cv::Rect(5, 5, 10, 10)).setTo(20);
  labels(cv::Rect(30, 5, 10, 10)).setTo(30);
  const cv::Mat depth(labels.size(), CV_16UC1, cv::Scalar(1000));
  cv::Mat regions(labels.size(), CV_16UC1, cv::Scalar(1));
  regions(cv::Rect(5, 5, 10, 10)).setTo(2);  // object 2 apart, object 3 in the table's region
  const RealSegmentScore s = scoreRealSegments(regions, labels, depth);
  EXPECT_EQ(s.objects, 2);
  EXPECT_EQ(s.kept_apart, 1);
  EXPECT_EQ(s.table_whole, 1);
  EXPECT_NEAR(tableCoverage(regions, labels, depth), 1.0, 1e-12);
}

// An axis-aligned box from low to high, in BoxCorners order.
BoxCorners axisBox(const Eigen::Vector3d& low, const Eigen::Vector3d& high) {
  BoxCorners c;
  for (int back = 0; back < 2; ++back) {
    const double z = back ? high.z() : low.z();
    c[4 * back + 0] = {low.x(), low.y(), z};
    c[4 * back + 1] = {high.x(), low.y(), z};
    c[4 * back + 2] = {high.x(), high.y(), z};
    c[4 * back + 3] = {low.x(), high.y(), z};
  }
  return c;
}

TEST(BoxEval, CountsThePointsInsideAndTheVolumeOverThePointsBox) {
  // Points filling a 10 x 10 x 10 cm cube at 1 m.
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j)
      for (int k = 0; k <= 10; ++k) points.emplace_back(0.01 * i, 0.01 * j, 1.0 + 0.01 * k);
  EXPECT_NEAR(pointsBoxVolume(points), 1e-3, 1e-9);
  BoxModeScore score;
  // The cube itself, padded by 1 mm: everything inside, volume ratio ~1.06.
  const BoxCorners padded = axisBox({-0.001, -0.001, 0.999}, {0.101, 0.101, 1.101});
  score.add(&padded, points);
  // The lower half in x: 6 of 11 slices inside, volume 0.5.
  const BoxCorners half = axisBox({-0.001, -0.001, 0.999}, {0.0501, 0.101, 1.101});
  score.add(&half, points);
  score.add(nullptr, points);  // a failed box counts 0
  ASSERT_EQ(score.coverage.size(), 2u);
  EXPECT_DOUBLE_EQ(score.coverage[0], 1.0);
  EXPECT_NEAR(score.coverage[1], 6.0 / 11.0, 1e-12);
  EXPECT_NEAR(score.volume_ratio[0], 1.0612, 1e-3);
  EXPECT_NEAR(score.volume_ratio[1], 0.5316, 1e-3);
  EXPECT_EQ(score.failed, 1);
  EXPECT_NEAR(score.meanCoverage(), (1.0 + 6.0 / 11.0) / 3.0, 1e-12);
}

TEST(BoxEval, BoxableObjectsLeaveOutTheTableSmallThingsAndThingsCutByTheBorder) {
  const auto f = clutteredFrame();
  const auto objects = boxableObjects(f.truth, f.frame.depth.cols, f.frame.depth.rows, 300);
  ASSERT_FALSE(objects.empty());
  for (const auto* o : objects) {
    EXPECT_NE(o->kind, "table");
    EXPECT_GE(o->pixel_count, 300u);
    EXPECT_GT(o->image_box.x, 0);
    EXPECT_LT(o->image_box.br().x, f.frame.depth.cols);
  }
}

// FNV-1a over an image's bytes, row by row.
std::uint64_t hashImage(const cv::Mat& image, std::uint64_t hash) {
  for (int v = 0; v < image.rows; ++v) {
    const auto* row = image.ptr<unsigned char>(v);
    for (std::size_t i = 0; i < image.cols * image.elemSize(); ++i)
      hash = (hash ^ row[i]) * 0x100000001B3ull;
  }
  return hash;
}

// The splits are the same scenes wherever they are built: the release suite (GCC) and the
// sanitizer run (clang) score the same frames, and so do machines that report figures. The
// value is the hash of the depth and truth of the first 12 scenes of each split as the scenes
// are defined; a change of that definition (a new draw, a reordered draw) changes it, and so
// do draws whose order the compiler chooses (two in one argument list).
TEST(SceneSplits, ScenesAreTheSameWhicheverCompilerBuiltThem) {
  std::uint64_t hash = 0xCBF29CE484222325ull;
  for (const Split split : {Split::kTrain, Split::kValidation, Split::kTest}) {
    for (int i = 0; i < 12; ++i) {
      const EvalScene scene = evalScene(split, i);
      const synthetic::RenderedFrame frame =
          synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
      hash = hashImage(frame.frame.depth, hash);
      hash = hashImage(frame.truth.surface_labels, hash);
      hash = hashImage(frame.truth.object_labels, hash);
    }
  }
  EXPECT_EQ(hash, 0x96B3FEA12CD8BB83ull) << std::hex << hash;
}

TEST(SceneSplits, SplitsShareNoSeedAndEveryDrawnSceneGenerates) {
  std::set<std::uint64_t> seeds;
  std::map<std::string, int> with;  // scenes with each feature of the wider distribution
  int plain = 0;
  for (const Split split : {Split::kTrain, Split::kValidation, Split::kTest})
    for (int i = 0; i < 200; ++i) {
      const EvalScene scene = evalScene(split, i);
      EXPECT_TRUE(seeds.insert(scene.params.seed).second);
      EXPECT_NO_THROW(synthetic::SyntheticScene{scene.params}) << formatSplit(split) << " " << i;
      // A camera pose that is not finite renders a frame without depth.
      EXPECT_TRUE(synthetic::SyntheticScene(scene.params)
                      .worldFromCamera(scene.frame_index)
                      .matrix()
                      .allFinite())
          << formatSplit(split) << " " << i;
      const synthetic::SceneParams& p = scene.params;
      if (!scene.curved_clutter) {
        ++plain;
        // Plain scenes hold no curved object.
        EXPECT_EQ(p.bowls_max + p.cups_max + p.tins_max + p.balls_max + p.lying_tins_max +
                      p.bins_max + p.columns_max + p.tori_max + p.mounds_max,
                  0);
        EXPECT_FALSE(p.thin_object_lids);
      }
      with["free look"] += p.free_look;
      with["roll"] += p.camera_roll_max_deg > 0;
      with["extra boxes"] += p.extra_boxes_max > 0;
      with["stacked"] += p.stacked_boxes_max > 0;
      with["touching"] += p.touching_box_pairs_max > 0;
      with["thin"] += p.thin_objects_max > 0;
      with["shelf"] += p.shelves_max > 0;
      with["flying pixels"] += p.kinect.flying_pixel_rate > 0;
      with["holes"] += p.kinect.holes_max > 0;
      if (scene.curved_clutter) {
        with["lying tins"] += p.lying_tins_max > 0;
        with["bins"] += p.bins_max > 0;
        with["columns"] += p.columns_max > 0;
        with["tori"] += p.tori_max > 0;
        with["mounds"] += p.mounds_max > 0;
      }
    }
  EXPECT_EQ(plain, 300);
  for (const char* feature :
       {"free look", "roll", "extra boxes", "stacked", "touching", "thin", "shelf", "flying pixels",
        "holes", "lying tins", "bins", "columns", "tori", "mounds"})
    EXPECT_GT(with[feature], 30) << feature;  // at least 5% of the 600 scenes
  EXPECT_EQ(parseSplit("val"), Split::kValidation);
  EXPECT_FALSE(parseSplit("holdout").has_value());
}

}  // namespace
}  // namespace shapesense::eval
