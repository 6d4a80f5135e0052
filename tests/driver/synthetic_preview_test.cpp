// Not a test: writes preview images of a few scenes for eyeballing. Run with
//   driver_tests --gtest_also_run_disabled_tests --gtest_filter='SyntheticPreview*'
// Output: <build>/test-scratch/synthetic_preview/seed<k>_{rgb,depth,surfaces}.png and
// mosaic.png (one row per seed, half size).

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "shapesense/driver/synthetic_scene.h"
#include "test_paths.h"

namespace shapesense::synthetic {
namespace {

cv::Mat falseColour(const cv::Mat& labels) {
  cv::Mat out(labels.size(), CV_8UC3, cv::Scalar::all(0));
  for (int v = 0; v < labels.rows; ++v)
    for (int u = 0; u < labels.cols; ++u) {
      const unsigned id = labels.at<std::uint16_t>(v, u);
      if (id == 0) continue;
      const unsigned h = id * 2654435761u;
      out.at<cv::Vec3b>(v, u) =
          cv::Vec3b(64 + (h & 0xBF), 64 + ((h >> 8) & 0xBF), 64 + ((h >> 16) & 0xBF));
    }
  return out;
}

TEST(SyntheticPreview, DISABLED_WritesPreviewImages) {
  const auto dir = testing::scratchDir("synthetic_preview");
  std::vector<cv::Mat> rows;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    SceneParams params;
    params.seed = seed;
    const RenderedFrame f = SyntheticScene(params).render(0, 0);
    const std::string base = (dir / ("seed" + std::to_string(seed))).string();
    cv::imwrite(base + "_rgb.png", f.frame.rgb);
    cv::Mat depth8;
    f.frame.depth.convertTo(depth8, CV_8U, 255.0 / 4500.0);
    cv::applyColorMap(depth8, depth8, cv::COLORMAP_JET);
    depth8.setTo(cv::Scalar::all(0), f.frame.depth == 0);
    cv::imwrite(base + "_depth.png", depth8);
    const cv::Mat surfaces = falseColour(f.truth.surface_labels);
    cv::imwrite(base + "_surfaces.png", surfaces);
    cv::Mat row;
    cv::hconcat(std::vector<cv::Mat>{f.frame.rgb, depth8, surfaces}, row);
    cv::resize(row, row, {}, 0.5, 0.5, cv::INTER_AREA);
    rows.push_back(row);
  }
  cv::Mat mosaic;
  cv::vconcat(rows, mosaic);
  cv::imwrite((dir / "mosaic.png").string(), mosaic);
}

}  // namespace
}  // namespace shapesense::synthetic
