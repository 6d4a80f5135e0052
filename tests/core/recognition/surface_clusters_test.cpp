// The clusters of a scene's surface off its supports (surface_clusters.h): of a table with two
// boxes made by hand; the poses that lay one box on another; and taught objects with neither
// features nor flat faces found by their clusters in a later frame, against the synthetic truth.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/core/recognition/surface_clusters.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/recognition_eval.h"
#include "two_views.h"

namespace shapesense {
namespace {

constexpr float kStep = 0.005f;
// The table top lies this far below the camera, which looks down on the boxes' tops.
constexpr float kTableY = 0.8f;

// A table top 1 m square at y = kTableY, z in [1, 2].
void addTable(SurfaceCloud& cloud) {
  for (float x = -0.5f; x <= 0.5f; x += kStep)
    for (float z = 1.0f; z <= 2.0f; z += kStep) {
      cloud.points.emplace_back(x, kTableY, z);
      cloud.normals.emplace_back(0.0f, -1.0f, 0.0f);
    }
}

// The front (z = z0) and top (y = 0.3 - height) of a box standing on the table.
void addBox(SurfaceCloud& cloud, float x0, float z0, float width, float height, float depth) {
  for (float x = x0 - width / 2; x <= x0 + width / 2 + 1e-6f; x += kStep) {
    for (float y = kTableY - height; y <= kTableY + 1e-6f; y += kStep) {
      cloud.points.emplace_back(x, y, z0);
      cloud.normals.emplace_back(0.0f, 0.0f, -1.0f);
    }
    for (float z = z0; z <= z0 + depth + 1e-6f; z += kStep) {
      cloud.points.emplace_back(x, kTableY - height, z);
      cloud.normals.emplace_back(0.0f, -1.0f, 0.0f);
    }
  }
}

FlatFaces tableFace() {
  FaceRectangle table;
  table.normal = Eigen::Vector3f(0.0f, -1.0f, 0.0f);
  table.centre = Eigen::Vector3f(0.0f, kTableY, 1.5f);
  table.axes = {Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ()};
  table.sides = {1.0f, 1.0f};
  return {{table}, {}};
}

TEST(SurfaceClusters, TwoBoxesOnATableAreTwoClustersOfTheirSize) {
  SurfaceCloud scene;
  addTable(scene);
  addBox(scene, -0.2f, 1.4f, 0.10f, 0.15f, 0.08f);
  addBox(scene, 0.2f, 1.5f, 0.20f, 0.06f, 0.12f);
  std::vector<SurfaceCluster> clusters = surfaceClusters(scene, tableFace());
  ASSERT_EQ(clusters.size(), 2u);
  std::sort(clusters.begin(), clusters.end(),
            [](const auto& a, const auto& b) { return a.box.centre.x() < b.box.centre.x(); });
  // Both stand on the table: each box's height above it (its top is seen), and the sides of
  // its footprint (its front and top), within a voxel.
  const struct {
    float width, height, depth;
  } truth[2] = {{0.10f, 0.15f, 0.08f}, {0.20f, 0.06f, 0.12f}};
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(clusters[static_cast<std::size_t>(i)].standing_box);
    const OrientedBox& box = *clusters[static_cast<std::size_t>(i)].standing_box;
    EXPECT_NEAR(box.axes.col(2).dot(Eigen::Vector3f(0.0f, -1.0f, 0.0f)), 1.0f, 1e-4f);
    EXPECT_NEAR(box.size.z(), truth[i].height, kStep);
    EXPECT_NEAR(std::max(box.size.x(), box.size.y()), std::max(truth[i].width, truth[i].depth),
                kStep);
    EXPECT_NEAR(std::min(box.size.x(), box.size.y()), std::min(truth[i].width, truth[i].depth),
                kStep);
    // The bottom face lies on the table.
    EXPECT_NEAR((box.centre - 0.5f * box.size.z() * box.axes.col(2)).y(), kTableY, 1e-3f);
  }
  EXPECT_NEAR(clusters[0].box.centre.x(), -0.2f, 0.01f);
  EXPECT_NEAR(clusters[1].box.centre.x(), 0.2f, 0.01f);
  // Without a support, the table joins both boxes into one cluster, standing on nothing.
  const std::vector<SurfaceCluster> unsupported = surfaceClusters(scene, FlatFaces{});
  ASSERT_EQ(unsupported.size(), 1u);
  EXPECT_FALSE(unsupported[0].standing_box);
}

// A box turned about the table's normal: its standing box has its sides along the box's, and
// one of the four standing poses carries the box's own standing box onto the turned one's.
TEST(SurfaceClusters, AStandingBoxLiesAlongTheSidesOfWhatStands) {
  SurfaceCloud box;
  addBox(box, 0.0f, 1.4f, 0.24f, 0.10f, 0.12f);
  const Eigen::Vector4f table(0.0f, -1.0f, 0.0f, kTableY);
  const Eigen::Vector3f pivot(0.0f, kTableY, 1.4f);
  const Eigen::Isometry3f motion =
      Eigen::Translation3f(0.05f, 0.0f, 0.1f) * Eigen::Translation3f(pivot) *
      Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitY()) * Eigen::Translation3f(-pivot);
  SurfaceCloud moved;
  for (std::size_t i = 0; i < box.size(); ++i) {
    moved.points.push_back(motion * box.points[i]);
    moved.normals.push_back(motion.linear() * box.normals[i]);
  }
  const OrientedBox before = standingBox(box, table);
  const OrientedBox after = standingBox(moved, table);
  EXPECT_NEAR(after.size.z(), 0.10f, 1e-3f);
  EXPECT_NEAR(std::max(after.size.x(), after.size.y()), 0.24f, kStep);
  EXPECT_NEAR(std::min(after.size.x(), after.size.y()), 0.12f, kStep);
  // One side lies along the turned box's front (its x axis turned by 0.5 rad).
  const Eigen::Vector3f front = motion.linear() * Eigen::Vector3f::UnitX();
  EXPECT_GT(
      std::max(std::abs(after.axes.col(0).dot(front)), std::abs(after.axes.col(1).dot(front))),
      std::cos(0.01f));
  const std::vector<Eigen::Isometry3f> poses = standingPoses(before, after);
  ASSERT_EQ(poses.size(), 4u);
  int holding = 0;
  for (const Eigen::Isometry3f& pose : poses)
    if ((pose.linear() - motion.linear()).norm() < 1e-2f &&
        (pose.translation() - motion.translation()).norm() < 2e-3f)
      ++holding;
  EXPECT_EQ(holding, 1);
}

