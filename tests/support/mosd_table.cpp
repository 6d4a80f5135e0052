#include "mosd_table.h"

#include <algorithm>
#include <cstdint>
#include <map>

namespace shapesense::testing {

double mosdTableCoverage(const cv::Mat& regions, const cv::Mat& truth_labels,
                         const cv::Mat& depth_mm) {
  CV_Assert(regions.type() == CV_16UC1 && truth_labels.type() == CV_16UC1 &&
            depth_mm.type() == CV_16UC1);
  CV_Assert(regions.size() == truth_labels.size() && regions.size() == depth_mm.size());
  std::map<int, int> overlap;  // region id -> table pixels in it
  int table = 0;
  for (int v = 0; v < regions.rows; ++v)
    for (int u = 0; u < regions.cols; ++u) {
      const int label = truth_labels.at<std::uint16_t>(v, u);
      if (label < 1 || label > 9 || depth_mm.at<std::uint16_t>(v, u) == 0) continue;
      ++table;
      if (const int id = regions.at<std::uint16_t>(v, u)) ++overlap[id];
    }
  int best = 0;
  for (const auto& [id, count] : overlap) best = std::max(best, count);
  return table ? static_cast<double>(best) / table : 0.0;
}

}  // namespace shapesense::testing
