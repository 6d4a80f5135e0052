// ObjectModelStore on its own: load, list, get, add and its refusals, on a scratch folder.

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "shapesense/core/recognition/object_model_file.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/server/object_model_store.h"
#include "shapesense/server/recording_root.h"
#include "test_paths.h"

namespace shapesense::testing {
namespace {

namespace fs = std::filesystem;

// One taught box (the scene of the core's model file test), named as asked.
ObjectModel taughtBox(const std::string& name) {
  static const ObjectModel box = [] {
    synthetic::SceneParams params;
    params.seed = 21;
    const auto rendered = synthetic::SyntheticScene(params).render(0, 0);
    for (const auto& object : rendered.truth.objects)
      if (object.name == "box1")
        return teachObjectModel("box1", rendered.frame.depth, rendered.frame.intrinsics,
                                rendered.truth.object_labels == object.id);
    throw std::logic_error("seed 21 has no box1");
  }();
  ObjectModel model = box;
  model.name = name;
  return model;
}

grpc::Status add(ObjectModelStore& store, const std::string& name, bool replace = false) {
  StoredObjectModel stored;
  bool replaced = false;
  return store.add(taughtBox(name), replace, stored, replaced);
}

TEST(ObjectModelStore, CreatesAMissingFolderAndStartsEmpty) {
  const fs::path dir = scratchDir("object-model-store-missing") / "a" / "b";
  ObjectModelStore store(dir);
  EXPECT_TRUE(fs::is_directory(dir));
  EXPECT_TRUE(store.list().empty());
  EXPECT_FALSE(store.get("box1"));
  EXPECT_TRUE(store.skipped().empty());
}

TEST(ObjectModelStore, AddsSavesListsByNameAndLoadsAgain) {
  const fs::path dir = scratchDir("object-model-store-add");
  {
    ObjectModelStore store(dir);
    StoredObjectModel stored;
    bool replaced = true;
    ASSERT_TRUE(store.add(taughtBox("mug"), false, stored, replaced).ok());
    EXPECT_FALSE(replaced);
    EXPECT_GT(stored.taught_at_ns, 0);
    ASSERT_TRUE(add(store, "box").ok());
    EXPECT_TRUE(fs::is_regular_file(dir / "mug.json"));
    const auto listed = store.list();
    ASSERT_EQ(listed.size(), 2u);
    EXPECT_EQ(listed[0].model->name, "box");
    EXPECT_EQ(listed[1].model->name, "mug");
  }
  ObjectModelStore again(dir);
  ASSERT_EQ(again.list().size(), 2u);
  const auto mug = again.get("mug");
  ASSERT_TRUE(mug);
  EXPECT_EQ(mug->model->features.size(), taughtBox("mug").features.size());
}

TEST(ObjectModelStore, RefusesATakenNameUnlessReplacingAndAFullFolder) {
  ObjectModelStore store(scratchDir("object-model-store-full"), /*max_models=*/2);
  ASSERT_TRUE(add(store, "a").ok());
  EXPECT_EQ(add(store, "a").error_code(), grpc::StatusCode::ALREADY_EXISTS);
  EXPECT_EQ(store.admits("a", false).error_code(), grpc::StatusCode::ALREADY_EXISTS);
  StoredObjectModel stored;
  bool replaced = false;
  ASSERT_TRUE(store.add(taughtBox("a"), true, stored, replaced).ok());
  EXPECT_TRUE(replaced);
  ASSERT_TRUE(add(store, "b").ok());
  EXPECT_EQ(add(store, "c").error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(store.admits("b", true).ok()) << "replacing takes no room";
  EXPECT_EQ(store.list().size(), 2u);
}

TEST(ObjectModelStore, SkipsFilesThatDoNotLoadAndSaysWhy) {
  const fs::path dir = scratchDir("object-model-store-skips");
  saveObjectModel(taughtBox("good"), {}, dir / "good.json");
  saveObjectModel(taughtBox("other"), {}, dir / "renamed.json");  // name and file disagree
  std::ofstream(dir / "broken.json") << "not json";
  std::ofstream(dir / "notes.txt") << "not a model, not looked at";
  std::ofstream(dir / "half.json.tmp") << "a save that was cut short";
  ObjectModelStore store(dir);
  ASSERT_EQ(store.list().size(), 1u);
  EXPECT_EQ(store.list()[0].model->name, "good");
  ASSERT_EQ(store.skipped().size(), 2u);
  std::string skipped = store.skipped()[0] + "\n" + store.skipped()[1];
  EXPECT_NE(skipped.find("broken.json"), std::string::npos) << skipped;
  EXPECT_NE(skipped.find("rename the file to other.json"), std::string::npos) << skipped;
}

TEST(ObjectModelStore, DefaultFolderIsBesideTheRecordings) {
  EXPECT_EQ(defaultObjectModelsDir().filename(), "object-models");
  EXPECT_EQ(defaultObjectModelsDir().parent_path(), defaultRecordRoot().parent_path());
}

}  // namespace
}  // namespace shapesense::testing
