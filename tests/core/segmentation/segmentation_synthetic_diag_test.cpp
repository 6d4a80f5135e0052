// Diagnostics (disabled by default): where does a method lose pixel accuracy against the synthetic
// per-surface truth, what bounds a depth-step-only method, which regions cover the mosd table.
// Run: core_tests --gtest_also_run_disabled_tests --gtest_filter='SegmentationSyntheticDiag.*'
// Env: SEG_DIAG_METHOD (default depth_step / plane_prediction), SEG_DIAG_VERBOSE=1 (per truth
// surface), SEG_DIAG_PAIRS (oracle contact length, default 10), SEG_DIAG_RMS (coplanar merge),
// SEG_FUSED_{ANGLE,WIN,SMOOTH}, SEG_DIAG_DUMP=<dir> (colour images of regions and edges).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mosd_table.h"
#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

struct Loss {
  long labelled = 0, unassigned = 0, merged = 0;
};

// Pixels lost: truth pixels with found 0, and truth pixels inside a found region whose best truth
// is another surface (merged away).
Loss lossOf(const cv::Mat& found, const synthetic::RenderedFrame& f, bool verbose) {
  const cv::Mat& truth = f.truth.surface_labels;
  std::map<int, std::map<int, int>> ov;  // found -> truth -> count
  std::map<int, int> tsize, tunassigned;
  Loss l;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) {
      const int t = truth.at<std::uint16_t>(v, u);
      if (!t) continue;
      ++l.labelled;
      ++tsize[t];
      const int r = found.at<std::uint16_t>(v, u);
      if (!r) {
        ++l.unassigned;
        ++tunassigned[t];
        continue;
      }
      ++ov[r][t];
    }
  std::map<int, int> best_of;  // found -> best truth
  std::map<int, long> tkept, tmerged;
  for (auto& [r, m] : ov) {
    int bt = 0, bc = 0;
    for (auto [t, c] : m)
      if (c > bc) {
        bc = c;
        bt = t;
      }
    best_of[r] = bt;
    for (auto [t, c] : m) {
      if (t == bt)
        tkept[t] += c;
      else {
        tmerged[t] += c;
        l.merged += c;
      }
    }
  }
  if (verbose) {
    for (auto [t, n] : tsize) {
      if (n < 300) continue;
      std::string name = "?";
      for (const auto& s : f.truth.surfaces)
        if (s.id == t) name = s.name;
      // Which found region holds most of t, and who owns it.
      int br = 0, bc = 0;
      for (auto& [r, m] : ov) {
        auto it = m.find(t);
        if (it != m.end() && it->second > bc) {
          bc = it->second;
          br = r;
        }
      }
      std::string owner = "-";
      if (br)
        for (const auto& s : f.truth.surfaces)
          if (s.id == best_of[br]) owner = s.name;
      std::printf(
          "   %-26s %6d px  kept %5.1f%%  merged %5.1f%%  unassigned %5.1f%%  main region %3d "
          "(owner %s)\n",
          name.c_str(), n, 100.0 * tkept[t] / n, 100.0 * tmerged[t] / n, 100.0 * tunassigned[t] / n,
          br, owner.c_str());
    }
  }
  return l;
}

// Ceiling of any depth-step segmentation: truth surfaces that touch along >= 10 pixel pairs
// without a depth step (same rule as DepthStepParams defaults at 1 px) are merged; the pixel
// accuracy of that partition bounds what an edge detector that only sees steps can reach.
double stepOracleAccuracy(const synthetic::RenderedFrame& f) {
  const cv::Mat& t = f.truth.surface_labels;
  const cv::Mat& d = f.frame.depth;
  std::map<std::pair<int, int>, int> cont;
  std::map<int, long> size;
  auto stepAt = [](double a, double b) {
    const double z = std::min(a, b);
    return std::fabs(a - b) > std::max(10.0, 3.0 * 0.125 / 43.5 * 1e-3 * z * z + 0.01 * z);
  };
  for (int v = 0; v < t.rows; ++v)
    for (int u = 0; u < t.cols; ++u) {
      const int a = t.at<std::uint16_t>(v, u);
      if (!a) continue;
      ++size[a];
      for (auto [du, dv] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (u + du >= t.cols || v + dv >= t.rows) continue;
        const int b = t.at<std::uint16_t>(v + dv, u + du);
        if (!b || b == a) continue;
        if (!stepAt(d.at<std::uint16_t>(v, u), d.at<std::uint16_t>(v + dv, u + du)))
          ++cont[{std::min(a, b), std::max(a, b)}];
      }
    }
  std::map<int, int> parent;
  for (auto [l, n] : size) parent[l] = l;
  std::function<int(int)> root = [&](int x) {
    return parent[x] == x ? x : parent[x] = root(parent[x]);
  };
  static const int min_pairs =
      std::getenv("SEG_DIAG_PAIRS") ? std::atoi(std::getenv("SEG_DIAG_PAIRS")) : 10;
  for (auto [k, n] : cont)
    if (n >= min_pairs) parent[root(k.first)] = root(k.second);
  std::map<int, long> best;
  long total = 0;
  for (auto [l, n] : size) {
    best[root(l)] = std::max(best[root(l)], n);
    total += n;
  }
  long good = 0;
  for (auto [r, n] : best) good += n;
  return double(good) / total;
}

