// Flat faces and convex edges (flat_faces.h): of a surface made by hand with known sides; and a
// taught box found by its faces alone in a later frame, against the synthetic truth.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "shapesense/core/recognition/flat_faces.h"
#include "shapesense/core/recognition/object_matching.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/recognition_eval.h"
#include "two_views.h"

namespace shapesense {
namespace {

// The camera-facing front (x in [-w/2, w/2], y in [-h/2, h/2], z = z0) and top (y = -h/2, z in
// [z0, z0 + depth]) of a box, on a 5 mm grid, with normals towards the camera (-z, -y). With
// `concave`, the top is turned into a floor in front of the front face instead (y = h/2, z in
// [z0 - depth, z0]): the faces meet, but at a concave edge.
SurfaceCloud twoFaces(float width, float height, float depth, float z0, bool concave) {
  constexpr float kStep = 0.005f;
  SurfaceCloud out;
  for (float x = -width / 2; x <= width / 2 + 1e-6f; x += kStep) {
    for (float y = -height / 2; y <= height / 2 + 1e-6f; y += kStep) {
      out.points.emplace_back(x, y, z0);
      out.normals.emplace_back(0.0f, 0.0f, -1.0f);
    }
    for (float z = kStep; z <= depth + 1e-6f; z += kStep) {
      out.points.emplace_back(x, concave ? height / 2 : -height / 2, concave ? z0 - z : z0 + z);
      out.normals.emplace_back(0.0f, -1.0f, 0.0f);
    }
  }
  return out;
}

TEST(FlatFaces, TwoFacesOfABoxMeetAtOneConvexEdge) {
  const SurfaceCloud box = twoFaces(0.20f, 0.10f, 0.15f, 1.0f, false);
  const std::vector<SurfaceFace> faces = facesOfSurface(box);
  ASSERT_EQ(faces.size(), 2u);
  const std::vector<FaceEdge> edges = convexEdges(faces);
  ASSERT_EQ(edges.size(), 1u);
  const FaceEdge& edge = edges[0];
  // The edge runs along x through (., -0.05, 1.0); within 1 mm, 0.5 deg.
  EXPECT_GT(std::abs(edge.direction.x()), std::cos(0.5f * 3.14159f / 180.0f));
  const Eigen::Vector3f offset = edge.line_point - Eigen::Vector3f(0.0f, -0.05f, 1.0f);
  EXPECT_LT((offset - offset.dot(edge.direction) * edge.direction).norm(), 0.001f);
  // Its length and the faces' reach within 1.5 cm (the ends leave out a few per cent).
  EXPECT_NEAR(edge.end - edge.start, 0.20f, 0.015f);
  const float front_reach = faces[0].normal.z() < -0.9f ? edge.reach[0] : edge.reach[1];
  const float top_reach = faces[0].normal.z() < -0.9f ? edge.reach[1] : edge.reach[0];
  EXPECT_NEAR(front_reach, 0.10f, 0.015f);
  EXPECT_NEAR(top_reach, 0.15f, 0.015f);
}

TEST(FlatFaces, AFloorInFrontOfAFaceIsNoConvexEdge) {
  const SurfaceCloud corner = twoFaces(0.20f, 0.10f, 0.15f, 1.0f, true);
  const std::vector<SurfaceFace> faces = facesOfSurface(corner);
  ASSERT_EQ(faces.size(), 2u);
  EXPECT_TRUE(convexEdges(faces).empty());
}

TEST(FlatFaces, AnEdgeLaidOnItselfMovedGivesTheMotion) {
  const SurfaceCloud box = twoFaces(0.20f, 0.10f, 0.15f, 1.0f, false);
  Eigen::Isometry3f motion = Eigen::Isometry3f::Identity();
  motion.linear() =
      Eigen::AngleAxisf(0.4f, Eigen::Vector3f(0.2f, 1.0f, -0.3f).normalized()).toRotationMatrix();
  motion.translation() = Eigen::Vector3f(0.1f, -0.05f, 0.3f);
  SurfaceCloud moved;
  for (std::size_t i = 0; i < box.size(); ++i) {
    moved.points.push_back(motion * box.points[i]);
    moved.normals.push_back(motion.linear() * box.normals[i]);
  }
  const std::vector<FaceEdge> model = convexEdges(facesOfSurface(box));
  const std::vector<FaceEdge> scene = convexEdges(facesOfSurface(moved));
  ASSERT_EQ(model.size(), 1u);
  ASSERT_EQ(scene.size(), 1u);
  const auto poses = edgeAlignedPoses(model[0], scene[0], 5.0f, 0.03f);
  // The faces differ in size, so only the right assignment passes, and both ends agree.
  ASSERT_EQ(poses.size(), 1u);
  const Eigen::AngleAxisf turn(poses[0].linear() * motion.linear().transpose());
  EXPECT_LT(std::abs(turn.angle()), 0.5f * 3.14159f / 180.0f);
  EXPECT_LT((poses[0].translation() - motion.translation()).norm(), 0.003f);
}

// The models of the teach view's boxes of at least 1500 pixels, with their features taken
// away (the truth object beside each); boxes too small to teach are left out.
std::vector<std::pair<const synthetic::TruthObject*, ObjectModel>> featurelessBoxModels(
    const synthetic::RenderedFrame& teach) {
  std::vector<std::pair<const synthetic::TruthObject*, ObjectModel>> out;
  for (const auto& object : teach.truth.objects) {
    if (object.kind != "box" || object.pixel_count < 1500) continue;
    try {
      ObjectModel model = teachObjectModel(object.name, teach.frame.depth, teach.frame.intrinsics,
                                           teach.truth.object_labels == object.id);
      model.features.clear();
      out.emplace_back(&object, std::move(model));
    } catch (const std::invalid_argument&) {
    }
  }
  return out;
}

// With its features taken away, a taught box is found by its faces alone in a later frame of
// the same scene, where the camera moved (the truth motion from both camera poses).
TEST(FlatFacesQuality, ABoxWithoutFeaturesIsFoundByItsFaces) {
  int found = 0, wrong = 0, tried = 0;
  for (std::uint64_t seed = 21; seed < 27; ++seed) {
    const auto [teach, later, truth] = testing::twoViews(seed, 150);
    const SceneSurface later_surface(later.frame.depth, later.frame.intrinsics);
    for (const auto& [box, model] : featurelessBoxModels(teach)) {
      const synthetic::TruthObject& object = *box;
      ++tried;
      const auto detection = findObject(model, later_surface);
      if (!detection) continue;
      const eval::PoseErrorDeg error =
          testing::taughtObjectError(detection->camera_from_model, truth, model.box.centre, object);
      std::printf("seed %lu %s: error %.1f mm %.2f deg\n", seed, object.name.c_str(),
                  1e3 * error.translation_m, error.rotation_deg);
      if (testing::withinRecallTolerance(error)) {
        ++found;
      } else {
        ++wrong;
      }
    }
  }
  std::printf("found %d of %d by their faces, %d with a wrong pose\n", found, tried, wrong);
  // Regression record, not a requirement: the faces reached 11 of 18 boxes with 1 wrong pose
  // (a box slid 1.5 cm along its edge), the features and faces together 20 of 21 of these
  // objects (ObjectMatchingQuality.FindsATaughtBoxInALaterFrame, whose requirement is 0.9).
  // A box that shows one face in either view, or whose faces the plane detector joins to a
  // neighbour's, has no face or edge of its size to be laid on.
  EXPECT_GE(tried, 15);
  EXPECT_GE(found, 0.5 * tried);
  EXPECT_LE(wrong, 2);
}

// The poses laid by faces are bounded per model and frame: with none allowed, a box found by
// its faces alone is not found.
TEST(FlatFaces, ThePosesLaidByFacesAreCapped) {
  const auto [teach, later, truth] = testing::twoViews(21, 150);
  const SceneSurface later_surface(later.frame.depth, later.frame.intrinsics);
  ObjectMatchParams none;
  none.max_flat_face_poses = 0;
  none.poses_from_clusters = false;
  int checked = 0;
  for (const auto& [box, model] : featurelessBoxModels(teach)) {
    if (!findObject(model, later_surface)) continue;
    ++checked;
    EXPECT_FALSE(findObject(model, later_surface, none)) << box->name;
  }
  EXPECT_GE(checked, 1);
}

}  // namespace
}  // namespace shapesense
