// shapesense-plane-diag: why the Hough plane detector misses truth planes, on the 30 synthetic
// frames of bench/planes_bench.cpp (frame 0 of the scenes with seeds 1..30). For each missed
// truth plane it prints its name and size and the found regions that overlap it (fraction of
// the truth region, fraction of the found region on planar truth), which tells split (several
// partial overlaps), merged (one found region much larger than the truth) and missed (no
// overlap) apart; then the correct-detection fraction.
//
//   shapesense-plane-diag [--tolerance-factor F] [--min-tolerance-steps S] [--seeds N]

#include <CLI/CLI.hpp>
#include <cstdint>
#include <cstdio>
#include <map>
#include <optional>
#include <utility>

#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"
#include "shapesense/eval/plane_eval.h"

using namespace shapesense;

namespace {

// Pixel counts of truth regions, found regions and each (truth, found) overlap of one frame.
struct Overlaps {
  std::map<int, long> truth_size, found_size;
  std::map<std::pair<int, int>, long> overlap;
};

Overlaps overlapsOf(const cv::Mat& planar_truth, const cv::Mat& labels) {
  Overlaps o;
  for (int v = 0; v < planar_truth.rows; ++v)
    for (int u = 0; u < planar_truth.cols; ++u) {
      const int tl = planar_truth.at<std::uint16_t>(v, u), fl = labels.at<std::uint16_t>(v, u);
      if (!tl) continue;
      ++o.truth_size[tl];
      if (fl) ++o.found_size[fl];
      ++o.overlap[{tl, fl}];
    }
  return o;
}

// The found regions covering >= 5% of truth plane `id`, and what each of them mostly covers.
void printOverlapsOf(int id, const Overlaps& o, const PlaneDetection& out) {
  const long size = o.truth_size.at(id);
  for (const auto& [key, px] : o.overlap) {
    if (key.first != id || px < 0.05 * size) continue;
    if (key.second == 0) {
      std::printf(" [unlabelled %.2f]", double(px) / size);
      continue;
    }
    int main_truth = 0;
    long main_px = 0;
    for (const auto& [k2, px2] : o.overlap)
      if (k2.second == key.second && px2 > main_px) main_px = px2, main_truth = k2.first;
    const DetectedPlane& fp = out.planes[key.second - 1];
    std::printf(
        " [found %d (group %d, n %.2f %.2f %.2f, d %.3f): %.2f of truth, %.2f of found, mostly "
        "%d]",
        key.second, fp.group, fp.normal.x(), fp.normal.y(), fp.normal.z(), fp.d, double(px) / size,
        double(px) / o.found_size.at(key.second), main_truth == id ? 0 : main_truth);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Missed truth planes of the Hough plane detector on synthetic frames"};
  std::optional<double> tolerance_factor, min_tolerance_steps;
  int seeds = 30;
  app.add_option("--tolerance-factor", tolerance_factor,
                 "PlaneLabelingParams::adaptive_tolerance_factor");
  app.add_option("--min-tolerance-steps", min_tolerance_steps,
                 "PlaneLabelingParams::min_tolerance_steps");
  app.add_option("--seeds", seeds, "scenes with seeds 1..N")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  HoughPlaneParams params;
  if (tolerance_factor) params.labeling.adaptive_tolerance_factor = *tolerance_factor;
  if (min_tolerance_steps) params.labeling.min_tolerance_steps = *min_tolerance_steps;
  HoughPlaneDetector det(params);
  eval::PlaneScore total;
  for (std::uint64_t seed = 1; seed <= static_cast<std::uint64_t>(seeds); ++seed) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    const auto f = synthetic::SyntheticScene(sp).render(0, 0);
    const auto out = det.detect(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
    const auto score = eval::scorePlanes(out.labels, out.planes, f.truth);
    total.add(score);
    const cv::Mat truth = eval::planarTruth(f.truth);
    const Overlaps o = overlapsOf(truth, out.labels);
    std::map<int, bool> correct;
    for (const auto& [tid, fid] : score.matches) correct[tid] = true;
    const double min_px = 0.005 * truth.total();
    for (const auto& ts : f.truth.surfaces) {
      const auto size = o.truth_size.find(ts.id);
      if (ts.kind != synthetic::SurfaceKind::kPlane || size == o.truth_size.end() ||
          size->second < min_px || correct[ts.id])
        continue;
      std::printf("seed %2llu MISS %-18s %5.2f%% of image:", static_cast<unsigned long long>(seed),
                  ts.name.c_str(), 100.0 * size->second / truth.total());
      printOverlapsOf(ts.id, o, out);
      std::printf("\n");
    }
  }
  std::printf("correct %.3f (%d/%d)\n", total.correctFraction(), total.correct,
              total.truth_regions);
  return 0;
}
