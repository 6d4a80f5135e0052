#include "train.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <numeric>
#include <optional>
#include <random>
#include <thread>
#include <utility>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "dataset.h"
#include "shapesense/core/bowls/bowl_detector.h"
#include "shapesense/core/bowls/bowl_model.h"
#include "shapesense/core/bowls/depth_preprocess.h"
#include "shapesense/core/bowls/waldboost.h"
#include "shapesense/core/geometry/image_boxes.h"

namespace shapesense::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
  std::uint64_t x = a * 0x9E3779B97F4A7C15ULL ^ (b + 0x632BE59BD9B4E019ULL + (a << 6) + (a >> 2));
  x ^= x >> 31;
  x *= 0xBF58476D1CE4E5B9ULL;
  return x ^ (x >> 29);
}

std::uint64_t viewId(const std::string& v) { return v == "top" ? 1 : v == "middle" ? 2 : 3; }

void progress(const std::string& view, const WaldBoostStageStats& s, int total, double secs) {
  const int width = 30, filled = s.stage * width / std::max(1, total);
  std::fprintf(stderr,
               "\r[%-6s] %3d/%d |%s%s| pos kept %.3f  neg rejected %.2f  pool %5zu%s  %.0f s   ",
               view.c_str(), s.stage, total, std::string(filled, '#').c_str(),
               std::string(width - filled, ' ').c_str(), s.positives_kept, s.negatives_rejected,
               s.negative_pool, s.refilled ? " (refilled)" : "           ", secs);
}

/// A dataset frame as the detector sees it.
struct PreparedFrame {
  cv::Mat img8;    ///< the 8-bit image the classifier reads
  cv::Mat filled;  ///< hole-filled depth in mm, for the detector's depth gate
  double fx = 525.0;
};

/// What every view trains on: the dataset, read and preprocessed once.
struct TrainingFrames {
  std::vector<DatasetFrame> frames;
  std::vector<PreparedFrame> prepared;  ///< one per frame
  /// Frames the bootstrapping scans for negatives: all of them, since windows near upright
  /// bowls are skipped there (ViewTrainer::acceptedWindowsOf).
  std::vector<std::size_t> negatives;
  DepthPreprocessParams preprocess;  ///< the seed's mapping; recorded in each model
};

// The frames are independent, so `threads` workers each take the next unprepared one.
std::vector<PreparedFrame> prepareFrames(const fs::path& data,
                                         const std::vector<DatasetFrame>& frames,
                                         const DepthTo8BitMap& to8bit, int threads) {
  std::vector<PreparedFrame> prepared(frames.size());
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (std::size_t i; (i = next++) < frames.size();) {
      prepared[i].img8 = preprocessDepth(readDepth(data, frames[i]), to8bit, &prepared[i].filled);
      prepared[i].fx = frames[i].intrinsics.fx;
    }
  };
  std::vector<std::thread> pool;
  for (int i = 0; i < threads; ++i) pool.emplace_back(work);
  for (auto& t : pool) t.join();
  return prepared;
}

/// Wide scenes from the validation or test split are for choosing and reporting only.
void requireTrainingSplit(const fs::path& data) {
  std::ifstream in(data / "dataset.json");
  if (!in) return;
  const json generator = json::parse(in).value("generator", json::object());
  const std::string split = generator.value("wide_split", "train");
  if (generator.value("wide_scenes", 0) > 0 && split != "train")
    throw std::runtime_error(data.string() + " holds wide scenes of the " + split +
                             " split: train only on the train split");
}

TrainingFrames loadTrainingFrames(const TrainOptions& o) {
  const auto t0 = Clock::now();
  requireTrainingSplit(o.data);
  TrainingFrames set;
  set.frames = readDataset(o.data);
  set.prepared = prepareFrames(o.data, set.frames, DepthTo8BitMap(set.preprocess), o.threads);
  set.negatives.resize(set.frames.size());
  std::iota(set.negatives.begin(), set.negatives.end(), std::size_t{0});
  const auto bowl_free = std::count_if(set.frames.begin(), set.frames.end(),
                                       [](const DatasetFrame& f) { return f.negative; });
  spdlog::info(
      "dataset {}: {} frames ({} bowl-free), all used for bootstrapping; preprocessed in {:.1f} s",
      o.data.string(), set.frames.size(), bowl_free, secondsSince(t0));
  return set;
}

/// The classifier's window in level pixels, and the object box inside it.
struct WindowShape {
  int width = 0, height = 0;
  double aspect = 0;                           ///< median box height / width it was chosen from
  double object_width = 0, object_height = 0;  ///< the window less the margin on each side
};

