#pragma once
// Pictures a person can look at: the frame a result came from, as colour or coloured depth,
// with the result drawn over it.

#include <filesystem>

#include <opencv2/core.hpp>

#include "connection.h"
#include "shapesense/core/geometry/camera.h"
#include "shapesense/core/geometry/frame.h"

namespace shapesense::cli {

/// Depth in millimetres as a colour image (turbo, near = blue, far = red); no reading = black.
cv::Mat colorizeDepth(const cv::Mat& depth_mm);

/// Paints each non-zero label of `labels` (CV_16UC1) over `bgr` in its own colour, blended with
/// weight `alpha`, and outlines the regions; label 0 stays as it was.
void paintLabels(cv::Mat& bgr, const cv::Mat& labels, double alpha = 0.55);

/// The colour of label `id` in every overlay (stable across frames and commands).
cv::Vec3b labelColour(std::uint32_t id);

/// Draws a bowl: its image box and its 3D box in the colour of its view, and "score view"
/// above the box.
void drawBowl(cv::Mat& bgr, const CameraIntrinsics& intrinsics, const v1::Bowl& bowl);

/// Draws a found taught object: its 3D box and "name score" above the box's projection.
void drawObjectDetection(cv::Mat& bgr, const CameraIntrinsics& intrinsics,
                         const v1::ObjectDetection& detection);

/// A cached frame fetched for drawing: its picture (colour when the source has it, else
/// coloured depth) and intrinsics.
struct FrameBackground {
  cv::Mat bgr;
  cv::Mat depth_mm;
  CameraIntrinsics intrinsics;
};

/// Fetches the frame at exactly `timestamp_ns` (as a result reported it).
FrameBackground fetchFrameBackground(Connection& connection, TimestampNs timestamp_ns);

/// Writes a PNG; throws std::runtime_error naming the path when it cannot.
void writePng(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace shapesense::cli
