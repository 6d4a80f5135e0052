// TEMPORARY diagnostics (to be deleted).
#include <algorithm>
#include <cstdint>
#include <iostream>
#include <variant>
#include <vector>
#include <gtest/gtest.h>
#include "shapesense/core/box_estimation.h"
#include "shapesense/driver/synthetic_scene.h"
namespace shapesense {
namespace {
TEST(BoxDiag, Dump) {
  const char* env = std::getenv("BOXDIAG");
  if (!env) GTEST_SKIP();
  BoxEstimationParams bp;
  if (const char* e = std::getenv("BOX_K")) bp.std_scale = std::atof(e);
  if (const char* e = std::getenv("BOX_C")) bp.inlier_sigmas = std::atof(e);
  for (int s = 1; s <= 10; ++s) {
    synthetic::SceneParams params; params.seed = s; params.render_colour = false;
    const synthetic::SyntheticScene scene(params);
    const auto rendered = scene.render(0, 0);
    const cv::Mat& depth = rendered.frame.depth;
    const auto& k = rendered.frame.intrinsics;
    const cv::Mat& labels = rendered.truth.object_labels;
    for (const auto& o : rendered.truth.objects) {
      if (o.kind == "table" || o.image_box.empty() || o.pixel_count < 200) continue;
      const cv::Rect r = o.image_box;
      std::vector<Eigen::Vector3d> pts; std::vector<double> zs; int roi_valid = 0;
      for (int v = r.y; v < r.y + r.height; ++v) for (int u = r.x; u < r.x + r.width; ++u) {
        auto d = depth.at<std::uint16_t>(v, u); if (!d) continue; ++roi_valid;
        if (labels.at<std::uint16_t>(v, u) != o.id) continue;
        pts.push_back(k.backproject(u, v, d * 0.001)); zs.push_back(d * 0.001);
      }
      std::sort(zs.begin(), zs.end());
      auto res = estimateBox(depth, k, r.tl(), {r.x + r.width - 1, r.y + r.height - 1}, BoxMode::kAxisAlignedContained, bp);
      auto& b = std::get<BoxEstimate>(res);
      const auto& c = b.corners;
      int out_z = 0, out_x = 0, out_y = 0, in = 0;
      for (auto& p : pts) {
        bool oz = p.z() < c[0].z() || p.z() > c[4].z();
        bool ox = p.x() < c[0].x() || p.x() > c[1].x();
        bool oy = p.y() < c[0].y() || p.y() > c[3].y();
        out_z += oz; out_x += ox; out_y += oy; in += !(oz||ox||oy);
      }
      double n = pts.size();
      printf("s%d %-6s px=%5zu obj/roi=%.2f u=[%3d,%3d] v=[%3d,%3d] z=[%.3f %.3f] p2-98=[%.3f %.3f] est=[%.3f %.3f] med=%.3f used/valid=%d/%d in=%.2f outz=%.2f outx=%.2f outy=%.2f vol=%.2f\n",
        s, o.kind.c_str(), o.pixel_count, n / roi_valid, r.x, r.x + r.width - 1, r.y, r.y + r.height - 1,
        zs.front(), zs.back(), zs[zs.size()*2/100], zs[zs.size()*98/100], b.stats.near_m, b.stats.far_m, b.stats.median_m,
        b.stats.used_pixels, b.stats.valid_pixels, in / n, out_z / n, out_x / n, out_y / n, boxVolume(c) / o.size.prod());
    }
  }
}
}  // namespace
}  // namespace shapesense
