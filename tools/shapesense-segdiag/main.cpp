// shapesense-segdiag: diagnostics of the segmentation methods against the synthetic per-surface
// truth and the mosd_tabletop table. Experiments, not tests: they print, they assert nothing.
//
//   shapesense-segdiag loss    [--method M] [--verbose] [--pairs N] [--param NAME=VALUE ...]
//       where each method loses pixel accuracy on synthetic seeds 1-6 (unassigned or merged
//       away), at the defaults, at full resolution and without the coplanar merge, and the
//       accuracy a step-only edge detector could reach at best (--pairs: oracle contact length)
//   shapesense-segdiag ceiling
//       why depth-step segmentation cannot reach pixel accuracy 0.9: the creases it cannot see
//   shapesense-segdiag mosd    --mosd DIR [--method M] [--dump DIR] [--param NAME=VALUE ...]
//       which regions cover the mosd_tabletop table, per frame
//   shapesense-segdiag edges   [--dump DIR]
//       the normal, fused and depth-step edge images of synthetic seed 1
//   shapesense-segdiag sweep   --mosd DIR [--method M] [--param NAME=VALUE ...]
//       mean accuracy over seeds 1-6 and the worst mosd table coverage of one parameter set
//
// --param names: fused.angle, fused.window, fused.smoothing, pp.radius, pp.steps, pp.smoothing,
// pp.gradient, pp.long, pp.long_steps, pp.fallback, ds.steps, ds.slope, ds.min_mm, ds.radius,
// ds.min_marker_px, ds.downsample, rms (coplanar_rms_steps of every method).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

using namespace shapesense;

