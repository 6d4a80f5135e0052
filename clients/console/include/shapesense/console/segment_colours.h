#pragma once
// The segments overlay of the page: the daemon's region image coloured by the console, so the
// browser gets a picture it can lay over the preview as it is.

#include <string>

namespace shapesense::console {

/// The 16-bit region image `labels_png` (GetSegmentsResponse.labels_png) as an RGBA PNG of the
/// same size: each region id a colour of its own, the same for the same id on every frame, and
/// alpha 0 where the id is 0 (unassigned). Throws std::invalid_argument when `labels_png` is
/// not a single-channel PNG.
std::string colourSegmentLabels(const std::string& labels_png);

}  // namespace shapesense::console
