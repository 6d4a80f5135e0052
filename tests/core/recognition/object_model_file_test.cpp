#include "shapesense/core/recognition/object_model_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

ObjectModel taughtBox() {
  synthetic::SceneParams params;
  params.seed = 21;
  const auto rendered = synthetic::SyntheticScene(params).render(0, 0);
  for (const auto& object : rendered.truth.objects)
    if (object.name == "box1")
      return teachObjectModel("box1", rendered.frame.depth, rendered.frame.intrinsics,
                              rendered.truth.object_labels == object.id);
  throw std::logic_error("seed 21 has no box1");
}

TEST(ObjectModelFile, RoundTripKeepsEveryValue) {
  const ObjectModel model = taughtBox();
  ASSERT_FALSE(model.features.empty());
  ASSERT_FALSE(model.outline_probes.empty());
  const auto dir = std::filesystem::temp_directory_path() / "shapesense_object_model_test";
  std::filesystem::create_directories(dir);
  saveObjectModel(model, {}, dir / "box1.json");
  const ObjectModel loaded = loadObjectModel(dir / "box1.json");
  EXPECT_EQ(loaded.name, "box1");
  ASSERT_EQ(loaded.surface.size(), model.surface.size());
  ASSERT_EQ(loaded.features.size(), model.features.size());
  ASSERT_EQ(loaded.outline_probes.size(), model.outline_probes.size());
  for (std::size_t i = 0; i < model.features.size(); ++i) {
    EXPECT_TRUE(loaded.features[i].position.isApprox(model.features[i].position, 1e-6f));
    EXPECT_LT(descriptorDistance2(loaded.features[i], model.features[i]), 1e-10f);
  }
  EXPECT_TRUE(loaded.box.centre.isApprox(model.box.centre, 1e-6f));
  std::filesystem::remove_all(dir);
}

TEST(ObjectModelFile, RefusesMalformedFilesNamingTheProblem) {
  const std::string good = objectModelToJson(taughtBox(), {});
  EXPECT_NO_THROW(parseObjectModel(good));
  const auto refuses = [](const std::string& text, const std::string& why) {
    try {
      parseObjectModel(text);
      ADD_FAILURE() << "accepted: " << text.substr(0, 80);
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refuses("{", "parse");
  refuses("[]", "not a shapesense-object-model");
  refuses(R"({"format": "shapesense-bowl-model"})", "not a shapesense-object-model");
  const auto withVersion = [&good](int version) {
    std::string text = good;
    text.replace(text.find("\"version\":" + std::to_string(kObjectModelVersion)), 11,
                 "\"version\":" + std::to_string(version));
    return text;
  };
  refuses(withVersion(7), "unsupported version");
  for (int earlier = 1; earlier < kObjectModelVersion; ++earlier)
    refuses(withVersion(earlier), "teach it again");
  std::string other_radius = good;
  const auto radius_at = other_radius.find("\"support_radius_m\":");
  other_radius.replace(radius_at, 19, "\"support_radius_m\":9,\"x\":");
  refuses(other_radius, "other descriptor parameters");
  std::string bad_name = good;
  bad_name.replace(bad_name.find("\"name\":\"box1\""), 13, "\"name\":\"../x\"");
  refuses(bad_name, "invalid object name");
  std::string nan_value = good;
  nan_value.replace(nan_value.find("\"p\":["), 5, "\"p\":[1e999,");
  refuses(nan_value, "");
}

TEST(ObjectModelFile, NamesAreSafeAsFileNames) {
  EXPECT_TRUE(isValidObjectModelName("mug"));
  EXPECT_TRUE(isValidObjectModelName("red_mug-2.v1"));
  EXPECT_FALSE(isValidObjectModelName(""));
  EXPECT_FALSE(isValidObjectModelName(".hidden"));
  EXPECT_FALSE(isValidObjectModelName("../etc"));
  EXPECT_FALSE(isValidObjectModelName("a/b"));
  EXPECT_FALSE(isValidObjectModelName("mug\n"));
  EXPECT_FALSE(isValidObjectModelName(std::string(65, 'a')));
}

TEST(ObjectModelFile, RefusesWhatIsNotASmallRegularFile) {
  EXPECT_THROW(loadObjectModel(std::filesystem::temp_directory_path()), std::runtime_error);
  EXPECT_THROW(loadObjectModel("/nonexistent/model.json"), std::runtime_error);
}

}  // namespace
}  // namespace shapesense