// The median box aspect of the view's training bowls, so that the typical bowl of the view
// fills the window's object box; nullopt when the view has no training bowls.
std::optional<WindowShape> chooseWindowShape(const std::vector<DatasetFrame>& frames,
                                             const std::string& view, const TrainOptions& o) {
  std::vector<double> aspects;
  for (const auto& f : frames)
    for (const auto& b : f.bowls)
      if (b.trainable && b.view == view)
        aspects.push_back(static_cast<double>(b.box.height) / b.box.width);
  if (aspects.empty()) return std::nullopt;
  std::nth_element(aspects.begin(), aspects.begin() + aspects.size() / 2, aspects.end());
  WindowShape s;
  s.aspect = aspects[aspects.size() / 2];
  s.width = o.window_width;
  s.height = std::clamp(static_cast<int>(std::lround(s.width * s.aspect)), 12, 36);
  s.object_width = s.width * (1 - 2 * o.margin);
  s.object_height = s.height * (1 - 2 * o.margin);
  return s;
}

// Crops the window centred on `centre` (level pixels) from a level, optionally flipped.
bool cropWindow(const cv::Mat& level8, cv::Point2d centre, int W, int H, int dx, int dy, bool flip,
                cv::Mat& out) {
  const int x = static_cast<int>(std::lround(centre.x - W / 2.0)) + dx;
  const int y = static_cast<int>(std::lround(centre.y - H / 2.0)) + dy;
  if (x < 0 || y < 0 || x + W > level8.cols || y + H > level8.rows) return false;
  out = level8(cv::Rect(x, y, W, H)).clone();
  if (flip) cv::flip(out, out, 1);
  return true;
}

/// The pyramid level whose scale is nearest to `scale` (in log terms; the first on ties).
std::size_t nearestLevel(const std::vector<BowlPyramidLevel>& levels, double scale) {
  std::size_t best = 0;
  for (std::size_t k = 1; k < levels.size(); ++k)
    if (std::abs(std::log(levels[k].scale / scale)) <
        std::abs(std::log(levels[best].scale / scale)))
      best = k;
  return best;
}

struct Positives {
  std::vector<cv::Mat> windows;
  int bowls = 0;  ///< the bowls they were cropped from
};

// Each of the view's training bowls at the pyramid level whose scale best fits it, shifted by
// up to `jitter` pixels and mirrored (a mirrored table-top scene is as plausible as the scene).
Positives cropPositives(const TrainingFrames& set, const std::string& view,
                        const WindowShape& shape, double scale_step, int jitter) {
  const int W = shape.width, H = shape.height;
  Positives positives;
  for (std::size_t i = 0; i < set.frames.size(); ++i) {
    std::vector<const BowlAnnotation*> mine;
    for (const auto& b : set.frames[i].bowls)
      if (b.trainable && b.view == view) mine.push_back(&b);
    if (mine.empty()) continue;  // spares building the pyramid
    const auto levels = buildBowlPyramid(set.prepared[i].img8, scale_step, W, H);
    for (const auto* b : mine) {
      const double s = std::sqrt(b->box.area() / (shape.object_width * shape.object_height));
      const auto& L = levels[nearestLevel(levels, s)];
      const cv::Point2d c((b->box.x + b->box.width / 2.0) / L.scale,
                          (b->box.y + b->box.height / 2.0) / L.scale);
      ++positives.bowls;
      for (int dy = -jitter; dy <= jitter; ++dy)
        for (int dx = -jitter; dx <= jitter; ++dx) {
          if (dx != 0 && dy != 0) continue;  // a plus shape: 5 positions
          for (bool flip : {false, true}) {
            cv::Mat w;
            if (cropWindow(L.image8, c, W, H, dx, dy, flip, w))
              positives.windows.push_back(std::move(w));
          }
        }
    }
  }
  return positives;
}

/// Trains, checkpoints and saves the classifier of one view.
class ViewTrainer {
 public:
  ViewTrainer(const TrainOptions& o, const TrainingFrames& set, std::string view,
              const WindowShape& shape);

  void run() const;

 private:
  json trainingRecord(const Positives& positives) const;
  WaldBoostClassifier resumeOrStart(const json& training) const;
  WaldBoostStageStats trainStages(WaldBoostTrainer& trainer, const json& training,
                                  Clock::time_point t0) const;
  void saveCheckpoint(const WaldBoostClassifier& classifier, const json& training) const;
  void saveModel(const WaldBoostClassifier& classifier, json training,
                 const WaldBoostStageStats& last, Clock::time_point t0) const;
  std::vector<cv::Mat> bootstrapNegatives(const WaldBoostClassifier& current, int stage,
                                          std::size_t count) const;
  std::vector<cv::Mat> acceptedWindowsOf(std::size_t frame, const BowlViewModel& current, int stage,
                                         std::size_t cap) const;
  bool nearUprightBowl(const BowlWindowHit& hit, double scale, const DatasetFrame& f) const;

