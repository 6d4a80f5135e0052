#include "overlay.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "shapesense/core/boxes/box_estimation.h"

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

cv::Vec3b labelColour(std::uint32_t id) {
  // Golden-ratio hue steps keep neighbouring ids far apart in colour.
  const double hue = std::fmod(id * 0.618033988749895, 1.0) * 180.0;
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue, 200 + 55 * (id % 2), 230));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr.at<cv::Vec3b>(0, 0);
}

void paintLabels(cv::Mat& bgr, const cv::Mat& labels, double alpha) {
  CV_Assert(labels.type() == CV_16UC1 && labels.size() == bgr.size() && bgr.type() == CV_8UC3);
  std::vector<cv::Vec3b> palette;
  for (int v = 0; v < labels.rows; ++v) {
    const auto* label = labels.ptr<std::uint16_t>(v);
    auto* pixel = bgr.ptr<cv::Vec3b>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const std::uint16_t id = label[u];
      if (id == 0) continue;
      if (id >= palette.size()) {
        for (std::size_t k = palette.size(); k <= id; ++k)
          palette.push_back(labelColour(static_cast<std::uint32_t>(k)));
      }
      const bool border = (u + 1 < labels.cols && label[u + 1] != id) ||
                          (v + 1 < labels.rows && labels.ptr<std::uint16_t>(v + 1)[u] != id);
      for (int c = 0; c < 3; ++c) {
        pixel[u][c] = border ? 0
                             : cv::saturate_cast<std::uint8_t>((1 - alpha) * pixel[u][c] +
                                                               alpha * palette[id][c]);
      }
    }
  }
}

void drawBowl(cv::Mat& bgr, const CameraIntrinsics& intrinsics, const v1::Bowl& bowl) {
  // One colour per view class (BGR), so a wrong view stands out across a sequence.
  const cv::Scalar colour = bowl.view() == "top"      ? cv::Scalar(255, 160, 0)
                            : bowl.view() == "middle" ? cv::Scalar(0, 220, 255)
                            : bowl.view() == "side"   ? cv::Scalar(255, 0, 255)
                                                      : cv::Scalar(255, 255, 255);
  if (bowl.corners_size() == 8) {
    BoxCorners corners;
    for (int i = 0; i < 8; ++i)
      corners[i] = {bowl.corners(i).x(), bowl.corners(i).y(), bowl.corners(i).z()};
    drawBox(bgr, intrinsics, corners, colour, 1);
  }
  const auto& b = bowl.box();
  const cv::Rect box(b.x(), b.y(), b.width(), b.height());
  cv::rectangle(bgr, box, colour, 2);
  char label[48];
  std::snprintf(label, sizeof label, "%.1f %s", bowl.score(), bowl.view().c_str());
  // Above the box, or inside its top edge when the box touches the image's top.
  const cv::Point origin(box.x, box.y >= 16 ? box.y - 5 : box.y + 14);
  cv::putText(bgr, label, origin, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(bgr, label, origin, cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
}

void drawObjectDetection(cv::Mat& bgr, const CameraIntrinsics& intrinsics,
                         const v1::ObjectDetection& detection) {
  const cv::Vec3b colour = labelColour(static_cast<std::uint32_t>(
      std::hash<std::string>{}(detection.name()) % 65521 + 1));  // one colour per name
  const cv::Scalar scalar(colour[0], colour[1], colour[2]);
  if (detection.box().corners_size() == 8) {
    BoxCorners corners;
    for (int i = 0; i < 8; ++i) {
      const auto& c = detection.box().corners(i);
      corners[i] = {c.x(), c.y(), c.z()};
    }
    drawBox(bgr, intrinsics, corners, scalar, 2);
  }
  const auto& b = detection.image_box();
  char label[96];
  std::snprintf(label, sizeof label, "%s %.2f", detection.name().c_str(), detection.score());
  // Above the box's projection, or inside its top edge when that touches the image's top.
  const cv::Point origin(b.x(), b.y() >= 16 ? b.y() - 5 : b.y() + 14);
  cv::putText(bgr, label, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(bgr, label, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, scalar, 1, cv::LINE_AA);
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
  background.intrinsics = {
      k.fx(), k.fy(), k.cx(), k.cy(), static_cast<int>(k.width()), static_cast<int>(k.height())};
  return background;
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  if (!cv::imwrite(path.string(), image)) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace shapesense::cli
