// The bowl dataset generator (tools/shapesense-train): frames from the evaluation's wide scene
// distribution are appended after the table-top scenes, annotated like every other frame, and
// the options are recorded in dataset.json.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "dataset.h"
#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/eval/scene_splits.h"

namespace shapesense::train {
namespace {

namespace fs = std::filesystem;

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("shapesense_" + name + "_" +
                        std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::remove_all(dir);
  return dir;
}

// The truth's bowls of a wide frame, in the order the generator writes them.
std::vector<const synthetic::TruthObject*> visibleBowls(const synthetic::RenderedFrame& r) {
  std::vector<const synthetic::TruthObject*> bowls;
  for (const auto& o : r.truth.objects)
    if (o.kind == "bowl" && !o.image_box.empty()) bowls.push_back(&o);
  return bowls;
}

TEST(BowlDataset, WideScenesAreAppendedAndAnnotatedFromTheirScene) {
  const fs::path dir = freshDir("bowl_dataset_wide");
  GenerateParams gp;
  gp.seed = 3;
  gp.positive_scenes = 1;
  gp.negative_scenes = 0;
  gp.frames_per_scene = 1;
  gp.wide_scenes = 2;
  gp.wide_first = 5;  // scene 5 is a curved-clutter scene (odd index), scene 6 a plain one
  generateDataset(dir, gp);

  const auto frames = readDataset(dir);
  ASSERT_EQ(frames.size(), 3u);  // 1 table-top frame, then the 2 wide frames
  int wide_bowls = 0;
  for (int k = 0; k < 2; ++k) {
    const DatasetFrame& f = frames[static_cast<std::size_t>(1 + k)];
    SCOPED_TRACE("wide scene " + std::to_string(5 + k) + ", " + f.file);
    EXPECT_EQ(f.file, "frames/00000" + std::to_string(1 + k) + ".png");
    // The scene the evaluation's train split draws, at its scored frame.
    const auto scene = eval::evalScene(eval::Split::kTrain, 5 + k);
    const auto r = synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
    // The depth is the rendered frame's, room included.
    const cv::Mat depth = readDepth(dir, f);
    ASSERT_EQ(depth.size(), r.frame.depth.size());
    EXPECT_EQ(cv::countNonZero(depth != r.frame.depth), 0);
    EXPECT_DOUBLE_EQ(f.intrinsics.fx, r.frame.intrinsics.fx);
    EXPECT_DOUBLE_EQ(f.intrinsics.cy, r.frame.intrinsics.cy);
    // Every visible bowl of the truth, with its box, view, orientation and difficult flag.
    const auto truth = visibleBowls(r);
    ASSERT_EQ(f.bowls.size(), truth.size());
    bool any_upright = false;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const auto& o = *truth[i];
      const auto& a = f.bowls[i];
      EXPECT_EQ(a.box, o.image_box);
      EXPECT_EQ(a.view, o.view_class);
      EXPECT_EQ(a.upright, o.upright);
      EXPECT_EQ(a.difficult, isDifficultBowl(o.image_box, o.pixel_count, o.visible_fraction));
      EXPECT_EQ(a.trainable, o.upright && !isTinyOrSparseBowl(o.image_box, o.pixel_count));
      any_upright |= o.upright;
    }
    EXPECT_EQ(f.negative, !any_upright);
    wide_bowls += static_cast<int>(truth.size());
  }
  EXPECT_TRUE(frames[2].bowls.empty()) << "a plain scene (even index) holds no bowl";
  EXPECT_TRUE(frames[2].negative);

  // The options are recorded, so a model trained on it says what it saw.
  const auto meta = nlohmann::json::parse(std::ifstream(dir / "dataset.json"));
  const auto& g = meta.at("generator");
  EXPECT_EQ(g.at("wide_scenes").get<int>(), 2);
  EXPECT_EQ(g.at("wide_first").get<int>(), 5);
  EXPECT_EQ(g.at("wide_split").get<std::string>(), "train");
  EXPECT_EQ(g.at("positive_scenes").get<int>(), 1);
  EXPECT_GT(wide_bowls, 0) << "the curved-clutter scene should show a bowl to check";
  fs::remove_all(dir);
}

TEST(BowlDataset, WithoutWideScenesTheGeneratorBlockIsUnchanged) {
  const fs::path dir = freshDir("bowl_dataset_plain");
  GenerateParams gp;
  gp.positive_scenes = 1;
  gp.negative_scenes = 0;
  gp.frames_per_scene = 1;
  generateDataset(dir, gp);
  EXPECT_EQ(readDataset(dir).size(), 1u);
  const auto meta = nlohmann::json::parse(std::ifstream(dir / "dataset.json"));
  EXPECT_FALSE(meta.at("generator").contains("wide_scenes"));
  fs::remove_all(dir);
}

TEST(BowlDataset, AnUnknownSplitIsRefused) {
  GenerateParams gp;
  gp.positive_scenes = 0;
  gp.negative_scenes = 0;
  gp.wide_scenes = 1;
  gp.wide_split = "holdout";
  EXPECT_THROW(generateDataset(freshDir("bowl_dataset_bad"), gp), std::invalid_argument);
}

}  // namespace
}  // namespace shapesense::train