  const TrainOptions& o_;
  const TrainingFrames& set_;
  const std::string view_;
  const WindowShape shape_;
  /// The detector's pyramid step and search range, so that the bootstrapping scans windows
  /// as detection will.
  const BowlDetectorParams det_;
  BowlViewModel untrained_;  ///< the view's model with no stages yet
  WaldBoostTrainParams params_;
  fs::path checkpoint_, model_file_;
};

ViewTrainer::ViewTrainer(const TrainOptions& o, const TrainingFrames& set, std::string view,
                         const WindowShape& shape)
    : o_(o), set_(set), view_(std::move(view)), shape_(shape) {
  untrained_.view = view_;
  untrained_.classifier.win_w = shape.width;
  untrained_.classifier.win_h = shape.height;
  untrained_.object_margin = o.margin;
  untrained_.min_object_width_m = o.min_width_m;
  untrained_.max_object_width_m = o.max_width_m;
  untrained_.preprocess = set.preprocess;
  params_.stages = o.stages;
  params_.target_miss_rate = o.miss_rate;
  params_.negative_pool = o.pool;
  params_.refill_every = o.refill_every;
  checkpoint_ = o.out / ".checkpoints" / ("bowl_" + view_ + ".json");
  model_file_ = o.out / ("bowl_" + view_ + ".json");
}

void ViewTrainer::run() const {
  const auto t0 = Clock::now();
  Positives positives = cropPositives(set_, view_, shape_, det_.scale_step, o_.jitter);
  spdlog::info("[{}] window {}x{} (aspect {:.2f}), {} bowls -> {} positives", view_, shape_.width,
               shape_.height, shape_.aspect, positives.bowls, positives.windows.size());
  const json training = trainingRecord(positives);
  WaldBoostTrainer trainer(std::move(positives.windows), resumeOrStart(training), params_);
  const WaldBoostStageStats last = trainStages(trainer, training, t0);
  saveModel(trainer.classifier(), training, last, t0);
}

// The settings and data the classifier comes from; it goes into the model file, and a
// checkpoint is resumed only when its record is the same.
json ViewTrainer::trainingRecord(const Positives& positives) const {
  return {{"tool", "shapesense-train"},
          {"dataset", json::parse(std::ifstream(o_.data / "dataset.json"))},
          {"seed", o_.seed},
          {"stages", params_.stages},
          {"target_miss_rate", params_.target_miss_rate},
          {"negative_pool", params_.negative_pool},
          {"refill_every", params_.refill_every},
          {"max_cell", params_.max_cell},
          {"positives", positives.windows.size()},
          {"bowls", positives.bowls},
          {"negative_frames", set_.negatives.size()},
          {"jitter_px", o_.jitter}};
}

WaldBoostClassifier ViewTrainer::resumeOrStart(const json& training) const {
  if (fs::exists(checkpoint_)) {
    const auto c = loadBowlModel(checkpoint_);
    if (json::parse(c.training_json) == training && c.classifier.win_w == shape_.width &&
        c.classifier.win_h == shape_.height) {
      spdlog::info("[{}] resuming at stage {}", view_, c.classifier.stages.size());
      return c.classifier;
    }
  }
  return untrained_.classifier;
}

// A checkpoint is written where a refill is due: a resumed trainer starts with a refill, so
// resuming there reproduces the uninterrupted run (see WaldBoostTrainer).
WaldBoostStageStats ViewTrainer::trainStages(WaldBoostTrainer& trainer, const json& training,
                                             Clock::time_point t0) const {
  const NegativeSource source = [this](const WaldBoostClassifier& current, int stage,
                                       std::size_t count) {
    return bootstrapNegatives(current, stage, count);
  };
  WaldBoostStageStats st;
  while (true) {
    const int t = static_cast<int>(trainer.classifier().stages.size());
    if (t > 0 && trainer.isRefillStage(t)) saveCheckpoint(trainer.classifier(), training);
    if (!trainer.trainStage(source, &st)) break;
    progress(view_, st, params_.stages, secondsSince(t0));
  }
  std::fprintf(stderr, "\n");
  return st;
}

void ViewTrainer::saveCheckpoint(const WaldBoostClassifier& classifier,
                                 const json& training) const {
  BowlViewModel c = untrained_;
  c.classifier = classifier;
  c.training_json = training.dump();
  saveBowlModel(c, checkpoint_);
}

void ViewTrainer::saveModel(const WaldBoostClassifier& classifier, json training,
                            const WaldBoostStageStats& last, Clock::time_point t0) const {
  BowlViewModel model = untrained_;
  model.classifier = classifier;
  training["stages_trained"] = model.classifier.stages.size();
  training["final_positives_kept"] = last.positives_kept;
  training["final_negative_pool"] = last.negative_pool;
  model.training_json = training.dump();
  saveBowlModel(model, model_file_);
  fs::remove(checkpoint_);
  spdlog::info("[{}] {} stages in {:.1f} s -> {}", view_, model.classifier.stages.size(),
               secondsSince(t0), model_file_.string());
}

