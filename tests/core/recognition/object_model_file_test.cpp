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
  // The box was taught standing on the table; its standing box is made again from the support.
  ASSERT_TRUE(model.support && model.standing_box);
  ASSERT_TRUE(loaded.support && loaded.standing_box);
  EXPECT_TRUE(loaded.support->isApprox(*model.support, 1e-6f));
  EXPECT_TRUE(loaded.standing_box->centre.isApprox(model.standing_box->centre, 1e-5f));
  EXPECT_TRUE(loaded.standing_box->size.isApprox(model.standing_box->size, 1e-5f));
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
  // A file saved without a support loads standing on nothing; a support that is no plane is
  // refused.
  std::string no_support = good;
  const auto support_at = no_support.find(",\"support\":[");
  ASSERT_NE(support_at, std::string::npos);
  no_support.erase(support_at, no_support.find(']', support_at) + 1 - support_at);
  const ObjectModel unsupported = parseObjectModel(no_support);
  EXPECT_FALSE(unsupported.support);
  EXPECT_FALSE(unsupported.standing_box);
  std::string bad_support = good;
  const auto bad_at = bad_support.find("\"support\":[");
  bad_support.replace(bad_at, bad_support.find(']', bad_at) + 1 - bad_at,
                      "\"support\":[2,0,0,0.5]");
  refuses(bad_support, "not unit");
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
