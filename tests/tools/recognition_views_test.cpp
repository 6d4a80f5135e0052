// The recognition ground truth: other views are the same layout from the drawn poses, the truth
// transform between views moves every object's truth pose and rendered surface where that view
// shows it, and cases are pure functions of (split, index).

#include "shapesense/eval/recognition_views.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <string>

#include <opencv2/core.hpp>

namespace shapesense::eval {
namespace {

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

const synthetic::TruthObject& object(const synthetic::TruthFrame& truth, std::uint16_t id) {
  return truth.objects.at(id - 1u);
}

// Of the object's teach pixels whose ideal 3D point teachToView moves into `view`'s image, the
// share that `view` shows at that depth (within 5 mm) and labels as the same object.
double shareFoundWhereTheTruthPutsIt(const RecognitionCase& c, const RecognitionView& view,
                                     std::uint16_t id) {
  const CameraIntrinsics k = c.params.intrinsics;
  const Eigen::Isometry3d to_view = teachToView(c, view);
  const synthetic::TruthFrame& from = c.teach.rendered.truth;
  const synthetic::TruthFrame& to = view.rendered.truth;
  std::size_t inside = 0, found = 0;
  for (int v = 0; v < from.object_labels.rows; ++v)
    for (int u = 0; u < from.object_labels.cols; ++u) {
      if (from.object_labels.at<std::uint16_t>(v, u) != id) continue;
      const Eigen::Vector3d p = to_view * k.backproject(u, v, from.ideal_depth.at<float>(v, u));
      const Eigen::Vector2d px = k.project(p);
      const int pu = static_cast<int>(std::lround(px.x()));
      const int pv = static_cast<int>(std::lround(px.y()));
      if (p.z() <= 0 || pu < 0 || pv < 0 || pu >= k.width || pv >= k.height) continue;
      ++inside;
      found += std::abs(to.ideal_depth.at<float>(pv, pu) - p.z()) < 0.005 &&
               to.object_labels.at<std::uint16_t>(pv, pu) == id;
    }
  return inside > 0 ? static_cast<double>(found) / static_cast<double>(inside) : 0.0;
}

TEST(RecognitionViews, TheTruthTransformMovesEveryTaughtObjectToItsPoseInTheOtherView) {
  int pairs = 0;
  for (int i = 0; i < 5; ++i) {
    SCOPED_TRACE("validation case " + std::to_string(i));
    const RecognitionCase c = recognitionCase(Split::kValidation, i);
    ASSERT_EQ(c.others.size(), 3u);
    const std::vector<std::uint16_t> ids = teachableObjects(c);
    EXPECT_FALSE(ids.empty());
    for (const RecognitionView& view : c.others) {
      const Eigen::Isometry3d to_view = teachToView(c, view);
      for (const std::uint16_t id : ids) {
        const synthetic::TruthObject& taught = object(c.teach.rendered.truth, id);
        const synthetic::TruthObject& seen = object(view.rendered.truth, id);
        if (seen.pixel_count == 0) continue;
        ++pairs;
        EXPECT_LT((seen.center - to_view * taught.center).norm(), 1e-3) << taught.name;
        // Axis 2 is the object's own axis; about it many objects are symmetric.
        EXPECT_LT(angleDeg(seen.rotation.col(2), to_view.linear() * taught.rotation.col(2)), 0.1)
            << taught.name;
        // The rendering agrees: most of what the teach view shows of the object is where the
        // truth transform puts it (the rest is hidden from the new side, or by another object).
        if (visibleShare(c, view, id) > 0.7) {
          EXPECT_GT(shareFoundWhereTheTruthPutsIt(c, view, id), 0.5) << taught.name;
        }
      }
    }
  }
  EXPECT_GT(pairs, 20);
}

TEST(RecognitionViews, OtherViewsOrbitTheTableAndLookWhereTheTeachViewLooked) {
  for (int i = 0; i < 5; ++i) {
    SCOPED_TRACE("validation case " + std::to_string(i));
    const RecognitionCase c = recognitionCase(Split::kValidation, i);
    const synthetic::TruthFrame& teach = c.teach.rendered.truth;
    const auto table = std::find_if(teach.objects.begin(), teach.objects.end(),
                                    [](const auto& o) { return o.kind == "table"; });
    ASSERT_NE(table, teach.objects.end());
    const Eigen::Vector3d pivot = c.teach.world_from_camera * table->center;
    const Eigen::Vector3d eye = c.teach.world_from_camera.translation();
    // The teach camera's view of the table top's centre, where its optical axis meets it.
    const Eigen::Vector3d forward = c.teach.world_from_camera.linear().col(2);
    const double top = pivot.z() + table->size.z() / 2;
    const Eigen::Vector3d aim = eye + forward * ((top - eye.z()) / forward.z());
    EXPECT_TRUE(c.teach.rendered.truth.world_from_camera.isApprox(c.teach.world_from_camera, 0.0));
    for (const RecognitionView& view : c.others) {
      EXPECT_TRUE(view.rendered.truth.world_from_camera.isApprox(view.world_from_camera, 0.0));
      const Eigen::Vector3d other = view.world_from_camera.translation();
      const Eigen::Vector2d a = (eye - pivot).head<2>(), b = (other - pivot).head<2>();
      EXPECT_NEAR(a.norm(), b.norm(), 1e-9);  // an orbit about the vertical through the pivot
      const double azimuth =
          std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b))) * 180.0 / std::numbers::pi;
      EXPECT_GE(azimuth, 10.0 - 1e-9);
      EXPECT_LE(azimuth, 35.0 + 1e-9);
      EXPECT_LE(std::abs(other.z() - eye.z()), 0.15 + 1e-9);
      // It looks at the orbited aim point: that projects to the principal point (up to the
      // camera's roll of about a degree turning the rise sideways).
      const Eigen::Vector3d turned =
          pivot + Eigen::AngleAxisd(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)),
                                    Eigen::Vector3d::UnitZ()) *
                      (aim - pivot);
      const Eigen::Vector2d px =
          c.params.intrinsics.project(view.world_from_camera.inverse() * turned);
      EXPECT_NEAR(px.x(), c.params.intrinsics.cx, 2.0);
      EXPECT_NEAR(px.y(), c.params.intrinsics.cy, 1e-6);
      // Roll kept: the camera's x axis stays as level as the teach camera's.
      EXPECT_NEAR(view.world_from_camera.linear().col(0).z(),
                  c.teach.world_from_camera.linear().col(0).z(), 1e-9);
      // A fresh frame: the noise differs from the teach view's.
      EXPECT_NE(view.rendered.frame.sequence, c.teach.rendered.frame.sequence);
    }
  }
}