// A trail of flying pixels behind a box's top, beyond a gap wider than standing_box_gap_m,
// leaves its standing box as it was.
TEST(SurfaceClusters, AStandingBoxLeavesATrailBeyondAGapOut) {
  SurfaceCloud box;
  addBox(box, 0.0f, 1.4f, 0.20f, 0.10f, 0.12f);
  const Eigen::Vector4f table(0.0f, -1.0f, 0.0f, kTableY);
  const OrientedBox alone = standingBox(box, table);
  SurfaceCloud trailed = box;
  for (int k = 1; k <= 4; ++k) {
    trailed.points.emplace_back(0.0f, kTableY - 0.10f, 1.52f + 0.03f * static_cast<float>(k));
    trailed.normals.emplace_back(0.0f, -1.0f, 0.0f);
  }
  const OrientedBox with_trail = standingBox(trailed, table);
  EXPECT_NEAR(std::min(alone.size.x(), alone.size.y()), 0.12f, kStep);
  EXPECT_TRUE(with_trail.size.isApprox(alone.size, 1e-4f))
      << with_trail.size.transpose() << " against " << alone.size.transpose();
  // Without the gap the trail is the box's own surface.
  SurfaceClusterParams no_gap;
  no_gap.standing_box_gap_m = 0.1f;
  EXPECT_GT(std::min(standingBox(trailed, table, no_gap).size.x(),
                     standingBox(trailed, table, no_gap).size.y()),
            0.2f);
}

