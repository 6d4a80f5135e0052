#include "shapesense/core/planes/plane_polygon.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace shapesense {
namespace {

double cross(const cv::Point2f& a, const cv::Point2f& b, const cv::Point2f& c) {
  return static_cast<double>(b.x - a.x) * (c.y - a.y) -
         static_cast<double>(b.y - a.y) * (c.x - a.x);
}

bool insideTriangle(const cv::Point2f& p, const cv::Point2f& a, const cv::Point2f& b,
                    const cv::Point2f& c) {
  // Counter-clockwise triangle (positive area); boundary counts as inside so that a
  // reflex vertex touching the ear blocks it.
  return cross(a, b, p) >= 0 && cross(b, c, p) >= 0 && cross(c, a, p) >= 0;
}

}  // namespace

std::vector<std::array<int, 3>> triangulatePolygon(const std::vector<cv::Point2f>& poly) {
  std::vector<std::array<int, 3>> tris;
  const int n = static_cast<int>(poly.size());
  if (n < 3) return tris;
  double area = 0;
  for (int i = 0; i < n; ++i) area += cross({0, 0}, poly[i], poly[(i + 1) % n]);
  std::vector<int> idx(n);
  for (int i = 0; i < n; ++i) idx[i] = area >= 0 ? i : n - 1 - i;  // make it counter-clockwise
  int guard = 0;
  while (idx.size() > 3 && guard < 4 * n * n) {
    bool clipped = false;
    const int m = static_cast<int>(idx.size());
    for (int i = 0; i < m; ++i) {
      ++guard;
      const int a = idx[(i + m - 1) % m], b = idx[i], c = idx[(i + 1) % m];
      if (cross(poly[a], poly[b], poly[c]) <= 0) continue;  // reflex or degenerate
      bool ear = true;
      for (int j = 0; j < m && ear; ++j) {
        const int q = idx[j];
        if (q == a || q == b || q == c) continue;
        if (insideTriangle(poly[q], poly[a], poly[b], poly[c])) ear = false;
      }
      if (!ear) continue;
      tris.push_back({a, b, c});
      idx.erase(idx.begin() + i);
      clipped = true;
      break;
    }
    if (!clipped) {
      // Not simple (self-touching contour): drop collinear/degenerate vertices as fan.
      for (std::size_t i = 1; i + 1 < idx.size(); ++i) tris.push_back({idx[0], idx[i], idx[i + 1]});
      return tris;
    }
  }
  if (idx.size() == 3) tris.push_back({idx[0], idx[1], idx[2]});
  return tris;
}

void regionPolygon(const cv::Mat& mask, cv::Point origin, double scale, double offset,
                   const Eigen::Vector3d& normal, double d, const CameraIntrinsics& intrinsics,
                   double epsilon_cells, std::vector<Eigen::Vector3d>& polygon,
                   std::vector<std::array<int, 3>>& triangles) {
  polygon.clear();
  triangles.clear();
  if (mask.empty()) return;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  if (contours.empty()) return;
  const auto& best =
      *std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
        return std::fabs(cv::contourArea(a)) < std::fabs(cv::contourArea(b));
      });
  std::vector<cv::Point> approx;
  cv::approxPolyDP(best, approx, epsilon_cells, true);
  std::vector<cv::Point2f> simple(approx.begin(), approx.end());
  if (approx.size() < 3 || std::fabs(cv::contourArea(approx)) < 1.0) {
    // A region one cell wide (a thin strip: a table's front edge seen from above) has a
    // degenerate contour; its samples stand for step x step cells, so use their bounding
    // rotated rectangle grown by one cell.
    cv::RotatedRect r = cv::minAreaRect(best);
    r.size.width += 1.0f;
    r.size.height += 1.0f;
    cv::Point2f corners[4];
    r.points(corners);
    simple.assign(corners, corners + 4);
  }
  std::vector<cv::Point2f> kept;
  for (const auto& c : simple) {
    const double u = offset + scale * (c.x + origin.x), v = offset + scale * (c.y + origin.y);
    const Eigen::Vector3d ray = intrinsics.ray(u, v);
    const double den = normal.dot(ray);
    if (!(den < -1e-6)) continue;  // ray (nearly) parallel to the plane: no stable vertex
    const double t = -d / den;
    polygon.push_back(t * ray);
    kept.emplace_back(static_cast<float>(u), static_cast<float>(v));
  }
  if (polygon.size() < 3) {
    polygon.clear();
    return;
  }
  triangles = triangulatePolygon(kept);
}

}  // namespace shapesense
