#include "overlay.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace shapesense::cli {
namespace {

cv::Mat decode(const std::string& bytes, int flags) {
  return cv::imdecode(std::vector<unsigned char>(bytes.begin(), bytes.end()), flags);
}

}  // namespace

cv::Mat colorizeDepth(const cv::Mat& depth_mm) {
  // 0.4-5 m spans the Kinect's range; beyond saturates.
  cv::Mat scaled;
  depth_mm.convertTo(scaled, CV_8U, 255.0 / 4600.0, -400.0 * 255.0 / 4600.0);
  cv::Mat bgr;
  cv::applyColorMap(scaled, bgr, cv::COLORMAP_TURBO);
  bgr.setTo(cv::Scalar::all(0), depth_mm == 0);
  return bgr;
}

FrameBackground fetchFrameBackground(Connection& connection, TimestampNs timestamp_ns) {
  v1::GetFrameRequest request;
  request.set_at_ns(timestamp_ns);
  v1::GetFrameResponse response;
  Connection::check(connection.stub().GetFrame(connection.context().get(), request, &response));
  FrameBackground background;
  background.depth_mm = decode(response.depth_png(), cv::IMREAD_UNCHANGED);
  if (!response.rgb_png().empty()) background.bgr = decode(response.rgb_png(), cv::IMREAD_COLOR);
  if (background.bgr.empty()) background.bgr = colorizeDepth(background.depth_mm);
  const auto& k = response.intrinsics();
  background.intrinsics = {k.fx(), k.fy(), k.cx(), k.cy(), static_cast<int>(k.width()),
                           static_cast<int>(k.height())};
  return background;
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  if (!cv::imwrite(path.string(), image)) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace shapesense::cli
