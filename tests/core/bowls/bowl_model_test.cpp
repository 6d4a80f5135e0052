// Bowl model files: save/load round trip gives an identical classifier and identical scores;
// malformed files are rejected with the file's name; the shipped models load.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_model.h"
#include "test_paths.h"

namespace shapesense {
namespace {

std::filesystem::path shippedModels() {
  return std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models";
}

BowlViewModel randomModel(std::uint64_t seed) {
  cv::RNG rng(seed);
  BowlViewModel m;
  m.view = "middle";
  m.classifier.win_w = 24;
  m.classifier.win_h = 18;
  const auto features = enumerateLbpFeatures(24, 18, 2);
  for (int t = 0; t < 30; ++t) {
    WaldBoostStage s;
    s.feature = features[rng.uniform(0, static_cast<int>(features.size()))];
    for (auto& v : s.lut) v = static_cast<std::int16_t>(rng.uniform(-3000, 3001));
    s.threshold = t == 29 ? INT32_MIN : rng.uniform(-20000, 0);
    m.classifier.stages.push_back(s);
  }
  m.training_json = R"({"seed":7})";
  return m;
}

TEST(BowlModel, RoundTripGivesIdenticalClassifierAndScores) {
  const auto dir = testing::scratchDir("bowl_model_roundtrip");
  const BowlViewModel m = randomModel(3);
  saveBowlModel(m, dir / "bowl_middle.json");
  const BowlViewModel back = loadBowlModel(dir / "bowl_middle.json");
  EXPECT_EQ(back, m);
  EXPECT_EQ(back.training_json, m.training_json);
  cv::RNG rng(9);
  for (int i = 0; i < 200; ++i) {
    cv::Mat w(18, 24, CV_8UC1);
    rng.fill(w, cv::RNG::UNIFORM, 0, 256);
    std::int32_t a = 0, b = 0;
    const bool ra = m.classifier.evaluateWindow(w, a), rb = back.classifier.evaluateWindow(w, b);
    ASSERT_EQ(ra, rb);
    ASSERT_EQ(a, b);
  }
}

TEST(BowlModel, MalformedFilesAreRejectedWithTheirName) {
  const auto dir = testing::scratchDir("bowl_model_bad");
  std::ofstream(dir / "bowl_bad.json") << R"({"format": "something-else", "version": 1})";
  try {
    loadBowlModel(dir / "bowl_bad.json");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bowl_bad.json"), std::string::npos);
  }
  EXPECT_THROW(loadBowlModel(dir / "missing.json"), std::runtime_error);
  EXPECT_THROW(BowlDetector::load(testing::scratchDir("bowl_model_empty")), std::runtime_error);
}

TEST(BowlModel, ShippedModelsLoad) {
  const auto detector = BowlDetector::load(shippedModels());
  std::vector<std::string> views;
  for (const auto& m : detector.models()) {
    views.push_back(m.view);
    // Training stops when bootstrapping finds no more hard negatives; the shipped "top" model
    // stopped after 3 stages (see models/README.md), so the floor is 3.
    EXPECT_GE(m.classifier.stages.size(), 3u) << m.view;
  }
  EXPECT_EQ(views, (std::vector<std::string>{"middle", "side", "top"}));  // sorted by file name
}

}  // namespace
}  // namespace shapesense
