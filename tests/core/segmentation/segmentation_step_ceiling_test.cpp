// Why depth-step segmentation cannot reach the issue's pixel accuracy of 0.9 on the synthetic
// scenes: most truth surfaces meet a neighbour at a crease (wall/wall, wall/floor, table top/table
// edge, box face/table top, leg/floor), where the depth is continuous. A criterion that only sees
// depth steps must give such surfaces one region, and pixel accuracy (each found region scores
// its best truth surface) then loses every pixel of the smaller ones.
//
// The ceiling below merges two truth surfaces when they touch along at least kMinContact pairs of
// 4-adjacent measured pixels whose noise-free depths differ by less than the default depth-step
// threshold at the smallest offset a 2x-downsampled window compares (2 full-resolution pixels).
// kMinContact = 150 pixel pairs is far longer than the few-pixel corridor a watershed needs to
// join two markers, so the bound is generous to the method (short contacts are not merged).
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "shapesense/core/segmentation/segmentation.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

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

TEST(SegmentationStepCeiling, CreasesBoundDepthStepBelowIssueTarget) {
  double ceiling = 0, reached = 0;
  int frames = 0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    sp.render_colour = false;
    const synthetic::SyntheticScene scene(sp);
    const synthetic::RenderedFrame f = scene.render(0, 0);
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
  ceiling /= frames;
  reached /= frames;
  std::printf("[step ceiling] mean ceiling %.3f, depth_step %.3f, issue target 0.9\n", ceiling,
              reached);
  // The bound itself: creases alone cost more than the 10% the issue's target allows.
  EXPECT_LT(ceiling, 0.9);
  // And depth_step is not far from it (it also loses short contacts the bound leaves apart, and
  // sometimes wins where grazing-angle dropouts cut a crease); measured ceiling 0.77, reached 0.67.
  EXPECT_GE(reached, ceiling - 0.15);
}

}  // namespace
}  // namespace shapesense
