#pragma once
// Scoring of detected planes against synthetic truth: SegComp (Hoover et al. 1996, T = 0.8)
// against the planar truth surfaces, with each truth plane's outcome by its share of the image,
// the spurious planes, and the plane errors of the correct pairs.

#include <array>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "shapesense/core/planes/planes.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::eval {

/// Share-of-image bins of the truth planes: [0.5%, 1%), [1%, 2%), [2%, 5%), [5%, 100%].
inline constexpr std::array<double, 5> kPlaneSizeBinEdges = {0.005, 0.01, 0.02, 0.05, 1.01};
inline constexpr int kPlaneSizeBins = 4;

/// What became of the truth planes of one size bin.
struct PlaneOutcomes {
  int correct = 0;
  int split = 0;   ///< over-segmented: cut into several planes
  int merged = 0;  ///< under-segmented: one plane with a neighbour
  int missed = 0;
  int total() const { return correct + split + merged + missed; }
  void add(const PlaneOutcomes& o);
};

struct PlaneScore {
  int frames = 0;
  int truth_regions = 0;  ///< truth planar surfaces >= 0.5% of the image
  int correct = 0;        ///< SegComp correct detections at T = 0.8
  std::array<PlaneOutcomes, kPlaneSizeBins> by_size{};
  int reported = 0;  ///< reported planes with at least one pixel
  /// Reported planes in no correct, split or merged relation with a truth plane (a plane cut
  /// out of a curved surface, or a wrong one).
  int spurious = 0;
  int spurious_on_curved = 0;  ///< of them, those lying mostly on curved surfaces
  /// The others by the two planar truth surfaces under most of their pixels (the second
  /// holding at least a tenth of the plane): surfaces meeting at 60 deg or more (a face with a
  /// strip of the face beyond its crease), parallel within 10 deg and more than 5 mm apart (a
  /// lid on a table, stacked faces), parallel and within 5 mm (touching faces flush: no depth
  /// reading tells them apart; their distances from the camera compared, a coarse measure for
  /// planes up to 10 deg apart); the rest (other angles, or one surface and pixels of none).
  int spurious_across_crease = 0;
  int spurious_parallel = 0;
  int spurious_coplanar = 0;
  int spurious_other = 0;
  std::vector<double> angle_deg;  ///< per correctly detected truth plane
  std::vector<double> dist_m;
  std::vector<std::pair<int, int>> matches;  ///< (truth surface id, found id) of correct pairs

  void add(const PlaneScore& o);
  double correctFraction() const { return truth_regions ? double(correct) / truth_regions : 0.0; }
  double spuriousPerFrame() const { return frames ? double(spurious) / frames : 0.0; }
};

/// The median (NaN for none).
double median(std::vector<double> values);

/// truth.surface_labels restricted to planar surfaces.
cv::Mat planarTruth(const synthetic::TruthFrame& truth);

/// Scores one frame's planes (`labels` CV_16UC1, ids of `planes`) against its truth.
PlaneScore scorePlanes(const cv::Mat& labels, const std::vector<DetectedPlane>& planes,
                       const synthetic::TruthFrame& truth);

}  // namespace shapesense::eval
