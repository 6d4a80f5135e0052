// ListObjectModels through a real in-process gRPC server: what TeachObject taught, and what a
// daemon started again on the same folder loads (a corrupt file skipped with a log line).

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "object_scene.h"
#include "test_paths.h"

namespace shapesense::testing {
namespace {

v1::ListObjectModelsResponse listModels(TestServer& srv) {
  v1::ListObjectModelsResponse response;
  const auto status = srv.stub().ListObjectModels(clientContext().get(), {}, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response;
}

TEST(ListObjectModels, ListsNothingBeforeTeachingAndTheFoldersLimit) {
  TestServer srv;
  const auto response = listModels(srv);
  EXPECT_EQ(response.models_size(), 0);
  EXPECT_EQ(response.max_models(), ObjectModelStore::kDefaultMaxModels);
}

TEST(ListObjectModels, ListsWhatWasTaughtByNameAndAgainAfterARestart) {
  const auto dir = scratchDir("list-object-models");
  v1::ListObjectModelsResponse before;
  {
    TestServer srv(16, {}, {}, patientLimits(), dir);
    ObjectScene scene(srv);
    v1::TeachObjectResponse taught;
    const auto start_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::system_clock::now().time_since_epoch())
                              .count();
    ASSERT_TRUE(teachObject(srv, 0, scene.roi("box1"), "zeta", false, taught).ok());
    ASSERT_TRUE(teachObject(srv, 0, scene.roi("box1"), "alpha", false, taught).ok());
    before = listModels(srv);
    ASSERT_EQ(before.models_size(), 2);
    EXPECT_EQ(before.models(0).name(), "alpha");
    EXPECT_EQ(before.models(1).name(), "zeta");
    EXPECT_EQ(before.models(0).feature_count(), taught.model().feature_count());
    EXPECT_GE(before.models(0).taught_at_ns(), start_ns - 2'000'000'000);  // file time grain
  }
  TestServer restarted(16, {}, {}, patientLimits(), dir);
  const auto after = listModels(restarted);
  ASSERT_EQ(after.models_size(), 2);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(after.models(i).name(), before.models(i).name());
    EXPECT_EQ(after.models(i).feature_count(), before.models(i).feature_count());
    EXPECT_EQ(after.models(i).surface_points(), before.models(i).surface_points());
    EXPECT_NEAR(after.models(i).box_size().z(), before.models(i).box_size().z(), 1e-6);
    EXPECT_EQ(after.models(i).taught_at_ns(), before.models(i).taught_at_ns());
  }
}

TEST(ListObjectModels, ACorruptFileIsSkippedWithALogLineAndTheRestLoads) {
  const auto dir = scratchDir("list-object-models-corrupt");
  {
    TestServer srv(16, {}, {}, patientLimits(), dir);
    ObjectScene scene(srv);
    v1::TeachObjectResponse taught;
    ASSERT_TRUE(teachObject(srv, 0, scene.roi("box1"), "good", false, taught).ok());
  }
  std::ofstream(dir / "broken.json") << "{\"format\": \"shapesense-object-model\", \"vers";
  auto sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
  spdlog::default_logger()->sinks().push_back(sink);
  {
    TestServer restarted(16, {}, {}, patientLimits(), dir);
    const auto listed = listModels(restarted);
    ASSERT_EQ(listed.models_size(), 1);
    EXPECT_EQ(listed.models(0).name(), "good");
    ASSERT_EQ(restarted.objectModels().skipped().size(), 1u);
    EXPECT_NE(restarted.objectModels().skipped()[0].find("broken.json"), std::string::npos);
  }
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::remove(sinks.begin(), sinks.end(), sink), sinks.end());
  bool logged = false;
  for (const auto& line : sink->last_formatted())
    logged |= line.find("object model skipped") != std::string::npos &&
              line.find("broken.json") != std::string::npos;
  EXPECT_TRUE(logged) << "no log line names the skipped file";
}

}  // namespace
}  // namespace shapesense::testing
