#pragma once
// A TestServer cache holding frames of one synthetic scene with the detectors' results, for the
// taught-object calls: an object taught from the first frame is looked for in the others (the
// camera sways between them; the renderer's camera poses give the truth motion).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "server_fixture.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::testing {

struct ObjectScene {
  /// The scene of the core's object model file test (its box1 teaches well).
  static constexpr std::uint64_t kSeed = 21;
  /// Frame indices rendered into the cache, as sequences 0, 1, ...: the teaching frame, then a
  /// later one (5 s on) the camera has swayed in.
  static constexpr int kRenderIndices[] = {0, 150};

  /// Renders the frames into srv's cache (frame i at kServerT0 + i * kFramePeriodNs) and
  /// publishes the default detector chain's results (bowls off) for them.
  explicit ObjectScene(TestServer& srv);

  /// The ROI around `name` in frame `sequence` (its truth image box).
  cv::Rect roi(const std::string& name, int sequence = 0) const;
  /// The motion of the scene's content from frame 0's camera to frame `sequence`'s.
  Eigen::Isometry3d motion(int sequence) const;

  std::vector<synthetic::TruthFrame> truths;
};

/// Limits under which a query waits for the query worker as long as it takes: teaching and
/// finding take long on a loaded machine, and these tests are about them, not the load limits
/// (query_limits_test.cpp).
ServerLimits patientLimits();

/// Teaches `name` from the ROI `roi` of the frame at `at_ns`.
grpc::Status teachObject(TestServer& srv, std::int64_t at_ns, const cv::Rect& roi,
                         const std::string& name, bool replace, v1::TeachObjectResponse& response);

/// Rotation angle of a quaternion, degrees.
double rotationDeg(const v1::Quaternion& q);

}  // namespace shapesense::testing
