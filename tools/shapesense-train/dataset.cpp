#include "dataset.h"

#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/bowls/bowl_eval.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/scene_splits.h"

namespace shapesense::train {

using nlohmann::json;

namespace {

// Four camera presets so that all three view classes are well represented: the default
// robot-head view (mostly "side": the rim seen below 20 deg), a high camera ("top" and
// "middle"), a raised one ("middle") and an overhead one ("top").
synthetic::SceneParams sceneParams(std::uint64_t seed, int preset, bool negative) {
  synthetic::SceneParams p;
  p.seed = seed;
  p.render_colour = false;
  // The scene requires table distance (3D) > camera rise above the table (0.62-0.78 m high).
  if (preset == 1) {  // high: rise 1.12-1.68 m at 1.7-2.1 m, elevation ~30-80 deg
    p.camera_height_min_m = 1.9;
    p.camera_height_max_m = 2.3;
    p.table_distance_min_m = 1.7;
    p.table_distance_max_m = 2.1;
    p.min_table_elevation_deg = 30.0;
  } else if (preset == 3) {  // overhead: rise 1.42-1.98 m at 2.0-2.3 m, mostly "top" bowls
    p.camera_height_min_m = 2.2;
    p.camera_height_max_m = 2.6;
    p.table_distance_min_m = 2.0;
    p.table_distance_max_m = 2.3;
    p.min_table_elevation_deg = 40.0;
  } else if (preset == 2) {  // raised: rise 0.52-0.98 m at 1.1-1.8 m, elevation ~20-60 deg
    p.camera_height_min_m = 1.3;
    p.camera_height_max_m = 1.6;
    p.table_distance_min_m = 1.1;
    p.table_distance_max_m = 1.8;
    p.min_table_elevation_deg = 17.0;
  }
  // Look-alike distractors in every scene.
  p.cups_min = 1;
  p.cups_max = 3;
  p.tins_min = 0;
  p.tins_max = 2;
  p.balls_min = 0;
  p.balls_max = 2;
  if (negative) {
    // Bowl-free for the detector: no bowl or only upside-down ones (which are not bowls).
    p.bowls_min = 0;
    p.bowls_max = 2;
    p.bowl_upside_down_probability = 1.0;
    p.tins_min = 1;
    p.tins_max = 3;
    p.balls_min = 1;
    p.balls_max = 3;
  }
  return p;
}

/// A frame's annotation line: every visible bowl (upright or not) with its box, view class,
/// pixels, visible fraction and difficult flag; "negative" when no upright bowl shows.
json annotateFrame(const synthetic::RenderedFrame& r, const std::string& file) {
  json line;
  line["file"] = file;
  const auto& in = r.frame.intrinsics;
  line["fx"] = in.fx;
  line["fy"] = in.fy;
  line["cx"] = in.cx;
  line["cy"] = in.cy;
  json bowls = json::array();
  bool any_upright = false;
  for (const auto& o : r.truth.objects) {
    if (o.kind != "bowl" || o.image_box.empty()) continue;
    const auto& b = o.image_box;
    any_upright |= o.upright;
    bowls.push_back({{"box", {b.x, b.y, b.width, b.height}},
                     {"view", o.view_class},
                     {"upright", o.upright},
                     {"pixels", o.pixel_count},
                     {"visible_fraction", o.visible_fraction},
                     {"difficult", isDifficultBowl(b, o.pixel_count, o.visible_fraction)}});
  }
  line["negative"] = !any_upright;
  line["bowls"] = std::move(bowls);
  return line;
}

/// The frame of wide scene `index` of a split ("train", "validation" or "test"):
/// eval::evalScene(split, index) at its scored frame index.
synthetic::RenderedFrame renderWideScene(const std::string& split, int index) {
  const auto parsed = eval::parseSplit(split);
  if (!parsed) throw std::invalid_argument("unknown scene split \"" + split + "\"");
  const eval::EvalScene scene = eval::evalScene(*parsed, index);
  return synthetic::SyntheticScene(scene.params).render(scene.frame_index, 0);
}

std::string frameName(int index) {
  char name[64];
  std::snprintf(name, sizeof name, "frames/%06d.png", index);
  return name;
}

void writeDepth(const std::filesystem::path& dir, const std::string& name, const cv::Mat& depth) {
  if (!cv::imwrite((dir / name).string(), depth)) throw std::runtime_error("cannot write " + name);
}

/// Table-top scene `s` of the bowl generator: frames_per_scene lines from lines[s * fps].
void generateTableScene(const std::filesystem::path& dir, const GenerateParams& gp, int s,
                        std::vector<std::string>& lines) {
  const bool negative = s >= gp.positive_scenes;
  const int preset = s % 4;
  // Scene seeds are a pure function of (seed, scene index): the dataset is deterministic.
  const std::uint64_t scene_seed = gp.seed * 1000003ULL + static_cast<std::uint64_t>(s);
  synthetic::SyntheticScene scene(sceneParams(scene_seed, preset, negative));
  for (int k = 0; k < gp.frames_per_scene; ++k) {
    const auto r = scene.render(static_cast<std::uint64_t>(k * 45), 0);
    cv::Mat depth = r.frame.depth.clone();
    cv::RNG rng(scene_seed * 31 + static_cast<std::uint64_t>(k));
    if (rng.uniform(0.0, 1.0) < gp.blank_room_fraction) depth.setTo(0, r.truth.object_labels == 0);
    const int index = s * gp.frames_per_scene + k;
    const std::string name = frameName(index);
    writeDepth(dir, name, depth);
    lines[static_cast<std::size_t>(index)] = annotateFrame(r, name).dump();
  }
}

/// Wide scene `k` (eval::evalScene(wide_split, wide_first + k)): one frame after the table-top
/// frames.
void generateWideFrame(const std::filesystem::path& dir, const GenerateParams& gp, int k,
                       std::vector<std::string>& lines) {
  const auto r = renderWideScene(gp.wide_split, gp.wide_first + k);
  const int index = (gp.positive_scenes + gp.negative_scenes) * gp.frames_per_scene + k;
  const std::string name = frameName(index);
  writeDepth(dir, name, r.frame.depth);
  lines[static_cast<std::size_t>(index)] = annotateFrame(r, name).dump();
}

}  // namespace

void generateDataset(const std::filesystem::path& dir, const GenerateParams& gp) {
  if (gp.wide_scenes > 0 && !eval::parseSplit(gp.wide_split))
    throw std::invalid_argument("unknown scene split \"" + gp.wide_split + "\"");
  if (gp.wide_scenes < 0 || gp.wide_first < 0)
    throw std::invalid_argument("--wide-scenes and --wide-first must not be negative");
  std::filesystem::create_directories(dir / "frames");
  const int scenes = gp.positive_scenes + gp.negative_scenes;
  const int jobs = scenes + gp.wide_scenes;
  std::vector<std::string> lines(
      static_cast<std::size_t>(scenes * gp.frames_per_scene + gp.wide_scenes));
  std::atomic<int> next{0}, done{0};
  std::mutex print_mutex;
  std::exception_ptr error;
  auto worker = [&] {
    try {
      for (int s; (s = next++) < jobs;) {
        if (s < scenes)
          generateTableScene(dir, gp, s, lines);
        else
          generateWideFrame(dir, gp, s - scenes, lines);
        const int d = ++done;
        std::lock_guard lock(print_mutex);
        std::fprintf(stderr, "\rgenerate: scene %d/%d", d, jobs);
      }
    } catch (...) {
      std::lock_guard lock(print_mutex);
      if (!error) error = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int i = 0; i < std::max(1, gp.threads); ++i) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  std::fprintf(stderr, "\n");
  if (error) std::rethrow_exception(error);
  std::ofstream ann(dir / "annotations.jsonl");
  for (const auto& l : lines) ann << l << "\n";
  json generator = {{"seed", gp.seed},
                    {"positive_scenes", gp.positive_scenes},
                    {"negative_scenes", gp.negative_scenes},
                    {"frames_per_scene", gp.frames_per_scene},
                    {"blank_room_fraction", gp.blank_room_fraction}};
  if (gp.wide_scenes > 0) {  // absent otherwise: datasets without wide scenes stay as they were
    generator["wide_scenes"] = gp.wide_scenes;
    generator["wide_first"] = gp.wide_first;
    generator["wide_split"] = std::string(eval::formatSplit(*eval::parseSplit(gp.wide_split)));
  }
  json meta = {{"format", "shapesense-bowl-dataset"}, {"version", 2}, {"generator", generator}};
  std::ofstream(dir / "dataset.json") << meta.dump(2) << "\n";
}

void requireEvaluationTruth(const std::filesystem::path& dir) {
  std::ifstream in(dir / "dataset.json");
  if (!in) throw std::runtime_error("no dataset.json in " + dir.string());
  const int version = json::parse(in).value("version", 0);
  if (version < 2)
    throw std::runtime_error(dir.string() + " is a version " + std::to_string(version) +
                             " dataset: its \"difficult\" flags predate the visible-fraction "
                             "rule (core/bowl_eval.h), so it cannot be evaluated; regenerate it "
                             "with shapesense-train generate");
}

std::vector<DatasetFrame> readDataset(const std::filesystem::path& dir) {
  std::ifstream in(dir / "annotations.jsonl");
  if (!in) throw std::runtime_error("no annotations.jsonl in " + dir.string());
  std::vector<DatasetFrame> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const json j = json::parse(line);
    DatasetFrame f;
    f.file = j.at("file").get<std::string>();
    f.intrinsics.fx = j.at("fx").get<double>();
    f.intrinsics.fy = j.at("fy").get<double>();
    f.intrinsics.cx = j.at("cx").get<double>();
    f.intrinsics.cy = j.at("cy").get<double>();
    f.negative = j.at("negative").get<bool>();
    for (const auto& b : j.at("bowls")) {
      BowlAnnotation a;
      a.box = {b["box"][0].get<int>(), b["box"][1].get<int>(), b["box"][2].get<int>(),
               b["box"][3].get<int>()};
      a.view = b.at("view").get<std::string>();
      a.upright = b.at("upright").get<bool>();
      a.difficult = b.at("difficult").get<bool>();
      // Version 1 datasets have no pixel count, and their one flag was the tiny-or-sparse rule.
      a.trainable =
          a.upright &&
          (b.contains("pixels") ? !isTinyOrSparseBowl(a.box, b.at("pixels").get<std::size_t>())
                                : !a.difficult);
      f.bowls.push_back(a);
    }
    out.push_back(std::move(f));
  }
  return out;
}

cv::Mat readDepth(const std::filesystem::path& dir, const DatasetFrame& frame) {
  cv::Mat d = cv::imread((dir / frame.file).string(), cv::IMREAD_UNCHANGED);
  if (d.empty() || d.type() != CV_16UC1)
    throw std::runtime_error("bad depth frame " + (dir / frame.file).string());
  return d;
}

}  // namespace shapesense::train
