#pragma once
// Training data for the OpenCV xobjdetect WBDetector peer (bench/bowls_bench.cpp), made from the
// same bowl dataset as our models.
//
// WBDetector trains from a folder of 24x24 positive crops and a folder of object-free images,
// and scans square 24x24 windows. Our bowls are not square (median box height/width per view:
// side ~0.5, middle ~0.76, top ~0.9), so, per view as our models, every image is first stretched
// vertically by 1 / aspect (the view's median box aspect): a bowl box then becomes about square,
// and the detector sees what it was trained on. The object box sits inside the window with the
// same margin as our models (BowlViewModel::object_margin). Detections are mapped back with
// windowToObjectBox.
//
// Layout written by exportWbDetectorData (per view V):
//   <out>/V/pos/*.png   24x24 8-bit crops (preprocessDepth), mirrored copies included
//   <out>/V/neg/*.png   mosaics of random windows of the bowl-free frames (see the .cpp), then
//                       the dataset's bowl-free frames (preprocessDepth), stretched
//   <out>/V/meta.yml    aspect, margin, window (read with readWbDetectorMeta)

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace shapesense::train {

struct WbDetectorExportParams {
  std::vector<std::string> views = {"top", "middle", "side"};
  /// Object margin inside the window on each side. Default 0.125, as our models.
  double margin = 0.125;
  /// At most this many bowls per view become positives (evenly spread over the dataset).
  /// Default 500.
  int max_bowls_per_view = 500;
  /// Each bowl gives as many of its 10 variants as needed to reach about this many positives
  /// per view: the crop, its mirror, then both shifted by +-1 window pixel in x and y (our
  /// trainer uses all 10). WBDetector retrains every round on all positives and 10x as many
  /// negatives with a full scan of its 8464 features per weak classifier, so more costs time;
  /// fewer starves it (with the 80 top-view bowls x 2 its first round separates its 1580 random
  /// negatives with 4 features, the last at zero error, which yields a NaN weight and a
  /// classifier that rejects everything). Default 1000 (at least 2 variants per bowl).
  int target_positives = 1000;
};

/// Per-view geometry shared by the export and the detector side.
struct WbDetectorMeta {
  double aspect = 1.0;  ///< median box height / width of the view's training bowls
  double margin = 0.125;
  int window = 24;  ///< WBDetector's fixed window side (pixels)
};

/// Writes the folders described above from the dataset at `data`. Prints progress to stderr.
/// Throws std::runtime_error when a view has no training bowl or there is no bowl-free frame.
void exportWbDetectorData(const std::filesystem::path& data, const std::filesystem::path& out,
                          const WbDetectorExportParams& params);

void writeWbDetectorMeta(const std::filesystem::path& file, const WbDetectorMeta& meta);
/// Throws std::runtime_error when the file is missing or malformed.
WbDetectorMeta readWbDetectorMeta(const std::filesystem::path& file);

/// The image a view's WBDetector scans: `img8` stretched vertically by 1 / meta.aspect.
cv::Mat stretchForView(const cv::Mat& img8, const WbDetectorMeta& meta);

/// A window found in the stretched image -> the object box in the original image.
cv::Rect windowToObjectBox(const cv::Rect& window, const WbDetectorMeta& meta);

}  // namespace shapesense::train