namespace {

synthetic::RenderedFrame syntheticFrame(std::uint64_t seed) {
  synthetic::SceneParams p;
  p.seed = seed;
  p.render_colour = false;
  return synthetic::SyntheticScene(p).render(0, 0);
}

std::vector<RegionParams*> allRegions(SegmentationParams& sp) {
  return {&sp.depth_step.region, &sp.normal_edges.region, &sp.fused.region,
          &sp.plane_prediction.region, &sp.tiled_ransac.region};
}

// Sets one parameter from "NAME=VALUE" (names in the file comment).
void setParam(SegmentationParams& sp, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) throw std::invalid_argument("--param wants NAME=VALUE");
  const std::string name = assignment.substr(0, eq);
  const double x = std::stod(assignment.substr(eq + 1));
  const int i = static_cast<int>(x);
  auto& pp = sp.plane_prediction;
  auto& ds = sp.depth_step;
  const std::map<std::string, std::function<void()>> setters = {
      {"fused.angle", [&] { sp.fused.normal.max_angle_deg = x; }},
      {"fused.window", [&] { sp.fused.normal.window_radius = i; }},
      {"fused.smoothing", [&] { sp.fused.normal.normals.smoothing_radius_px = x; }},
      {"pp.radius", [&] { pp.window_radius = i; }},
      {"pp.steps", [&] { pp.noise_steps = x; }},
      {"pp.smoothing", [&] { pp.smoothing_radius = i; }},
      {"pp.gradient", [&] { pp.gradient_step = i; }},
      {"pp.long", [&] { pp.long_range = i; }},
      {"pp.long_steps", [&] { pp.long_noise_steps = x; }},
      {"pp.fallback", [&] { pp.curved_fallback_markers = i != 0; }},
      {"ds.steps", [&] { ds.noise_steps = x; }},
      {"ds.slope", [&] { ds.slope_factor = x; }},
      {"ds.min_mm", [&] { ds.min_threshold_mm = x; }},
      {"ds.radius", [&] { ds.window_radius = i; }},
      {"ds.min_marker_px", [&] { ds.region.min_marker_px = i; }},
      {"ds.downsample", [&] { ds.region.downsample = i; }},
      {"rms", [&] {
         for (RegionParams* r : allRegions(sp)) r->coplanar_rms_steps = x;
       }}};
  const auto it = setters.find(name);
  if (it == setters.end()) throw std::invalid_argument("unknown --param " + name);
  it->second();
}

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
double stepOracleAccuracy(const synthetic::RenderedFrame& f, int min_pairs) {
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

void printLoss(SegmentationMethod m, const SegmentationParams& base, bool verbose, int pairs) {
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    const synthetic::RenderedFrame f = syntheticFrame(seed);
    std::printf("[diag] seed %llu step-only oracle accuracy %.3f\n",
                static_cast<unsigned long long>(seed), stepOracleAccuracy(f, pairs));
    struct Variant {
      const char* name;
      SegmentationParams sp;
    };
    SegmentationParams full = base;
    for (RegionParams* r : allRegions(full)) r->downsample = 1;
    SegmentationParams nomerge = base;
    for (RegionParams* r : allRegions(nomerge)) r->merge_coplanar = false;
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

constexpr int kMinContact = 150;

struct Ceiling {
  double accuracy = 0;     // best pixel accuracy of any partition that merges crease contacts
  double crease_lost = 0;  // fraction of labelled pixels that partition must lose
};

Ceiling stepOnlyCeiling(const synthetic::RenderedFrame& f, bool print) {
  const cv::Mat& t = f.truth.surface_labels;
  const cv::Mat& z = f.truth.ideal_depth;  // metres, noise-free
  const DepthStepParams p;
  const KinectNoiseModel noise;
  // DepthStepParams' threshold (mm) for an offset of `px` full-resolution pixels at range z_mm.
  auto threshold = [&](double z_mm, double px) {
    const double step = noise.depthStep(z_mm * 1e-3) * 1e3;
    return std::max(p.min_threshold_mm, p.noise_steps * step + p.slope_factor * px * z_mm);
  };
  std::map<std::pair<int, int>, int> contact;
  std::map<int, long> size;
  long total = 0;
  for (int v = 0; v < t.rows; ++v)
    for (int u = 0; u < t.cols; ++u) {
      const int a = t.at<std::uint16_t>(v, u);
      if (!a) continue;
      ++size[a];
      ++total;
      for (auto [du, dv] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (u + du >= t.cols || v + dv >= t.rows) continue;
        const int b = t.at<std::uint16_t>(v + dv, u + du);
        if (!b || b == a) continue;
        const double za = 1e3 * z.at<float>(v, u), zb = 1e3 * z.at<float>(v + dv, u + du);
        if (std::fabs(za - zb) <= threshold(std::min(za, zb), 2.0))
          ++contact[{std::min(a, b), std::max(a, b)}];
      }
    }
  std::map<int, int> parent;
  for (const auto& [l, n] : size) parent[l] = l;
  std::function<int(int)> root = [&](int x) {
    return parent[x] == x ? x : parent[x] = root(parent[x]);
  };
  auto name = [&](int id) {
    for (const auto& s : f.truth.surfaces)
      if (s.id == id) return s.name;
    return std::string("?");
  };
  for (const auto& [k, n] : contact) {
    if (n < kMinContact) continue;
    parent[root(k.first)] = root(k.second);
    if (print)
      std::printf("   crease %-24s / %-24s %5d px pairs\n", name(k.first).c_str(),
                  name(k.second).c_str(), n);
  }
  std::map<int, long> best;
  for (const auto& [l, n] : size) best[root(l)] = std::max(best[root(l)], n);
  long good = 0;
  for (const auto& [r, n] : best) good += n;
  Ceiling c;
  c.accuracy = static_cast<double>(good) / static_cast<double>(total);
  c.crease_lost = 1.0 - c.accuracy;
  return c;
}

void printCeiling() {
  double ceiling = 0, reached = 0;
  int frames = 0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    const synthetic::RenderedFrame f = syntheticFrame(seed);
    std::printf("[step ceiling] seed %llu, truth surfaces touching without a depth step:\n",
                static_cast<unsigned long long>(seed));
    const Ceiling c = stepOnlyCeiling(f, true);
    const cv::Mat r =
        segmentDepth(f.frame.depth, f.frame.intrinsics, SegmentationMethod::kDepthStep);
    const double acc = scoreSegmentation(r, f.truth.surface_labels).pixel_accuracy;
    std::printf(
        "[step ceiling] seed %llu ceiling %.3f (crease-merged pixels %.3f)  depth_step reaches "
        "%.3f\n",
        static_cast<unsigned long long>(seed), c.accuracy, c.crease_lost, acc);
    ceiling += c.accuracy;
    reached += acc;
    ++frames;
  }
  std::printf("[step ceiling] mean ceiling %.3f, depth_step %.3f, issue target 0.9\n",
              ceiling / frames, reached / frames);
}

const char* const kMosdFrames[] = {"1600000000.000000", "1600000000.033333", "1600000000.066667",
                                   "1600000000.100000", "1600000000.133333", "1600000000.166667"};

// A mosd_tabletop frame: depth (mm) and labels (table = 1-9). False when missing.
bool loadMosd(const std::string& dir, const char* name, cv::Mat& depth, cv::Mat& labels) {
  const cv::Mat raw = cv::imread(dir + "/depth/" + name + ".png", cv::IMREAD_UNCHANGED);
  labels = cv::imread(dir + "/labels/" + name + ".png", cv::IMREAD_UNCHANGED);
  if (raw.empty() || labels.empty()) return false;
  raw.convertTo(depth, CV_16UC1, 0.2);
  return true;
}

cv::Mat colourRegions(const cv::Mat& l, int mul) {
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
}

void dumpMosd(const std::string& dump, const char* name, SegmentationMethod m,
              const SegmentationParams& sp, const cv::Mat& depth, const cv::Mat& labels,
              const cv::Mat& r) {
  cv::Mat dv;
  depth.convertTo(dv, CV_8U, 255.0 / 1200, -500 * 255.0 / 1200);
  cv::cvtColor(dv, dv, cv::COLOR_GRAY2BGR);
  cv::Mat row;
  cv::Mat e = segmentationEdgeStrength(depth, CameraIntrinsics{}, m, sp), e8;
  cv::resize(e, e, depth.size(), 0, 0, cv::INTER_NEAREST);
  e.convertTo(e8, CV_8U, 20);
  cv::cvtColor(e8, e8, cv::COLOR_GRAY2BGR);
  cv::hconcat(std::vector<cv::Mat>{dv, colourRegions(labels, 7), colourRegions(r, 13), e8}, row);
  cv::resize(row, row, cv::Size(), 0.5, 0.5, cv::INTER_NEAREST);
  cv::imwrite(dump + "/" + name + "_" + std::string(formatSegmentationMethod(m)) + ".png", row);
}

// Table pixels with depth per region (0 = unassigned), and their total.
std::map<int, int> tableOverlap(const cv::Mat& r, const cv::Mat& labels, const cv::Mat& depth,
                                int& table) {
  std::map<int, int> ov;
  table = 0;
  for (int v = 0; v < r.rows; ++v)
    for (int u = 0; u < r.cols; ++u) {
      const int l = labels.at<std::uint16_t>(v, u);
      if (l < 1 || l > 9 || depth.at<std::uint16_t>(v, u) == 0) continue;
      ++table;
      ++ov[r.at<std::uint16_t>(v, u)];
    }
  return ov;
}

void printMosd(const std::string& dir, SegmentationMethod m, const SegmentationParams& sp,
               const std::string& dump) {
  for (const char* name : kMosdFrames) {
    cv::Mat depth, labels;
    if (!loadMosd(dir, name, depth, labels)) continue;
    double zmin, zmax;
    cv::minMaxLoc(depth, &zmin, &zmax, nullptr, nullptr,
                  (labels >= 1) & (labels <= 9) & (depth > 0));
    const cv::Mat r = segmentDepth(depth, CameraIntrinsics{}, m, sp);
    if (!dump.empty()) dumpMosd(dump, name, m, sp, depth, labels, r);
    std::map<int, int> rsize;
    std::map<int, std::map<int, int>> comp;  // region -> class (0 none, 1 table, 2 object) -> px
    for (int v = 0; v < r.rows; ++v)
      for (int u = 0; u < r.cols; ++u) {
        const int id = r.at<std::uint16_t>(v, u);
        const int l = labels.at<std::uint16_t>(v, u);
        if (!id) continue;
        ++rsize[id];
        ++comp[id][l == 0 ? 0 : (l <= 9 ? 1 : 2)];
      }
    int table = 0;
    const std::map<int, int> ov = tableOverlap(r, labels, depth, table);
    std::printf("[mosd diag] %s %s table %d px z %.0f..%.0f:", name,
                std::string(formatSegmentationMethod(m)).c_str(), table, zmin, zmax);
    for (auto [id, c] : ov)
      if (c > table / 200)
        std::printf(" r%d %.3f(of %d)", id, double(c) / table, id ? rsize[id] : 0);
    std::printf("\n   composition (none/table/object):");
    for (auto& [id, c] : comp)
      if (rsize[id] > 10000) std::printf(" r%d %d/%d/%d", id, c[0], c[1], c[2]);
    std::printf("\n");
  }
}

void printEdges(const std::string& dump) {
  const synthetic::RenderedFrame f = syntheticFrame(1);
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
  if (!dump.empty()) cv::imwrite(dump + "/edges.png", row);
}

void printSweep(const std::string& dir, SegmentationMethod m, const SegmentationParams& sp) {
  double acc = 0, cor = 0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    const synthetic::RenderedFrame f = syntheticFrame(seed);
    const SegCompScore s = scoreSegmentation(segmentDepth(f.frame.depth, f.frame.intrinsics, m, sp),
                                             f.truth.surface_labels);
    std::printf(" %.3f", s.pixel_accuracy);
    acc += s.pixel_accuracy / 6;
    cor += s.correct_fraction / 6;
  }
  double worst = 1.0;
  for (const char* name : kMosdFrames) {
    cv::Mat depth, labels;
    if (!loadMosd(dir, name, depth, labels)) continue;
    int table = 0;
    const auto ov =
        tableOverlap(segmentDepth(depth, CameraIntrinsics{}, m, sp), labels, depth, table);
    int best = 0;
    for (auto [id, c] : ov)
      if (id) best = std::max(best, c);
    worst = std::min(worst, table ? static_cast<double>(best) / table : 0.0);
  }
  std::printf("\n[sweep] %s acc %.3f correct %.3f mosd worst table %.3f\n",
              std::string(formatSegmentationMethod(m)).c_str(), acc, cor, worst);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Segmentation diagnostics on synthetic scenes and mosd_tabletop"};
  app.require_subcommand(1);
  std::string method_name, dump, mosd = "../shared/data/real/mosd_tabletop";
  std::vector<std::string> params;
  bool verbose = false;
  int pairs = 10;
  auto method_option = [&](CLI::App* cmd, const std::string& default_method) {
    method_name = default_method;
    cmd->add_option("--method", method_name, "Segmentation method: " + listSegmentationMethods())
        ->capture_default_str();
    cmd->add_option("--param", params, "NAME=VALUE (see the source's comment)");
  };
  auto* loss = app.add_subcommand("loss", "Where a method loses pixel accuracy (synthetic)");
  method_option(loss, "depth_step");
  loss->add_flag("--verbose", verbose, "Per truth surface");
  loss->add_option("--pairs", pairs, "Oracle contact length (pixel pairs)")->capture_default_str();
  app.add_subcommand("ceiling", "What bounds a depth-step-only method (synthetic)");
  auto* mosd_cmd = app.add_subcommand("mosd", "Which regions cover the mosd_tabletop table");
  method_option(mosd_cmd, "plane_prediction");
  mosd_cmd->add_option("--mosd", mosd, "mosd_tabletop recording")->capture_default_str();
  mosd_cmd->add_option("--dump", dump, "Write colour images of regions and edges here");
  auto* edges = app.add_subcommand("edges", "Edge images of synthetic seed 1");
  edges->add_option("--dump", dump, "Write the edge images here");
  auto* sweep = app.add_subcommand("sweep", "Accuracy and mosd coverage of one parameter set");
  method_option(sweep, "plane_prediction");
  sweep->add_option("--mosd", mosd, "mosd_tabletop recording")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  SegmentationParams sp;
  for (const std::string& p : params) setParam(sp, p);
  const auto method = parseSegmentationMethod(method_name);
  if (!method) {
    std::fprintf(stderr, "unknown method %s\n", method_name.c_str());
    return 2;
  }
  if (loss->parsed()) printLoss(*method, sp, verbose, pairs);
  if (app.got_subcommand("ceiling")) printCeiling();
  if (mosd_cmd->parsed()) printMosd(mosd, *method, sp, dump);
  if (edges->parsed()) printEdges(dump);
  if (sweep->parsed()) printSweep(mosd, *method, sp);
  return 0;
}
