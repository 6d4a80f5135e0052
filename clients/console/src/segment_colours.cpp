#include "shapesense/console/segment_colours.h"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace shapesense::console {
namespace {

/// A bright colour per id: the golden-angle walk round the hue circle keeps neighbouring ids
/// (often neighbouring regions) far apart in hue.
cv::Vec4b colourOf(std::uint16_t id) {
  const double hue = std::fmod(id * 137.508, 360.0);
  const double c = 0.85, x = c * (1 - std::abs(std::fmod(hue / 60.0, 2.0) - 1));
  double r = 0, g = 0, b = 0;
  if (hue < 60)
    r = c, g = x;
  else if (hue < 120)
    r = x, g = c;
  else if (hue < 180)
    g = c, b = x;
  else if (hue < 240)
    g = x, b = c;
  else if (hue < 300)
    r = x, b = c;
  else
    r = c, b = x;
  const auto byte = [](double v) { return static_cast<std::uint8_t>(40 + v * 215); };
  return {byte(b), byte(g), byte(r), 255};  // OpenCV writes BGRA
}

}  // namespace

std::string colourSegmentLabels(const std::string& labels_png) {
  const std::vector<std::uint8_t> bytes(labels_png.begin(), labels_png.end());
  const cv::Mat labels = bytes.empty() ? cv::Mat() : cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  if (labels.empty() || labels.channels() != 1) {
    throw std::invalid_argument("the segments' region image is not a single-channel PNG");
  }
  cv::Mat ids;
  labels.convertTo(ids, CV_16U);
  cv::Mat rgba(ids.size(), CV_8UC4, cv::Scalar(0, 0, 0, 0));
  for (int y = 0; y < ids.rows; ++y) {
    const auto* id = ids.ptr<std::uint16_t>(y);
    auto* out = rgba.ptr<cv::Vec4b>(y);
    for (int x = 0; x < ids.cols; ++x) {
      if (id[x] != 0) out[x] = colourOf(id[x]);
    }
  }
  std::vector<std::uint8_t> png;
  cv::imencode(".png", rgba, png);
  return std::string(png.begin(), png.end());
}

}  // namespace shapesense::console
