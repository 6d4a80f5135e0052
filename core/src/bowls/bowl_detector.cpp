#include "shapesense/core/bowls/bowl_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "bowls/bowl_scan_kernels.h"
#include "shapesense/core/bowls/depth_preprocess.h"
#include "shapesense/core/bowls/lbp.h"
#include "shapesense/core/geometry/image_boxes.h"

namespace shapesense {

std::vector<BowlPyramidLevel> buildBowlPyramid(const cv::Mat& image8, double scale_step, int min_w,
                                               int min_h, double max_scale,
                                               double min_integral_scale) {
  CV_Assert(image8.type() == CV_8UC1 && scale_step > 1.0);
  std::vector<BowlPyramidLevel> levels;
  cv::Mat cur = image8;
  double scale = 1.0;
  while (cur.cols >= min_w && cur.rows >= min_h && scale <= max_scale) {
    BowlPyramidLevel l;
    l.scale = scale;
    l.image8 = cur;
    // A small tolerance: scales are products of scale_step and may round below the bound.
    if (scale >= min_integral_scale * (1.0 - 1e-9)) cv::integral(cur, l.integral, CV_32S);
    levels.push_back(std::move(l));
    scale *= scale_step;
    const cv::Size next(static_cast<int>(std::lround(image8.cols / scale)),
                        static_cast<int>(std::lround(image8.rows / scale)));
    if (next.width < 1 || next.height < 1) break;
    cv::Mat nxt;
    cv::resize(cur, nxt, next, 0, 0, cv::INTER_LINEAR);
    cur = nxt;
  }
  return levels;
}

double inscribedCircleOverlap(const cv::Rect& a, const cv::Rect& b) {
  const double r1 = std::min(a.width, a.height) / 2.0, r2 = std::min(b.width, b.height) / 2.0;
  if (r1 <= 0 || r2 <= 0) return 0.0;
  const double d = std::hypot((a.x + a.width / 2.0) - (b.x + b.width / 2.0),
                              (a.y + a.height / 2.0) - (b.y + b.height / 2.0));
  const double small = std::min(r1, r2), large = std::max(r1, r2);
  const double small_area = std::numbers::pi * small * small;
  if (d >= r1 + r2) return 0.0;
  if (d <= large - small) return 1.0;
  // Lens area of two intersecting circles.
  const double a1 =
      r1 * r1 * std::acos(std::clamp((d * d + r1 * r1 - r2 * r2) / (2 * d * r1), -1.0, 1.0));
  const double a2 =
      r2 * r2 * std::acos(std::clamp((d * d + r2 * r2 - r1 * r1) / (2 * d * r2), -1.0, 1.0));
  const double k = 0.5 * std::sqrt(std::max(
                             0.0, (-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2)));
  return std::clamp((a1 + a2 - k) / small_area, 0.0, 1.0);
}

namespace {

// The windows with IoU >= min_iou to a box: how many, and their mean box (corner by corner).
struct Neighbourhood {
  cv::Rect mean_box;
  int count = 0;
};

Neighbourhood neighboursOf(const cv::Rect& box, const std::vector<BowlDetection>& windows,
                           double min_iou) {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int n = 0;
  for (const auto& w : windows) {
    if (boxIoU(w.box, box) < min_iou) continue;
    x0 += w.box.x, y0 += w.box.y, x1 += w.box.x + w.box.width, y1 += w.box.y + w.box.height;
    ++n;
  }
  if (n == 0) return {box, 0};
  const int left = static_cast<int>(std::lround(x0 / n)),
            top = static_cast<int>(std::lround(y0 / n));
  return {{left, top, static_cast<int>(std::lround(x1 / n)) - left,
           static_cast<int>(std::lround(y1 / n)) - top},
          n};
}

}  // namespace

std::vector<BowlDetection> suppressNonMaxima(std::vector<BowlDetection> dets, double max_overlap,
                                             double merge_iou, double support_weight) {
  std::stable_sort(dets.begin(), dets.end(),
                   [](const auto& a, const auto& b) { return a.score > b.score; });
  std::vector<BowlDetection> kept;
  for (const auto& d : dets) {
    bool distinct = true;
    for (const auto& k : kept)
      if (inscribedCircleOverlap(d.box, k.box) >= max_overlap) {
        distinct = false;
        break;
      }
    if (distinct) kept.push_back(d);
  }
  if (merge_iou <= 0) return kept;
  for (auto& k : kept) {
    const Neighbourhood around = neighboursOf(k.box, dets, merge_iou);
    k.box = around.mean_box;
    if (support_weight > 0 && around.count > 1) k.score += support_weight * std::log(around.count);
  }
  std::stable_sort(kept.begin(), kept.end(),
                   [](const auto& a, const auto& b) { return a.score > b.score; });
  return kept;
}

void addLbpCodeImages(BowlPyramidLevel& level, const std::array<bool, 4>& cell_sizes,
                      const std::vector<std::uint8_t>& rows) {
  CV_Assert(!level.integral.empty());
  for (int k = 0; k < 4; ++k)
    if (cell_sizes[k]) level.codes[k] = lbpCodeImage(level.image8, 1 + k % 2, 1 + k / 2, rows);
}

namespace {

int cellSizeIndex(const LbpFeature& f) { return (f.cw - 1) + 2 * (f.ch - 1); }

/// Where one stage reads its LBP code for the window at (x, y): a byte of the level's code
/// image of its cell size (`code_base` + y * code stride + x) when there is one, else the
/// 16 integral-image corners at `offsets` from the window's integral element.
struct StageCodeReader {
  const std::uint8_t* code_base = nullptr;
  LbpOffsets offsets{};
};

/// The depth gate of one view on one level: object width in input pixels is
/// W * (1 - 2m) * scale; at depth z it spans that * z / fx metres. Depths are whole millimetres,
/// so the bounds are compared as integers, and each window column's input column is looked up
/// once per level. A window at (x, y) passes when the filled depth at row(y) and
/// input_column[x / stride] lies in [z_lo, z_hi].
struct DepthGate {
  bool on = false;
  int z_lo = 0, z_hi = 0;
  std::vector<int> input_column;
  /// One flag per window row (y / stride): whether any window of the row lies in the gate.
  std::vector<std::uint8_t> open_rows;
  bool admits(int z_mm) const { return (z_mm >= z_lo) & (z_mm <= z_hi); }
  const std::uint16_t* row(const cv::Mat& filled_mm, int y, int win_h, double scale) const {
    return filled_mm.ptr<std::uint16_t>(
        std::min(filled_mm.rows - 1, static_cast<int>((y + win_h * 0.5) * scale)));
  }
};

DepthGate depthGate(const BowlViewModel& model, const BowlPyramidLevel& level,
                    const cv::Mat& filled_mm, double fx, int stride) {
  DepthGate g;
  const int W = model.classifier.win_w;
  const double obj_px = W * (1.0 - 2.0 * model.object_margin) * level.scale;
  g.on = !filled_mm.empty() && fx > 0;
  const double zmin_mm = model.min_object_width_m * fx / obj_px * 1000.0;
  const double zmax_mm = model.max_object_width_m * fx / obj_px * 1000.0;
  g.z_lo = static_cast<int>(std::clamp(std::ceil(zmin_mm), 0.0, 65536.0));
  g.z_hi = static_cast<int>(std::clamp(std::floor(zmax_mm), -1.0, 65535.0));
  if (!g.on) return g;
  for (int x = 0; x + W <= level.image8.cols; x += stride)
    g.input_column.push_back(
        std::min(filled_mm.cols - 1, static_cast<int>((x + W * 0.5) * level.scale)));
  const int H = model.classifier.win_h;
  for (int y = 0; y + H <= level.image8.rows; y += stride) {
    const std::uint16_t* zrow = g.row(filled_mm, y, H, level.scale);
    g.open_rows.push_back(std::any_of(g.input_column.begin(), g.input_column.end(),
                                      [&](int c) { return g.admits(zrow[c]); }));
  }
  return g;
}

/// Marks in `rows` the level rows that the windows of `model` passing its depth gate `g` on this
/// level cover (all rows of any window row with at least one window in the gate).
void markGatedRows(const BowlViewModel& model, const BowlPyramidLevel& level, const DepthGate& g,
                   int stride, std::vector<std::uint8_t>& rows) {
  const int H = model.classifier.win_h;
  for (int y = 0; y + H <= level.image8.rows; y += stride)
    if (!g.on || g.open_rows[static_cast<std::size_t>(y / stride)])
      std::fill(rows.begin() + y, rows.begin() + y + H, std::uint8_t{1});
}

/// A model that cannot reach the final score anywhere would only cost time (a model without
/// stages accepts every gated window: bootstrapping).
bool canReach(const WaldBoostClassifier& clf, std::int32_t min_final_score) {
  return clf.stages.empty() || clf.maxScore() >= min_final_score;
}

/// scanBowlLevel for a model that canReach the score, with its depth gate on this level and its
/// rejectionThresholds(min_final_score) given: the detector computes the thresholds once per
/// frame rather than once per level, and the gate once for marking code rows and scanning.
std::vector<BowlWindowHit> scanLevel(const BowlViewModel& model, const BowlPyramidLevel& level,
                                     const cv::Mat& filled_mm, const DepthGate& dg, int stride,
                                     std::int32_t min_final_score,
                                     const std::vector<std::int32_t>& thresholds) {
  std::vector<BowlWindowHit> hits;
  const auto& clf = model.classifier;
  const int W = clf.win_w, H = clf.win_h;
  const int lw = level.image8.cols, lh = level.image8.rows;
  if (lw < W || lh < H) return hits;
  const std::size_t n_stages = clf.stages.size();

  const int integral_stride = static_cast<int>(level.integral.step1());
  int code_stride = -1;
  for (const auto& c : level.codes) {
    if (c.empty()) continue;
    CV_Assert(c.size() == level.image8.size() &&
              (code_stride < 0 || static_cast<int>(c.step1()) == code_stride));
    code_stride = static_cast<int>(c.step1());
  }
  std::vector<StageCodeReader> readers(n_stages);
  for (std::size_t t = 0; t < n_stages; ++t) {
    const LbpFeature& f = clf.stages[t].feature;
    const bool small_cells = f.cw <= 2 && f.ch <= 2;
    if (small_cells && !level.codes[cellSizeIndex(f)].empty())
      readers[t].code_base = level.codes[cellSizeIndex(f)].ptr<std::uint8_t>(f.y) + f.x;
    else
      readers[t].offsets = lbpOffsets(f, integral_stride);
  }
  const bool gate = dg.on;
  const std::vector<int>& input_column = dg.input_column;

  // The windows of one row go through the cascade together, stage by stage: each stage adds
  // its vote to every window still in the row and keeps those at or above its threshold in
  // place (the list is compacted, order kept). A per-window early exit would branch on every
  // stage, and the early stages reject about half of the windows at random, so most of those
  // branches were mispredicted; the compaction has no data-dependent branch. Every window
  // gets the same votes in the same order, so scores and hits are the same as window by window.
  const std::size_t row_windows = static_cast<std::size_t>((lw - W) / stride + 1);
  std::vector<int> alive_x(row_windows);               // x of the windows still in the cascade
  std::vector<std::int32_t> alive_score(row_windows);  // their running scores
  // The depth gate and the first two stages (when both read code images) share the first
  // compaction pass. Rows where no window lies in the gate (about a third of the rows of a
  // level on real frames) are skipped whole.
  const std::size_t fused_stages =
      n_stages >= 2 && readers[0].code_base && readers[1].code_base ? 2 : 0;
  // At the default stride the first pass runs in SIMD vectors (bowl_scan_kernels.h), which
  // gather the votes from 32-bit tables and read the gate from a flag per window.
  const bool vector_pass = fused_stages == 2 && stride == 2;
  std::vector<std::uint8_t> in_gate(row_windows, 1);  // per window of the row: in the gate
  for (int y = 0; y + H <= lh; y += stride) {
    if (gate) {
      if (!dg.open_rows[static_cast<std::size_t>(y / stride)]) continue;
      const std::uint16_t* zrow = dg.row(filled_mm, y, H, level.scale);
      for (std::size_t i = 0; i < row_windows; ++i)
        in_gate[i] = static_cast<std::uint8_t>(dg.admits(zrow[input_column[i]]));
    }
    const std::ptrdiff_t code_row = static_cast<std::ptrdiff_t>(y) * code_stride;
    std::size_t alive = 0, first = 0;
    if (fused_stages == 2) {
      const std::uint8_t* codes0 = readers[0].code_base + code_row;
      const std::uint8_t* codes1 = readers[1].code_base + code_row;
      const std::int32_t threshold0 = thresholds[0], threshold1 = thresholds[1];
      if (vector_pass) {
        const auto done = bowls::firstStagesStride2({.codes0 = codes0,
                                                     .codes1 = codes1,
                                                     .lut0 = clf.stages[0].lut.data(),
                                                     .lut1 = clf.stages[1].lut.data(),
                                                     .threshold0 = threshold0,
                                                     .threshold1 = threshold1,
                                                     .in_gate = in_gate.data(),
                                                     .windows = row_windows},
                                                    alive_x.data(), alive_score.data());
        first = done.processed;
        alive = done.kept;
      }
      const std::int32_t* lut0 = clf.stages[0].lut.data();
      const std::int32_t* lut1 = clf.stages[1].lut.data();
      for (std::size_t i = first; i < row_windows; ++i) {
        const int x = static_cast<int>(i) * stride;
        const std::int32_t h0 = lut0[codes0[x]], h1 = h0 + lut1[codes1[x]];
        alive_x[alive] = x;
        alive_score[alive] = h1;
        alive += static_cast<std::size_t>(in_gate[i] & (h0 >= threshold0) & (h1 >= threshold1));
      }
    } else {
      for (std::size_t i = 0; i < row_windows; ++i) {
        alive_x[alive] = static_cast<int>(i) * stride;
        alive_score[alive] = 0;
        alive += in_gate[i];
      }
    }
    const std::int32_t* integral_row = level.integral.ptr<std::int32_t>(y);
    for (std::size_t t = fused_stages; t < n_stages && alive > 0; ++t) {
      const StageCodeReader& r = readers[t];
      const std::int32_t* lut = clf.stages[t].lut.data();
      const std::int32_t threshold = thresholds[t];
      std::size_t kept = 0;
      // Two code-image stages in one compaction pass, as the first two: a window the first
      // rejects costs one more lookup, every survivor one load and store fewer.
      if (r.code_base && t + 1 < n_stages && readers[t + 1].code_base) {
        const std::uint8_t* codes = r.code_base + code_row;
        const std::uint8_t* codes_next = readers[t + 1].code_base + code_row;
        const std::int32_t* lut_next = clf.stages[t + 1].lut.data();
        const std::int32_t threshold_next = thresholds[t + 1];
        for (std::size_t k = 0; k < alive; ++k) {
          const int x = alive_x[k];
          const std::int32_t h = alive_score[k] + lut[codes[x]];
          const std::int32_t h_next = h + lut_next[codes_next[x]];
          alive_x[kept] = x;
          alive_score[kept] = h_next;
          kept += static_cast<std::size_t>((h >= threshold) & (h_next >= threshold_next));
        }
        alive = kept;
        ++t;
        continue;
      }
      if (r.code_base) {
        const std::uint8_t* codes = r.code_base + code_row;
        for (std::size_t k = 0; k < alive; ++k) {
          const int x = alive_x[k];
          const std::int32_t h = alive_score[k] + lut[codes[x]];
          alive_x[kept] = x;
          alive_score[kept] = h;
          kept += static_cast<std::size_t>(h >= threshold);
        }
      } else {
        for (std::size_t k = 0; k < alive; ++k) {
          const int x = alive_x[k];
          const std::int32_t h = alive_score[k] + lut[lbpCodeIntegral(integral_row + x, r.offsets)];
          alive_x[kept] = x;
          alive_score[kept] = h;
          kept += static_cast<std::size_t>(h >= threshold);
        }
      }
      alive = kept;
    }
    for (std::size_t k = 0; k < alive; ++k)
      if (alive_score[k] >= min_final_score) hits.push_back({alive_x[k], y, alive_score[k]});
  }
  return hits;
}

}  // namespace

std::vector<BowlWindowHit> scanBowlLevel(const BowlViewModel& model, const BowlPyramidLevel& level,
                                         const cv::Mat& filled_mm, double fx, int stride,
                                         std::int32_t min_final_score) {
  if (!canReach(model.classifier, min_final_score)) return {};
  return scanLevel(model, level, filled_mm, depthGate(model, level, filled_mm, fx, stride), stride,
                   min_final_score, model.classifier.rejectionThresholds(min_final_score));
}

BowlDetector BowlDetector::load(const std::filesystem::path& path, BowlDetectorParams params) {
  std::vector<BowlViewModel> models;
  if (std::filesystem::is_directory(path)) {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(path)) {
      const auto name = e.path().filename().string();
      if (e.is_regular_file() && name.starts_with("bowl_") && e.path().extension() == ".json")
        files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    for (const auto& f : files) models.push_back(loadBowlModel(f));
  } else {
    models.push_back(loadBowlModel(path));
  }
  if (models.empty()) throw std::runtime_error("no bowl_*.json model in " + path.string());
  return BowlDetector(std::move(models), std::move(params));
}

namespace {

/// The operating point the models state (they must agree), the score threshold replaced by
/// `score_threshold` when it is set. Models that state none need one set; without their
/// stated unverified threshold no unverified detection is kept.
BowlOperatingPoint resolveOperatingPoint(const std::vector<BowlViewModel>& models,
                                         const std::optional<double>& score_threshold) {
  std::optional<BowlOperatingPoint> stated;
  for (const auto& m : models) {
    if (!m.operating_point) continue;
    if (stated && !(*stated == *m.operating_point))
      throw std::runtime_error("BowlDetector: models disagree on the operating point");
    stated = m.operating_point;
  }
  if (!stated && !score_threshold)
    throw std::runtime_error(
        "BowlDetector: the models state no operating point; set a score threshold");
  BowlOperatingPoint point = stated.value_or(
      BowlOperatingPoint{.score_threshold = 0,
                         .unverified_score_threshold = std::numeric_limits<double>::infinity(),
                         .chosen_on = ""});
  if (score_threshold) {
    point.score_threshold = *score_threshold;
    point.chosen_on = "set by the caller";
  }
  return point;
}

}  // namespace

BowlDetector::BowlDetector(std::vector<BowlViewModel> models, BowlDetectorParams params)
    : models_(std::move(models)),
      params_(std::move(params)),
      depth_map_(models_.empty() ? DepthPreprocessParams{} : models_.front().preprocess) {
  if (models_.empty()) throw std::runtime_error("BowlDetector: no models");
  const auto& p0 = models_.front().preprocess;
  for (const auto& m : models_) {
    const auto& p = m.preprocess;
    if (p.near_m != p0.near_m || p.far_m != p0.far_m || p.low != p0.low || p.high != p0.high)
      throw std::runtime_error("BowlDetector: models disagree on the depth mapping");
  }
  operating_point_ = resolveOperatingPoint(models_, params_.score_threshold);
}

std::vector<BowlDetection> BowlDetector::detectRaw(const cv::Mat& depth_mm,
                                                   const CameraIntrinsics& intr) const {
  if (depth_mm.type() != CV_16UC1)
    throw std::invalid_argument("BowlDetector: depth must be CV_16UC1 mm");
  cv::Mat filled;
  const cv::Mat img8 = preprocessDepth(depth_mm, depth_map_, &filled);
  std::vector<const BowlViewModel*> active;
  int min_w = INT32_MAX, min_h = INT32_MAX;
  double min_obj_frac = 1.0;
  for (const auto& m : models_) {
    if (!params_.views.empty() &&
        std::find(params_.views.begin(), params_.views.end(), m.view) == params_.views.end())
      continue;
    active.push_back(&m);
    min_w = std::min(min_w, m.classifier.win_w);
    min_h = std::min(min_h, m.classifier.win_h);
    min_obj_frac = std::min(min_obj_frac, 1.0 - 2.0 * m.object_margin);
  }
  if (active.empty()) return {};
  const double max_scale = params_.max_object_px / (min_w * min_obj_frac);
  double min_scale = 1e9;  // the finest level any view searches
  for (const auto* m : active)
    min_scale = std::min(
        min_scale, params_.min_object_px / (m->classifier.win_w * (1.0 - 2.0 * m->object_margin)));
  auto levels = buildBowlPyramid(img8, params_.scale_step, min_w, min_h, max_scale, min_scale);
  const auto min_score =
      static_cast<std::int32_t>(std::ceil(operating_point_.score_threshold / kWaldBoostScoreUnit));
  std::array<bool, 4> code_cell_sizes{};
  bool any_code_image = false;
  // Per active view, computed once per frame rather than per level: whether it can fire at all,
  // and its rejection thresholds.
  std::vector<char> reachable(active.size(), 0);
  std::vector<std::vector<std::int32_t>> thresholds(active.size());
  for (std::size_t v = 0; v < active.size(); ++v) {
    const BowlViewModel* m = active[v];
    const auto& stages = m->classifier.stages;
    if (!canReach(m->classifier, min_score)) continue;  // can never fire: not scanned
    reachable[v] = 1;
    thresholds[v] = m->classifier.rejectionThresholds(min_score);
    const std::size_t n =
        std::min(stages.size(), static_cast<std::size_t>(std::max(0, params_.code_image_stages)));
    for (std::size_t t = 0; t < n; ++t) {
      const LbpFeature& f = stages[t].feature;
      if (f.cw <= 2 && f.ch <= 2) any_code_image = code_cell_sizes[cellSizeIndex(f)] = true;
    }
  }
  const cv::Mat gate = params_.depth_gate ? filled : cv::Mat();
  // Code images only for the rows some scanned window in the depth gate covers: in real frames
  // whole bands of a level (the depths its window size misfits) are never classified.
  auto scanned = [&](const BowlPyramidLevel& level, std::size_t view) {
    const auto& m = *active[view];
    const double obj_px = m.classifier.win_w * (1.0 - 2.0 * m.object_margin) * level.scale;
    return reachable[view] && !level.integral.empty() && obj_px >= params_.min_object_px &&
           obj_px <= params_.max_object_px;
  };
  // One task per (level, view) that is scanned; its depth gate serves the code rows and the scan.
  const std::size_t tasks = levels.size() * active.size();
  std::vector<DepthGate> gates(tasks);
  for (std::size_t task = 0; task < tasks; ++task) {
    const auto& level = levels[task / active.size()];
    const std::size_t view = task % active.size();
    if (scanned(level, view))
      gates[task] = depthGate(*active[view], level, gate, intr.fx, params_.stride);
  }
  if (any_code_image) {
    std::vector<std::uint8_t> rows;
    for (std::size_t l = 0; l < levels.size(); ++l) {
      auto& level = levels[l];
      if (level.integral.empty()) continue;
      rows.assign(static_cast<std::size_t>(level.image8.rows), 0);
      for (std::size_t v = 0; v < active.size(); ++v)
        if (scanned(level, v))
          markGatedRows(*active[v], level, gates[l * active.size() + v], params_.stride, rows);
      if (std::find(rows.begin(), rows.end(), std::uint8_t{1}) != rows.end())
        addLbpCodeImages(level, code_cell_sizes, rows);
    }
  }

  // Results gathered per task so the output order is fixed.
  std::vector<std::vector<BowlDetection>> per_task(tasks);
  auto run = [&](std::size_t task) {
    const auto& level = levels[task / active.size()];
    const std::size_t view = task % active.size();
    const auto& m = *active[view];
    if (!scanned(level, view)) return;
    const auto hits =
        scanLevel(m, level, gate, gates[task], params_.stride, min_score, thresholds[view]);
    const double mx = m.object_margin * m.classifier.win_w,
                 my = m.object_margin * m.classifier.win_h;
    const double ow = m.classifier.win_w - 2 * mx, oh = m.classifier.win_h - 2 * my;
    for (const auto& h : hits) {
      cv::Rect box(static_cast<int>(std::lround((h.x + mx) * level.scale)),
                   static_cast<int>(std::lround((h.y + my) * level.scale)),
                   static_cast<int>(std::lround(ow * level.scale)),
                   static_cast<int>(std::lround(oh * level.scale)));
      per_task[task].push_back({box, h.score * kWaldBoostScoreUnit, m.view, std::nullopt});
    }
  };
  if (params_.parallel) {
    cv::parallel_for_(cv::Range(0, static_cast<int>(per_task.size())), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) run(static_cast<std::size_t>(i));
    });
  } else {
    for (std::size_t i = 0; i < per_task.size(); ++i) run(i);
  }
  std::vector<BowlDetection> out;
  for (auto& v : per_task)
    out.insert(out.end(), std::make_move_iterator(v.begin()), std::make_move_iterator(v.end()));
  return out;
}

std::vector<BowlDetection> BowlDetector::detect(const cv::Mat& depth_mm,
                                                const CameraIntrinsics& intr) const {
  return suppressNonMaxima(detectRaw(depth_mm, intr), params_.nms_max_overlap,
                           params_.box_merge_iou, params_.support_score_weight);
}

std::vector<BowlDetection> keepBowlShaped(std::vector<BowlDetection> detections,
                                          const cv::Mat& depth_mm,
                                          const CameraIntrinsics& intrinsics,
                                          const PlaneDetection& planes,
                                          const BowlGeometryParams& params,
                                          double min_unverified_score) {
  std::erase_if(detections, [&](BowlDetection& detection) {
    const auto measured = measureBowlGeometry(depth_mm, intrinsics, detection.box, planes, params);
    if (measured.isBowl()) detection.geometry = measured.geometry;
    return !reportsBowl(measured, detection.score, min_unverified_score);
  });
  return detections;
}

bool reportsBowl(const BowlGeometryResult& measured, double score, double min_unverified_score) {
  return measured.isBowl() ||
         (isInconclusive(*measured.rejection) && score >= min_unverified_score);
}

}  // namespace shapesense
