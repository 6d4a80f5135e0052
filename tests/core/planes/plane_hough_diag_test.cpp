// Diagnostics of the Hough plane detector on the 30 frames of bench/planes_bench.cpp (DISABLED_:
// prints, asserts nothing; run with --gtest_also_run_disabled_tests). Per missed truth plane: its
// name and size, and the found regions that overlap it (fraction of the truth region, fraction
// of the found region on planar truth), which tells split (several partial overlaps), merged
// (one found region much larger than the truth) and missed (no overlap) apart.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "plane_scoring.h"
#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense {
namespace {

// Parameter overrides for experiments: PLANE_DIAG_TOL_FACTOR, PLANE_DIAG_MIN_TOL_STEPS.
HoughPlaneParams diagParams() {
  HoughPlaneParams p;
  if (const char* e = std::getenv("PLANE_DIAG_TOL_FACTOR"))
    p.labeling.adaptive_tolerance_factor = std::atof(e);
  if (const char* e = std::getenv("PLANE_DIAG_MIN_TOL_STEPS"))
    p.labeling.min_tolerance_steps = std::atof(e);
  return p;
}

TEST(PlaneHoughDiag, DISABLED_MissedTruthPlanes) {
  HoughPlaneDetector det(diagParams());
  planetest::PlaneScore total;
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    const auto f = synthetic::SyntheticScene(sp).render(0, 0);
    const auto out = det.detect(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
    const auto s = planetest::scorePlanes(out.labels, out.planes, f.truth);
    total.add(s);
    const cv::Mat t = planetest::planarTruth(f.truth);
    std::map<int, long> tsize, fsize;
    std::map<std::pair<int, int>, long> ov;
    for (int v = 0; v < t.rows; ++v)
      for (int u = 0; u < t.cols; ++u) {
        const int tl = t.at<std::uint16_t>(v, u), fl = out.labels.at<std::uint16_t>(v, u);
        if (!tl) continue;
        ++tsize[tl];
        if (fl) ++fsize[fl];
        ++ov[{tl, fl}];
      }
    std::map<int, bool> correct;
    for (const auto& [tid, fid] : s.matches) correct[tid] = true;
    const double min_px = 0.005 * t.total();
    for (const auto& ts : f.truth.surfaces) {
      if (ts.kind != synthetic::SurfaceKind::kPlane || tsize[ts.id] < min_px || correct[ts.id])
        continue;
      std::printf("seed %2llu MISS %-18s %5.2f%% of image:", static_cast<unsigned long long>(seed),
                  ts.name.c_str(), 100.0 * tsize[ts.id] / t.total());
      for (const auto& [key, o] : ov) {
        if (key.first != ts.id || o < 0.05 * tsize[ts.id]) continue;
        if (key.second == 0) {
          std::printf(" [unlabelled %.2f]", double(o) / tsize[ts.id]);
          continue;
        }
        // Which truth plane does this found region mostly cover?
        int main_t = 0;
        long main_o = 0;
        for (const auto& [k2, o2] : ov)
          if (k2.second == key.second && o2 > main_o) main_o = o2, main_t = k2.first;
        const auto& fp = out.planes[key.second - 1];
        std::printf(
            " [found %d (group %d, n %.2f %.2f %.2f, d %.3f): %.2f of truth, %.2f of found, mostly "
            "%d]",
            key.second, fp.group, fp.normal.x(), fp.normal.y(), fp.normal.z(), fp.d,
            double(o) / tsize[ts.id], double(o) / fsize[key.second], main_t == ts.id ? 0 : main_t);
      }
      std::printf("\n");
    }
  }
  std::printf("correct %.3f (%d/%d)\n", total.correctFraction(), total.correct,
              total.truth_regions);
}

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

// Median per-frame thread CPU time of the default detector against one with the accuracy steps
// of this session switched off (same frames, interleaved, so machine load hits both alike).
TEST(PlaneHoughDiag, DISABLED_CostOfAccuracySteps) {
  std::vector<synthetic::RenderedFrame> frames;
  for (std::uint64_t seed = 1; seed <= 30; ++seed) {
    synthetic::SceneParams sp;
    sp.seed = seed;
    frames.push_back(synthetic::SyntheticScene(sp).render(0, 0));
  }
  HoughPlaneParams off;
  off.leftover_ransac_hypotheses = 0;
  off.labeling.adaptive_tolerance_factor = 0.0;
  off.labeling.merge_coplanar_regions = false;
  off.labeling.grow_max_unreliable_normal_deg = 180.0;
  HoughPlaneDetector a, b(off);
  std::vector<double> ta, tb;
  for (int rep = 0; rep < 3; ++rep)
    for (const auto& f : frames) {
      double t0 = threadCpuMs();
      a.detect(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
      ta.push_back(threadCpuMs() - t0);
      t0 = threadCpuMs();
      b.detect(f.frame.depth, f.frame.intrinsics, f.frame.rgb);
      tb.push_back(threadCpuMs() - t0);
    }
  std::printf("median CPU ms/frame: default %.2f, accuracy steps off %.2f\n", planetest::median(ta),
              planetest::median(tb));
}

}  // namespace
}  // namespace shapesense
