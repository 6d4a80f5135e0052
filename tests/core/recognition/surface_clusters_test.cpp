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

// A table top 1 m square at y = 0.3 (below the camera), z in [1, 2].
void addTable(SurfaceCloud& cloud) {
  for (float x = -0.5f; x <= 0.5f; x += kStep)
    for (float z = 1.0f; z <= 2.0f; z += kStep) {
      cloud.points.emplace_back(x, 0.3f, z);
      cloud.normals.emplace_back(0.0f, -1.0f, 0.0f);
    }
}

// The front (z = z0) and top (y = 0.3 - height) of a box standing on the table.
void addBox(SurfaceCloud& cloud, float x0, float z0, float width, float height, float depth) {
  for (float x = x0 - width / 2; x <= x0 + width / 2 + 1e-6f; x += kStep) {
    for (float y = 0.3f - height; y <= 0.3f + 1e-6f; y += kStep) {
      cloud.points.emplace_back(x, y, z0);
      cloud.normals.emplace_back(0.0f, 0.0f, -1.0f);
    }
    for (float z = z0; z <= z0 + depth + 1e-6f; z += kStep) {
      cloud.points.emplace_back(x, 0.3f - height, z);
      cloud.normals.emplace_back(0.0f, -1.0f, 0.0f);
    }
  }
}

FlatFaces tableFace() {
  FaceRectangle table;
  table.normal = Eigen::Vector3f(0.0f, -1.0f, 0.0f);
  table.centre = Eigen::Vector3f(0.0f, 0.3f, 1.5f);
  table.axes = {Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitZ()};
  table.sides = {1.0f, 1.0f};
  return {{table}, {}};
}

Eigen::Vector3f sortedSizes(const OrientedBox& box) {
  Eigen::Vector3f sizes = box.size;
  std::sort(sizes.data(), sizes.data() + 3);
  return sizes;
}

TEST(SurfaceClusters, TwoBoxesOnATableAreTwoClustersOfTheirSize) {
  SurfaceCloud scene;
  addTable(scene);
  addBox(scene, -0.2f, 1.4f, 0.10f, 0.15f, 0.08f);
  addBox(scene, 0.2f, 1.5f, 0.20f, 0.06f, 0.12f);
  std::vector<OrientedBox> clusters = surfaceClusters(scene, tableFace());
  ASSERT_EQ(clusters.size(), 2u);
  std::sort(clusters.begin(), clusters.end(),
            [](const auto& a, const auto& b) { return a.centre.x() < b.centre.x(); });
  // What the surface shows of each box: its front and top, less the strip within the support's
  // band (1.5 cm) of the table.
  const Eigen::Vector3f first = sortedSizes(clusters[0]), second = sortedSizes(clusters[1]);
  EXPECT_NEAR(first[2], std::hypot(0.15f - 0.015f, 0.08f), 0.015f);
  EXPECT_NEAR(second[2], 0.20f, 0.01f);
  EXPECT_NEAR(clusters[0].centre.x(), -0.2f, 0.01f);
  EXPECT_NEAR(clusters[1].centre.x(), 0.2f, 0.01f);
  // Without a support, the table joins both boxes into one cluster.
  EXPECT_EQ(surfaceClusters(scene, FlatFaces{}).size(), 1u);
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
  // Regression record, not a requirement: the clusters alone reached 18 of 27 objects with no
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