TEST(SegmentationSyntheticDiag, DISABLED_PerRegionLoss) {
  const char* env = std::getenv("SEG_DIAG_METHOD");
  const SegmentationMethod m =
      parseSegmentationMethod(env ? env : "depth_step").value_or(SegmentationMethod::kDepthStep);
  const bool verbose = std::getenv("SEG_DIAG_VERBOSE") != nullptr;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    synthetic::SceneParams p;
    p.seed = seed;
    p.render_colour = false;
    const synthetic::SyntheticScene scene(p);
    const synthetic::RenderedFrame f = scene.render(0, 0);
    std::printf("[diag] seed %llu step-only oracle accuracy %.3f\n",
                static_cast<unsigned long long>(seed), stepOracleAccuracy(f));
    struct Variant {
      const char* name;
      SegmentationParams sp;
    };
    SegmentationParams base;
    if (const char* e = std::getenv("SEG_FUSED_ANGLE"))
      base.fused.normal.max_angle_deg = std::atof(e);
    if (const char* e = std::getenv("SEG_FUSED_WIN"))
      base.fused.normal.window_radius = std::atoi(e);
    if (const char* e = std::getenv("SEG_FUSED_SMOOTH"))
      base.fused.normal.normals.smoothing_radius_px = std::atof(e);
    if (const char* e = std::getenv("SEG_PP_RADIUS"))
      base.plane_prediction.window_radius = std::atoi(e);
    if (const char* e = std::getenv("SEG_PP_LONG")) base.plane_prediction.long_range = std::atoi(e);
    if (const char* e = std::getenv("SEG_PP_LSTEPS"))
      base.plane_prediction.long_noise_steps = std::atof(e);
    if (const char* e = std::getenv("SEG_PP_FALLBACK"))
      base.plane_prediction.curved_fallback_markers = std::atoi(e) != 0;
    if (const char* e = std::getenv("SEG_PP_STEPS"))
      base.plane_prediction.noise_steps = std::atof(e);
    SegmentationParams full = base;
    full.depth_step.region.downsample = full.normal_edges.region.downsample =
        full.fused.region.downsample = full.plane_prediction.region.downsample =
            full.tiled_ransac.region.downsample = 1;
    SegmentationParams nomerge = base;
    nomerge.depth_step.region.merge_coplanar = nomerge.normal_edges.region.merge_coplanar =
        nomerge.fused.region.merge_coplanar = nomerge.plane_prediction.region.merge_coplanar =
            nomerge.tiled_ransac.region.merge_coplanar = false;
    for (const Variant& var :
         {Variant{"default", base}, Variant{"ds=1", full}, Variant{"no-merge", nomerge}}) {
      const cv::Mat r = segmentDepth(f.frame.depth, f.frame.intrinsics, m, var.sp);
      const SegCompScore s = scoreSegmentation(r, f.truth.surface_labels);
      double mx;
      cv::minMaxLoc(r, nullptr, &mx);
      const SegCompScore so = scoreSegmentation(r, f.truth.object_labels);
      std::printf("[diag] seed %llu %s object-level acc %.3f correct %.2f\n",
                  static_cast<unsigned long long>(seed), var.name, so.pixel_accuracy,
                  so.correct_fraction);
      const Loss l = lossOf(r, f, verbose && std::string(var.name) == "default");
      std::printf(
          "[diag] seed %llu %-16s %-9s regions %3.0f acc %.3f correct %.2f  lost: unassigned %.3f "
          "merged %.3f\n",
          static_cast<unsigned long long>(seed), std::string(formatSegmentationMethod(m)).c_str(),
          var.name, mx, s.pixel_accuracy, s.correct_fraction, double(l.unassigned) / l.labelled,
          double(l.merged) / l.labelled);
    }
  }
}

}  // namespace
}  // namespace shapesense

