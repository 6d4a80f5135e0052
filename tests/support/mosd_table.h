#pragma once
// The table of shared/data/real/mosd_tabletop: its label images mark the table top with labels
// 1-9 (SOURCES.md). Tests check that a segmentation keeps it in one region.

#include <opencv2/core.hpp>

namespace shapesense::testing {

/// Fraction of the table's labelled pixels that have a depth reading and lie in the one region
/// of `regions` (CV_16UC1, 0 = unassigned) covering most of them; 0 when no table pixel has depth.
double mosdTableCoverage(const cv::Mat& regions, const cv::Mat& truth_labels,
                         const cv::Mat& depth_mm);

}  // namespace shapesense::testing
