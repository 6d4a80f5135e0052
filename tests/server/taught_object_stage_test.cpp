// The taught-object stage in the running daemon (shapesensed --taught-objects on): objects
// taught from the first frame of the synthetic scene come back in the scene updates of later
// frames, at the renderer's truth motion, and in the frame summaries' count.

#include <algorithm>
#include <chrono>
#include <map>
#include <set>
#include <thread>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>

#include "object_scene.h"
#include "server_fixture.h"
#include "shapesense/core/recognition/object_model_file.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/server/daemon.h"
#include "shapesense/v1/shapesense.grpc.pb.h"
#include "test_paths.h"

namespace shapesense {
namespace {

using namespace std::chrono_literals;
using testing::clientContext;

constexpr std::uint64_t kSeed = 21;

// The boxes and tins of frame 0 of the daemon's synthetic scene, saved where the daemon loads
// its taught objects; returns their box centres (model frame) by name.
std::map<std::string, Eigen::Vector3d> teachFirstFrame(const synthetic::SyntheticScene& scene,
                                                       const std::filesystem::path& dir) {
  const auto teach = scene.render(0, 0);
  std::map<std::string, Eigen::Vector3d> centres;
  for (const auto& object : teach.truth.objects) {
    if ((object.kind != "box" && object.kind != "tin") || object.pixel_count < 3000) continue;
    try {
      const ObjectModel model =
          teachObjectModel(object.name, teach.frame.depth, teach.frame.intrinsics,
                           teach.truth.object_labels == object.id);
      saveObjectModel(model, ObjectModelParams{}, dir / (object.name + ".json"));
      centres[object.name] = model.box.centre.cast<double>();
    } catch (const std::invalid_argument&) {
      // Too little shape to teach.
    }
  }
  return centres;
}

DaemonOptions stageOptions(const std::filesystem::path& models) {
  DaemonOptions options;
  options.source = "synthetic:" + std::to_string(kSeed);
  options.listen = "127.0.0.1:0";
  options.object_models = models;
  options.find_taught_objects = true;
  // Only the stage under test: the frames come faster.
  options.detectors.segmentation.reset();
  options.detectors.planes.reset();
  options.detectors.bowls = false;
  options.detectors.track_things = false;
  options.record.root.clear();
  // The test polls the scene while the detector thread works: a query waits for a worker
  // rather than being refused (the load limits have tests of their own).
  options.limits = testing::patientLimits();
  return options;
}

TEST(TaughtObjectStage, TheDaemonFollowsTaughtObjectsAtTheTruthMotion) {
  const auto models = testing::scratchDir("taught_object_stage");
  synthetic::SceneParams params;
  params.seed = kSeed;
  const synthetic::SyntheticScene scene(params);
  const auto centres = teachFirstFrame(scene, models);
  ASSERT_GE(centres.size(), 2u);
  const Eigen::Isometry3d world_from_teaching = scene.worldFromCamera(0);

  Daemon daemon(stageOptions(models));
  auto stub = v1::ShapeSense::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(daemon.port()), grpc::InsecureChannelCredentials()));

  // Scene updates until every taught object has been reported in some frame (each is searched
  // for in turn, one a frame, then followed).
  std::set<std::string> seen;
  int checked = 0;
  const auto until = std::chrono::steady_clock::now() + 60s;
  std::uint64_t last_sequence = 0;
  while (seen.size() < centres.size() && std::chrono::steady_clock::now() < until) {
    v1::GetSceneRequest request;
    v1::SceneUpdate update;
    const grpc::Status status =
        stub->GetScene(clientContext(std::chrono::seconds(10)).get(), request, &update);
    if (status.error_code() == grpc::StatusCode::UNAVAILABLE) {  // nothing processed yet
      std::this_thread::sleep_for(20ms);
      continue;
    }
    ASSERT_TRUE(status.ok()) << status.error_message();
    if (update.info().sequence() == last_sequence) {
      std::this_thread::sleep_for(10ms);
      continue;
    }
    last_sequence = update.info().sequence();
    const Eigen::Isometry3d truth =
        scene.worldFromCamera(update.info().sequence()).inverse() * world_from_teaching;
    for (const auto& detection : update.taught_objects()) {
      seen.insert(detection.name());
      const Eigen::Vector3d& centre = centres.at(detection.name());
      const Eigen::Vector3d t(detection.translation().x(), detection.translation().y(),
                              detection.translation().z());
      const Eigen::Quaterniond q(detection.rotation().w(), detection.rotation().x(),
                                 detection.rotation().y(), detection.rotation().z());
      // Issue 22's tolerance at the model's centre: 1 cm.
      EXPECT_LT((q * centre + t - truth * centre).norm(), 0.01)
          << detection.name() << " in frame " << update.info().sequence();
      EXPECT_GE(detection.score(), 0.95);
      ++checked;
    }
    bool timed = false;
    for (const auto& timing : update.timings()) timed |= timing.stage() == "taught_objects";
    EXPECT_TRUE(timed);
  }
  EXPECT_EQ(seen.size(), centres.size());
  EXPECT_GE(checked, static_cast<int>(centres.size()));

  v1::GetStatusResponse status;
  ASSERT_TRUE(stub->GetStatus(clientContext().get(), {}, &status).ok());
  EXPECT_EQ(std::count(status.detectors().begin(), status.detectors().end(), "taught_objects"), 1);
}

TEST(TaughtObjectStage, NeedsAnObjectModelsFolder) {
  DaemonOptions options = stageOptions({});
  options.object_models.clear();
  EXPECT_THROW(Daemon{options}, std::invalid_argument);
}

}  // namespace
}  // namespace shapesense
