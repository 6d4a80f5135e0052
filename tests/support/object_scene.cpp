#include "object_scene.h"

#include <cmath>

#include "shapesense/core/pipeline/detector_chain.h"

namespace shapesense::testing {

ObjectScene::ObjectScene(TestServer& srv) {
  synthetic::SceneParams params;
  params.seed = kSeed;
  const synthetic::SyntheticScene scene(params);
  DetectorConfig config;
  config.bowls = false;
  const DetectorChain chain = makeDetectorChain(config);
  std::uint64_t sequence = 0;
  for (const int index : kRenderIndices) {
    auto rendered =
        scene.render(index, kServerT0 + static_cast<TimestampNs>(sequence) * kFramePeriodNs);
    rendered.frame.sequence = sequence;
    truths.push_back(rendered.truth);
    auto frame = std::make_shared<const Frame>(std::move(rendered.frame));
    EXPECT_TRUE(srv.cache().insert(frame));
    EXPECT_TRUE(srv.cache().publishResults(
        sequence, std::make_shared<const FrameResults>(chain.process(*frame))));
    ++sequence;
  }
}

cv::Rect ObjectScene::roi(const std::string& name, int sequence) const {
  for (const auto& object : truths.at(sequence).objects)
    if (object.name == name) return object.image_box;
  ADD_FAILURE() << "no object " << name << " in frame " << sequence;
  return {};
}

Eigen::Isometry3d ObjectScene::motion(int sequence) const {
  return truths.at(sequence).world_from_camera.inverse() * truths.front().world_from_camera;
}

ServerLimits patientLimits() {
  ServerLimits limits;
  limits.queries.max_wait = std::chrono::seconds(30);
  return limits;
}

grpc::Status teachObject(TestServer& srv, std::int64_t at_ns, const cv::Rect& roi,
                         const std::string& name, bool replace, v1::TeachObjectResponse& response) {
  v1::TeachObjectRequest request;
  request.set_at_ns(at_ns);
  request.mutable_p1()->set_x(roi.x);
  request.mutable_p1()->set_y(roi.y);
  request.mutable_p2()->set_x(roi.x + roi.width - 1);
  request.mutable_p2()->set_y(roi.y + roi.height - 1);
  request.set_name(name);
  request.set_replace(replace);
  return srv.stub().TeachObject(clientContext(std::chrono::seconds(30)).get(), request, &response);
}

double rotationDeg(const v1::Quaternion& q) {
  const double w = std::min(1.0, std::abs(q.w()));
  return 2.0 * std::acos(w) * 180.0 / M_PI;
}

}  // namespace shapesense::testing