namespace shapesense {
namespace {

// mosd_tabletop: which regions cover the table (labels 1-9), per method, and their own size.
TEST(SegmentationSyntheticDiag, DISABLED_MosdTable) {
  const std::string dir = std::string(SHAPESENSE_SHARED_DIR) + "/data/real/mosd_tabletop";
  const char* env = std::getenv("SEG_DIAG_METHOD");
  const SegmentationMethod m = parseSegmentationMethod(env ? env : "plane_prediction")
                                   .value_or(SegmentationMethod::kPlanePrediction);
  SegmentationParams sp;
  if (const char* e = std::getenv("SEG_DIAG_RMS")) {
    const double x = std::atof(e);
    sp.depth_step.region.coplanar_rms_steps = sp.normal_edges.region.coplanar_rms_steps =
        sp.fused.region.coplanar_rms_steps = sp.plane_prediction.region.coplanar_rms_steps =
            sp.tiled_ransac.region.coplanar_rms_steps = x;
  }
  for (const char* name : {"1600000000.000000", "1600000000.033333", "1600000000.066667",
                           "1600000000.100000", "1600000000.133333", "1600000000.166667"}) {
    const cv::Mat raw = cv::imread(dir + "/depth/" + name + ".png", cv::IMREAD_UNCHANGED);
    const cv::Mat labels = cv::imread(dir + "/labels/" + name + ".png", cv::IMREAD_UNCHANGED);
    cv::Mat depth;
    raw.convertTo(depth, CV_16UC1, 0.2);
    double zmin, zmax;
    cv::minMaxLoc(depth, &zmin, &zmax, nullptr, nullptr,
                  (labels >= 1) & (labels <= 9) & (depth > 0));
    const cv::Mat r = segmentDepth(depth, CameraIntrinsics{}, m, sp);
    if (const char* dump = std::getenv("SEG_DIAG_DUMP")) {
      auto colour = [](const cv::Mat& l, int mul) {
        cv::Mat o(l.size(), CV_8UC3);
        for (int v = 0; v < l.rows; ++v)
          for (int u = 0; u < l.cols; ++u) {
            const unsigned x = l.at<std::uint16_t>(v, u);
            const unsigned h = x * mul * 2654435761u;
            o.at<cv::Vec3b>(v, u) =
                x ? cv::Vec3b(64 + (h >> 8) % 192, 64 + (h >> 16) % 192, 64 + (h >> 24) % 192)
                  : cv::Vec3b(0, 0, 0);
          }
        return o;
      };
      cv::Mat dv;
      depth.convertTo(dv, CV_8U, 255.0 / 1200, -500 * 255.0 / 1200);
      cv::cvtColor(dv, dv, cv::COLOR_GRAY2BGR);
      cv::Mat row;
      cv::Mat e = segmentationEdgeStrength(depth, CameraIntrinsics{}, m, sp), e8;
      cv::resize(e, e, depth.size(), 0, 0, cv::INTER_NEAREST);
      e.convertTo(e8, CV_8U, 20);
      cv::cvtColor(e8, e8, cv::COLOR_GRAY2BGR);
      cv::hconcat(std::vector<cv::Mat>{dv, colour(labels, 7), colour(r, 13), e8}, row);
      cv::resize(row, row, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
      cv::imwrite(
          std::string(dump) + "/" + name + "_" + std::string(formatSegmentationMethod(m)) + ".png",
          row);
    }
    std::map<int, int> ov, rsize;
    int table = 0;
    for (int v = 0; v < r.rows; ++v)
      for (int u = 0; u < r.cols; ++u) {
        const int id = r.at<std::uint16_t>(v, u);
        if (id) ++rsize[id];
        const int l = labels.at<std::uint16_t>(v, u);
        if (l < 1 || l > 9 || depth.at<std::uint16_t>(v, u) == 0) continue;
        ++table;
        ++ov[id];
      }
    std::printf("[mosd diag] %s %s table %d px z %.0f..%.0f:", name,
                std::string(formatSegmentationMethod(m)).c_str(), table, zmin, zmax);
    for (auto [id, c] : ov)
      if (c > table / 200)
        std::printf(" r%d %.3f(of %d)", id, double(c) / table, id ? rsize[id] : 0);
    {
      std::map<int, std::map<int, int>>
          comp;  // region -> label class (0 none, 1 table, 2 object) -> px
      for (int v = 0; v < r.rows; ++v)
        for (int u = 0; u < r.cols; ++u) {
          const int id = r.at<std::uint16_t>(v, u);
          const int l = labels.at<std::uint16_t>(v, u);
          if (id) ++comp[id][l == 0 ? 0 : (l <= 9 ? 1 : 2)];
        }
      std::printf("\n   composition (none/table/object):");
      for (auto& [id, c] : comp)
        if (rsize[id] > 10000) std::printf(" r%d %d/%d/%d", id, c[0], c[1], c[2]);
    }
    std::printf("\n");
  }
}

}  // namespace
}  // namespace shapesense

namespace shapesense {
namespace {
TEST(SegmentationSyntheticDiag, DISABLED_EdgeCompare) {
  synthetic::SceneParams p;
  p.seed = 1;
  p.render_colour = false;
  const synthetic::SyntheticScene scene(p);
  const synthetic::RenderedFrame f = scene.render(0, 0);
  const cv::Mat en =
      segmentationEdgeStrength(f.frame.depth, f.frame.intrinsics, SegmentationMethod::kNormalEdges);
  const cv::Mat ef =
      segmentationEdgeStrength(f.frame.depth, f.frame.intrinsics, SegmentationMethod::kFused);
  const cv::Mat ed =
      segmentationEdgeStrength(f.frame.depth, f.frame.intrinsics, SegmentationMethod::kDepthStep);
  std::printf("zero: normal %d fused %d depth %d; normal>0&fused==0: %d\n",
              cv::countNonZero(en == 0), cv::countNonZero(ef == 0), cv::countNonZero(ed == 0),
              cv::countNonZero((en > 0) & (ef == 0)));
  cv::Mat row;
  cv::hconcat(std::vector<cv::Mat>{en * 10, ef * 10, ed * 10}, row);
  if (const char* dump = std::getenv("SEG_DIAG_DUMP"))
    cv::imwrite(std::string(dump) + "/edges.png", row);
}
}  // namespace
}  // namespace shapesense

namespace shapesense {
namespace {
// A fixed amount of segmentation work for profiling (perf stat / perf record): SEG_PROFILE_REPS
// runs (default 200) of SEG_DIAG_METHOD (default depth_step) on synthetic seed 1, frame 0.
TEST(SegmentationSyntheticDiag, DISABLED_ProfileLoop) {
  synthetic::SceneParams p;
  p.seed = 1;
  p.render_colour = false;
  const synthetic::SyntheticScene scene(p);
  const synthetic::RenderedFrame f = scene.render(0, 0);
  const char* env = std::getenv("SEG_DIAG_METHOD");
  const SegmentationMethod m =
      parseSegmentationMethod(env ? env : "depth_step").value_or(SegmentationMethod::kDepthStep);
  const int reps =
      std::getenv("SEG_PROFILE_REPS") ? std::atoi(std::getenv("SEG_PROFILE_REPS")) : 200;
  int regions = 0;
  std::vector<double> ms;
  for (int i = 0; i < reps; ++i) {
    timespec a{}, b{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
    const cv::Mat r = segmentDepth(f.frame.depth, f.frame.intrinsics, m);
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
    ms.push_back((b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) * 1e-6);
    double mx;
    cv::minMaxLoc(r, nullptr, &mx);
    regions += static_cast<int>(mx);
  }
  std::sort(ms.begin(), ms.end());
  std::printf("[profile] %s %d runs, %d regions per run, thread-CPU median %.2f ms min %.2f ms\n",
              std::string(formatSegmentationMethod(m)).c_str(), reps, regions / std::max(reps, 1),
              ms.empty() ? 0.0 : ms[ms.size() / 2], ms.empty() ? 0.0 : ms.front());
}
}  // namespace
}  // namespace shapesense

namespace shapesense {
namespace {
// Parameter sweep helper: mean pixel accuracy / correct fraction of SEG_DIAG_METHOD over seeds 1-6
// and the worst mosd_tabletop table coverage, with plane-prediction parameters from the env
// (SEG_PP_{RADIUS,STEPS,SMOOTH,GRAD,LONG,LSTEPS,FALLBACK}) and
// depth-step parameters (SEG_DS_{STEPS,SLOPE,MIN,RADIUS,MINPX,DOWNSAMPLE}).
TEST(SegmentationSyntheticDiag, DISABLED_Sweep) {
  const char* env = std::getenv("SEG_DIAG_METHOD");
  const SegmentationMethod m = parseSegmentationMethod(env ? env : "plane_prediction")
                                   .value_or(SegmentationMethod::kPlanePrediction);
  SegmentationParams sp;
  auto& pp = sp.plane_prediction;
  if (const char* e = std::getenv("SEG_PP_RADIUS")) pp.window_radius = std::atoi(e);
  if (const char* e = std::getenv("SEG_PP_LONG")) pp.long_range = std::atoi(e);
  if (const char* e = std::getenv("SEG_PP_LSTEPS")) pp.long_noise_steps = std::atof(e);
  if (const char* e = std::getenv("SEG_PP_FALLBACK"))
    pp.curved_fallback_markers = std::atoi(e) != 0;
  auto& ds = sp.depth_step;
  if (const char* e = std::getenv("SEG_DS_STEPS")) ds.noise_steps = std::atof(e);
  if (const char* e = std::getenv("SEG_DS_SLOPE")) ds.slope_factor = std::atof(e);
  if (const char* e = std::getenv("SEG_DS_MIN")) ds.min_threshold_mm = std::atof(e);
  if (const char* e = std::getenv("SEG_DS_RADIUS")) ds.window_radius = std::atoi(e);
  if (const char* e = std::getenv("SEG_DS_MINPX")) ds.region.min_marker_px = std::atoi(e);
  if (const char* e = std::getenv("SEG_DS_DOWNSAMPLE")) ds.region.downsample = std::atoi(e);
  if (const char* e = std::getenv("SEG_PP_STEPS")) pp.noise_steps = std::atof(e);
  if (const char* e = std::getenv("SEG_PP_SMOOTH")) pp.smoothing_radius = std::atoi(e);
  if (const char* e = std::getenv("SEG_PP_GRAD")) pp.gradient_step = std::atoi(e);
  double acc = 0, cor = 0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    synthetic::SceneParams p;
    p.seed = seed;
    p.render_colour = false;
    const synthetic::SyntheticScene scene(p);
    const synthetic::RenderedFrame f = scene.render(0, 0);
    const SegCompScore s = scoreSegmentation(segmentDepth(f.frame.depth, f.frame.intrinsics, m, sp),
                                             f.truth.surface_labels);
    std::printf(" %.3f", s.pixel_accuracy);
    acc += s.pixel_accuracy / 6;
    cor += s.correct_fraction / 6;
  }
  const std::string dir = std::string(SHAPESENSE_SHARED_DIR) + "/data/real/mosd_tabletop";
  double worst = 1.0;
  for (const char* name : {"1600000000.000000", "1600000000.033333", "1600000000.066667",
                           "1600000000.100000", "1600000000.133333", "1600000000.166667"}) {
    const cv::Mat raw = cv::imread(dir + "/depth/" + name + ".png", cv::IMREAD_UNCHANGED);
    const cv::Mat labels = cv::imread(dir + "/labels/" + name + ".png", cv::IMREAD_UNCHANGED);
    if (raw.empty() || labels.empty()) continue;
    cv::Mat depth;
    raw.convertTo(depth, CV_16UC1, 0.2);
    const cv::Mat r = segmentDepth(depth, CameraIntrinsics{}, m, sp);
    worst = std::min(worst, testing::mosdTableCoverage(r, labels, depth));
  }
  std::printf("\n[sweep] %s acc %.3f correct %.3f mosd worst table %.3f\n",
              std::string(formatSegmentationMethod(m)).c_str(), acc, cor, worst);
}
}  // namespace
}  // namespace shapesense