TEST(SurfaceClusters, BoxAlignedPosesAreTheTwentyFourTurnsAndHoldTheMotion) {
  SurfaceCloud box;
  addBox(box, 0.0f, 1.0f, 0.24f, 0.10f, 0.05f);
  const Eigen::Isometry3f motion =
      Eigen::Translation3f(0.1f, -0.05f, 0.3f) *
      Eigen::AngleAxisf(0.6f, Eigen::Vector3f(0.2f, 1.0f, 0.3f).normalized());
  std::vector<Eigen::Vector3f> moved;
  for (const Eigen::Vector3f& p : box.points) moved.push_back(motion * p);
  const std::vector<Eigen::Isometry3f> poses =
      boxAlignedPoses(principalBox(box.points), principalBox(moved));
  ASSERT_EQ(poses.size(), 24u);
  int distinct = 0, near_motion = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(poses[i].linear().determinant(), 1.0f, 1e-4f);
    bool repeated = false;
    for (std::size_t j = 0; j < i; ++j)
      repeated = repeated || (poses[i].linear() - poses[j].linear()).norm() < 1e-3f;
    distinct += repeated ? 0 : 1;
    if ((poses[i].linear() - motion.linear()).norm() < 1e-3f &&
        (poses[i].translation() - motion.translation()).norm() < 1e-3f)
      ++near_motion;
  }
  EXPECT_EQ(distinct, 24);
  EXPECT_EQ(near_motion, 1);
}

TEST(SurfaceClusters, BoxSizesAgreeWithinTheSlackInAnyOrder) {
  OrientedBox model, cluster;
  model.size = Eigen::Vector3f(0.10f, 0.30f, 0.20f);
  cluster.size = Eigen::Vector3f(0.20f, 0.10f, 0.30f);
  EXPECT_TRUE(similarBoxSizes(model, cluster, 0.0f));
  cluster.size = Eigen::Vector3f(0.26f, 0.10f, 0.30f);  // 6 cm more: 0.2 x 20 cm + 2 cm
  EXPECT_TRUE(similarBoxSizes(model, cluster, 0.2f));
  EXPECT_FALSE(similarBoxSizes(model, cluster, 0.1f));
}

// The models of the teach view's objects of at least 1500 pixels with neither features nor
// flat faces: only their clusters can give their poses.
std::vector<std::pair<const synthetic::TruthObject*, ObjectModel>> shapelessModels(
    const synthetic::RenderedFrame& teach) {
  std::vector<std::pair<const synthetic::TruthObject*, ObjectModel>> out;
  for (const auto& object : teach.truth.objects) {
    if (object.pixel_count < 1500) continue;
    try {
      ObjectModel model = teachObjectModel(object.name, teach.frame.depth, teach.frame.intrinsics,
                                           teach.truth.object_labels == object.id);
      model.features.clear();
      model.flat_faces = {};
      out.emplace_back(&object, std::move(model));
    } catch (const std::invalid_argument&) {
    }
  }
  return out;
}

// A taught object with neither features nor flat faces is found by its cluster in a later
// frame of the same scene (the truth motion from both camera poses); without the clusters'
// poses, it is not found at all.
TEST(SurfaceClustersQuality, AnObjectWithoutFeaturesOrFacesIsFoundByItsCluster) {
  int found = 0, wrong = 0, tried = 0, found_without = 0;
  ObjectMatchParams without;
  without.poses_from_clusters = false;
  for (std::uint64_t seed = 21; seed < 27; ++seed) {
    const auto [teach, later, truth] = testing::twoViews(seed, 150);
    const SceneSurface later_surface(later.frame.depth, later.frame.intrinsics);
    for (const auto& [object, model] : shapelessModels(teach)) {
      ++tried;
      if (findObject(model, later_surface, without)) ++found_without;
      const auto detection = findObject(model, later_surface);
      if (!detection) continue;
      const eval::PoseErrorDeg error = testing::taughtObjectError(detection->camera_from_model,
                                                                  truth, model.box.centre, *object);
      std::printf("seed %lu %s: error %.1f mm %.2f deg\n", seed, object->name.c_str(),
                  1e3 * error.translation_m, error.rotation_deg);
      if (testing::withinRecallTolerance(error)) {
        ++found;
      } else {
        ++wrong;
      }
    }
  }
  std::printf("found %d of %d by their clusters, %d with a wrong pose\n", found, tried, wrong);
  // Regression record, not a requirement: the clusters alone reached 20 of 27 objects with no
  // wrong pose; with features and faces too these scenes require 0.9
  // (ObjectMatchingQuality.FindsATaughtBoxInALaterFrame). An object touching another shares
  // its cluster, whose box is then too large for the model's.
  EXPECT_GE(tried, 15);
  EXPECT_EQ(found_without, 0);
  EXPECT_GE(found, 0.5 * tried);
  EXPECT_LE(wrong, 2);
}

}  // namespace
}  // namespace shapesense