TEST(RecognitionViews, CasesArePureFunctionsOfSplitAndIndex) {
  const RecognitionCase a = recognitionCase(Split::kTest, 3);
  const RecognitionCase b = recognitionCase(Split::kTest, 3);
  EXPECT_TRUE(identical(a.teach.rendered.frame.depth, b.teach.rendered.frame.depth));
  ASSERT_EQ(a.others.size(), b.others.size());
  for (std::size_t v = 0; v < a.others.size(); ++v) {
    EXPECT_TRUE(identical(a.others[v].rendered.frame.depth, b.others[v].rendered.frame.depth));
    EXPECT_TRUE(a.others[v].world_from_camera.isApprox(b.others[v].world_from_camera, 0.0));
  }
  // Asking for fewer views gives the first of them.
  const RecognitionCase one = recognitionCase(Split::kTest, 3, 1);
  ASSERT_EQ(one.others.size(), 1u);
  EXPECT_TRUE(identical(one.others[0].rendered.frame.depth, a.others[0].rendered.frame.depth));
  EXPECT_THROW(recognitionCase(Split::kTest, -1), std::invalid_argument);
}

TEST(RecognitionViews, SplitsShareNoSeedWithEachOtherOrWithTheEvaluationScenes) {
  std::set<std::uint64_t> seeds;
  for (const Split split : {Split::kTrain, Split::kValidation, Split::kTest})
    for (int i = 0; i < 200; ++i) seeds.insert(evalScene(split, i).params.seed);
  for (const Split split : {Split::kTrain, Split::kValidation, Split::kTest})
    for (int i = 0; i < 3; ++i)
      EXPECT_TRUE(seeds.insert(recognitionCase(split, i, 0).params.seed).second);
}

}  // namespace
}  // namespace shapesense::eval