// The bootstrapping source: windows the current classifier accepts, from all frames in an
// order seeded by the view and stage, at most `cap` per frame so that the pool spreads over
// many frames. Frames are scanned `threads` at a time and their windows taken in frame order,
// so the result does not depend on which thread finishes first.
std::vector<cv::Mat> ViewTrainer::bootstrapNegatives(const WaldBoostClassifier& current, int stage,
                                                     std::size_t count) const {
  BowlViewModel m = untrained_;
  m.classifier = current;
  std::mt19937_64 rng(mix(mix(o_.seed, viewId(view_)), static_cast<std::uint64_t>(stage)));
  std::vector<std::size_t> order = set_.negatives;
  std::shuffle(order.begin(), order.end(), rng);
  const std::size_t cap = std::max<std::size_t>(4, count / 60);
  const auto threads = static_cast<std::size_t>(o_.threads);
  std::vector<cv::Mat> out;
  for (std::size_t b = 0; b < order.size() && out.size() < count; b += threads) {
    std::vector<std::future<std::vector<cv::Mat>>> jobs;
    for (std::size_t j = b; j < std::min(order.size(), b + threads); ++j)
      jobs.push_back(std::async(std::launch::async,
                                [&, j] { return acceptedWindowsOf(order[j], m, stage, cap); }));
    for (auto& job : jobs)
      for (auto& w : job.get())
        if (out.size() < count) out.push_back(std::move(w));
  }
  return out;
}

// Scanned like the detector does (same pyramid and depth gate) but at stride 1 where the
// detector uses 2: four times the candidate windows. Of those away from upright bowls, a
// seeded random `cap`.
std::vector<cv::Mat> ViewTrainer::acceptedWindowsOf(std::size_t frame, const BowlViewModel& current,
                                                    int stage, std::size_t cap) const {
  const int W = shape_.width, H = shape_.height;
  const auto& P = set_.prepared[frame];
  const auto levels = buildBowlPyramid(P.img8, det_.scale_step, W, H);
  std::vector<std::pair<std::size_t, BowlWindowHit>> hits;
  for (std::size_t k = 0; k < levels.size(); ++k) {
    const double obj_px = shape_.object_width * levels[k].scale;
    if (obj_px < det_.min_object_px || obj_px > det_.max_object_px) continue;
    for (const auto& h : scanBowlLevel(current, levels[k], P.filled, P.fx, 1, INT32_MIN))
      if (!nearUprightBowl(h, levels[k].scale, set_.frames[frame])) hits.push_back({k, h});
  }
  std::mt19937_64 r(mix(mix(o_.seed, static_cast<std::uint64_t>(stage) + 7), frame));
  std::shuffle(hits.begin(), hits.end(), r);
  std::vector<cv::Mat> windows;
  for (std::size_t q = 0; q < std::min(cap, hits.size()); ++q) {
    const auto& [k, h] = hits[q];
    windows.push_back(levels[k].image8(cv::Rect(h.x, h.y, W, H)).clone());
  }
  return windows;
}

// Whether the window's object box overlaps an upright bowl (IoU > 0.2): such windows are
// not negatives. Upside-down bowls are.
bool ViewTrainer::nearUprightBowl(const BowlWindowHit& hit, double scale,
                                  const DatasetFrame& f) const {
  const int W = shape_.width, H = shape_.height;
  const cv::Rect obj(static_cast<int>((hit.x + o_.margin * W) * scale),
                     static_cast<int>((hit.y + o_.margin * H) * scale),
                     static_cast<int>(shape_.object_width * scale),
                     static_cast<int>(shape_.object_height * scale));
  return std::any_of(f.bowls.begin(), f.bowls.end(), [&](const BowlAnnotation& b) {
    return b.upright && boxIoU(obj, b.box) > 0.2;
  });
}

}  // namespace

int runTrain(const TrainOptions& o) {
  const auto t0 = Clock::now();
  const TrainingFrames set = loadTrainingFrames(o);
  fs::create_directories(o.out / ".checkpoints");
  for (const auto& view : o.views) {
    const auto shape = chooseWindowShape(set.frames, view, o);
    if (!shape) {
      spdlog::warn("no training bowls for view {}", view);
      continue;
    }
    ViewTrainer(o, set, view, *shape).run();
  }
  fs::remove_all(o.out / ".checkpoints");
  spdlog::info("training done in {:.1f} s", secondsSince(t0));
  return 0;
}

}  // namespace shapesense::train
