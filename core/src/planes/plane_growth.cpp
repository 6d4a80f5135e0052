#include "planes/plane_growth.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace shapesense::labeling {
namespace {

// Open pixels (depth, no plane, not blocked) as 255, with a border of one closed pixel all round
// so that every pixel's four neighbours can be read without a bounds test.
cv::Mat openPixels(const cv::Mat& depth_mm, const cv::Mat& labels, const cv::Mat& blocked) {
  cv::Mat open = cv::Mat::zeros(labels.rows + 2, labels.cols + 2, CV_8UC1);
  cv::Mat inside = open(cv::Rect(1, 1, labels.cols, labels.rows));
  cv::compare(labels, 0, inside, cv::CMP_EQ);
  cv::Mat has_depth;
  cv::compare(depth_mm, 0, has_depth, cv::CMP_NE);
  cv::bitwise_and(inside, has_depth, inside);
  if (!blocked.empty()) inside.setTo(0, blocked);
  return open;
}

// The plane pixels with an open 4-neighbour (they line the planes' borders), in raster order:
// a vectorised pass per row marks them, and eight marks at a time skip the rest.
std::vector<cv::Point> seedPixels(const cv::Mat& labels, const cv::Mat& open) {
  std::vector<cv::Point> seeds;
  std::vector<std::uint8_t> marks(static_cast<std::size_t>(labels.cols) + 8, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const std::uint16_t* __restrict label = labels.ptr<std::uint16_t>(v);
    const std::uint8_t* __restrict up = open.ptr<std::uint8_t>(v) + 1;
    const std::uint8_t* __restrict row = open.ptr<std::uint8_t>(v + 1) + 1;
    const std::uint8_t* __restrict down = open.ptr<std::uint8_t>(v + 2) + 1;
    std::uint8_t* __restrict mark = marks.data();
    for (int u = 0; u < labels.cols; ++u)
      mark[u] = static_cast<std::uint8_t>((label[u] != 0) &
                                          ((row[u - 1] | row[u + 1] | up[u] | down[u]) != 0));
    for (int u = 0; u < labels.cols; u += 8) {
      std::uint64_t eight;  // the marks past the row's end stay 0
      std::memcpy(&eight, marks.data() + u, sizeof eight);
      if (!eight) continue;
      for (int k = u; k < u + 8 && k < labels.cols; ++k)
        if (marks[k]) seeds.emplace_back(k, v);
    }
  }
  return seeds;
}

}  // namespace

std::size_t growPlanesIntoUnlabelled(const cv::Mat& depth_mm, const CameraIntrinsics& intrinsics,
                                     const std::vector<float>& tolerance_at_1m,
                                     float tolerance_floor_m, const DepthStepRule& continuity,
                                     const cv::Mat& blocked, PlaneDetection& detection) {
  cv::Mat& labels = detection.labels;
  CV_Assert(depth_mm.type() == CV_16UC1 && labels.type() == CV_16UC1 &&
            labels.size() == depth_mm.size());
  CV_Assert(blocked.empty() || (blocked.type() == CV_8UC1 && blocked.size() == labels.size()));
  CV_Assert(tolerance_at_1m.size() > detection.planes.size());
  cv::Mat open = openPixels(depth_mm, labels, blocked);
  // Breadth first from every plane's border at once: the queue holds each ring after the last.
  std::vector<cv::Point> queue = seedPixels(labels, open);
  std::size_t taken = 0;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const cv::Point from = queue[head];
    const std::uint16_t id = labels.at<std::uint16_t>(from);
    DetectedPlane& plane = detection.planes[id - 1];
    CV_DbgAssert(plane.id == id);
    const double z_from = depth_mm.at<std::uint16_t>(from) * 1e-3;
    for (const cv::Point step :
         {cv::Point(-1, 0), cv::Point(1, 0), cv::Point(0, -1), cv::Point(0, 1)}) {
      const cv::Point p = from + step;
      std::uint8_t& is_open = open.at<std::uint8_t>(p.y + 1, p.x + 1);  // the border is closed
      if (!is_open) continue;
      const double z = depth_mm.at<std::uint16_t>(p) * 1e-3;
      if (continuity.isStep(z_from, z)) continue;
      const Eigen::Vector3d x = intrinsics.backproject(p.x, p.y, z);
      const double tolerance = std::max<double>(tolerance_floor_m, tolerance_at_1m[id] * z * z);
      if (std::abs(plane.normal.dot(x) + plane.d) > tolerance) continue;
      labels.at<std::uint16_t>(p) = id;
      is_open = 0;
      ++plane.inliers;
      plane.box |= cv::Rect(p.x, p.y, 1, 1);
      ++taken;
      queue.push_back(p);
    }
  }
  return taken;
}

}  // namespace shapesense::labeling
