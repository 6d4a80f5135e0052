#pragma once
// Command-line ROI arguments: "--roi x1,y1,x2,y2", two opposite corners in pixels.

#include <string>
#include <utility>

#include "shapesense/v1/shapesense.pb.h"

namespace shapesense::cli {

/// "x1,y1,x2,y2" -> two pixels. Throws CLI::ValidationError naming `option` and the bad text.
std::pair<v1::Pixel, v1::Pixel> parseRoiArgument(const std::string& text,
                                                 const std::string& option = "--roi");

}  // namespace shapesense::cli
