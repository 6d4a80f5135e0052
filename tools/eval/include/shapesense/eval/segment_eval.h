#pragma once
// Scoring of segmentations: against synthetic truth (SegComp with the truth an operator wants:
// each planar face its own region, each curved object one region) and against the labelled
// real OSD frames (objects kept apart from the table and from each other, the table whole).

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/geometry/frame.h"
#include "shapesense/core/segmentation/segmentation_scoring.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::eval {

/// The regions a segmentation should find (CV_16UC1, 0 = no depth): every surface of the room,
/// the table, the boxes, books, boards and shelves on its own; every object with a curved
/// surface (bowl, cup, tin, ball, bin, column, torus, mound, lid) as one region.
cv::Mat segmentTruth(const synthetic::TruthFrame& truth);

/// Whether `label` of segmentTruth(truth) is the one region of an object with a curved surface
/// (else it is a surface of the scene, its label the surface's id).
bool isCurvedObjectRegion(int label, const synthetic::TruthFrame& truth);

/// SegComp at T = 0.8 of `regions` against segmentTruth(truth).
SegCompScore scoreSegments(const cv::Mat& regions, const synthetic::TruthFrame& truth);
/// ...against truth regions already made by segmentTruth.
SegCompScore scoreSegments(const cv::Mat& regions, const cv::Mat& truth_regions);

/// A real frame with the OSD labels (SOURCES.md: 1-9 the table, label / 10 the object id).
struct LabelledFrame {
  std::string name;  ///< the depth file's name
  Frame frame;
  cv::Mat labels;  ///< CV_16UC1
};

/// Every frame of a recording folder that has a label image, in index order. Throws
/// std::runtime_error when the folder is not a readable recording.
std::vector<LabelledFrame> loadLabelledRecording(const std::filesystem::path& dir);

/// What an OSD label belongs to: 0 nothing, -1 the table, k > 0 object k.
int osdOwner(int label);

struct RealSegmentScore {
  int frames = 0;
  int objects = 0;      ///< labelled objects with depth
  int kept_apart = 0;   ///< objects the regions keep apart (see scoreRealSegments)
  int table_whole = 0;  ///< frames whose table is one region (>= 80% of it in one region)
  void add(const RealSegmentScore& o);
  double keptApartFraction() const { return objects ? double(kept_apart) / objects : 0.0; }
};

/// An object is kept apart when the regions lying mostly on it cover >= 80% of it and none of
/// them also holds >= 20% of the table or of another object. Only pixels with depth count.
RealSegmentScore scoreRealSegments(const cv::Mat& regions, const cv::Mat& labels,
                                   const cv::Mat& depth_mm);

/// Share of the table's labelled pixels with depth that lie in the one region covering most
/// of them (0 when the table has no pixel with depth).
double tableCoverage(const cv::Mat& regions, const cv::Mat& labels, const cv::Mat& depth_mm);

}  // namespace shapesense::eval
