#pragma once
// SegComp-style scoring of a region image against ground truth (Hoover et al., "An experimental
// comparison of range image segmentation algorithms", PAMI 1996).
//
// Conventions:
//  - Label 0 is "no region" in both images (truth 0 = no ground truth, e.g. no depth; found 0 =
//    unassigned). Only pixels with truth != 0 are scored; region sizes and overlaps are counted
//    over those pixels only, so a found region is not penalised for extending into pixels that have
//    no truth, and a truth pixel left unassigned (found 0) counts against coverage.
//  - Only truth regions covering >= min_truth_fraction of the image (rows*cols) enter the
//    classification counts (correct / over / under / missed); smaller ones are too small to judge
//    at T = 0.8. Pixel accuracy uses every labelled pixel.
//  - Correct detection: truth region Rm and found region Rn with overlap O >= T*|Rm| and
//    O >= T*|Rn| (for T > 0.5 each region has at most one such partner).
//  - Over-segmentation: a truth region (not correctly detected) with >= 2 found regions each
//    having >= T of its pixels inside it and together covering >= T of it.
//  - Under-segmentation: a found region with >= 2 (considered) truth regions each having >= T of
//    their pixels inside it, together covering >= T of it; counted per truth region involved.
//  - Missed: considered truth regions in none of the above. Noise: found regions (non-zero, with
//    at least one scored pixel) that are in no correct / over / under relation.
//  - Pixel accuracy: each found region scores the pixels it shares with its best-overlapping
//    truth region; sum / number of pixels with truth != 0 (found 0 scores nothing).

#include <vector>

#include <opencv2/core.hpp>

namespace shapesense {

/// What SegComp made of one region.
enum class SegCompOutcome { kNone, kCorrect, kOverSegmented, kUnderSegmented };

/// One truth region of the scored image: its label, its scored pixels, and its outcome
/// (kNone = missed when considered; regions below min_truth_fraction are not classified).
struct SegCompTruthRegion {
  int label = 0;
  int pixels = 0;
  bool considered = false;
  SegCompOutcome outcome = SegCompOutcome::kNone;
};

/// One found region with >= 1 scored pixel: its label, its scored pixels, and its outcome
/// (kNone = noise).
struct SegCompFoundRegion {
  int label = 0;
  int pixels = 0;
  SegCompOutcome outcome = SegCompOutcome::kNone;
};

struct SegCompScore {
  int truth_regions = 0;                  ///< truth regions >= min_truth_fraction of the image
  int found_regions = 0;                  ///< non-zero found regions with >= 1 scored pixel
  int correct = 0;                        ///< correctly detected truth regions
  int over_segmented = 0;                 ///< truth regions over-segmented
  int under_segmented = 0;                ///< truth regions involved in an under-segmentation
  int missed = 0;                         ///< considered truth regions with no relation
  int noise = 0;                          ///< found regions with no relation
  double correct_fraction = 0;            ///< correct / truth_regions (0 when there are none)
  double pixel_accuracy = 0;              ///< see file comment (0 when no pixel is labelled)
  std::vector<SegCompTruthRegion> truth;  ///< per truth region, in order of first appearance
  std::vector<SegCompFoundRegion> found;  ///< per found region, in order of first appearance
};

/// Both images CV_16UC1 (or CV_32SC1) of the same size.
SegCompScore scoreSegmentation(const cv::Mat& found_labels, const cv::Mat& truth_labels,
                               double overlap_threshold = 0.8, double min_truth_fraction = 0.005);

}  // namespace shapesense
