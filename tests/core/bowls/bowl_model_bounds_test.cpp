// Bowl model files with numbers no model holds: a float where an integer belongs, integers past
// their type, a feature whose extent overflows an int. Each was converted with undefined
// behaviour (found by fuzz/bowl_model_fuzz.cpp) and is now a malformed model.
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "shapesense/core/bowls/bowl_model.h"
#include "test_paths.h"

namespace shapesense {
namespace {

nlohmann::json shippedTopModel() {
  std::ifstream in(std::filesystem::path(SHAPESENSE_SOURCE_DIR) / "models" / "bowl_top.json");
  return nlohmann::json::parse(in);
}

std::string loadError(const std::string& name, const nlohmann::json& model) {
  const auto file = testing::scratchDir(name) / "bowl_top.json";
  std::ofstream(file) << model.dump();
  try {
    loadBowlModel(file);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << name << ": the model was accepted";
  return {};
}

TEST(BowlModelBounds, ShippedModelStillLoads) {
  const auto file = testing::scratchDir("bowl_bounds_shipped") / "bowl_top.json";
  std::ofstream(file) << shippedTopModel().dump();
  EXPECT_NO_THROW(loadBowlModel(file));
}

TEST(BowlModelBounds, FloatLutEntryIsMalformed) {
  auto model = shippedTopModel();
  model["stages"][0]["lut"][0] = -7.77778e+85;
  EXPECT_THAT(loadError("bowl_bounds_lut_float", model), ::testing::HasSubstr("integer"));
}

TEST(BowlModelBounds, LutEntryPastSixteenBitsIsMalformed) {
  auto model = shippedTopModel();
  model["stages"][0]["lut"][0] = 40000;
  EXPECT_THAT(loadError("bowl_bounds_lut_range", model), ::testing::HasSubstr("out of range"));
}

TEST(BowlModelBounds, HugeWindowWidthIsMalformed) {
  auto model = shippedTopModel();
  model["window"]["width"] = 1e300;
  EXPECT_THAT(loadError("bowl_bounds_window", model), ::testing::HasSubstr("integer"));
}

TEST(BowlModelBounds, FeatureWhoseExtentOverflowsIsOutsideTheWindow) {
  // x + 3 * cw wrapped to a negative number and passed the window check.
  auto model = shippedTopModel();
  model["stages"][0]["cw"] = 1'000'000'000;
  EXPECT_THAT(loadError("bowl_bounds_feature", model), ::testing::HasSubstr("outside the window"));
}

}  // namespace
}  // namespace shapesense
