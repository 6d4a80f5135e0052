#include "roi_arg.h"

#include <array>
#include <sstream>

#include <CLI/CLI.hpp>

namespace shapesense::cli {

std::pair<v1::Pixel, v1::Pixel> parseRoiArgument(const std::string& text,
                                                 const std::string& option) {
  std::array<int, 4> values{};
  std::istringstream in(text);
  char comma = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!(in >> values[i]) || (i < 3 && !(in >> comma && comma == ','))) {
      throw CLI::ValidationError(option,
                                 "'" + text + "' is not x1,y1,x2,y2 (four whole pixel numbers)");
    }
  }
  if (in >> comma) throw CLI::ValidationError(option, "'" + text + "' has more than four numbers");
  v1::Pixel p1, p2;
  p1.set_x(values[0]);
  p1.set_y(values[1]);
  p2.set_x(values[2]);
  p2.set_y(values[3]);
  return {p1, p2};
}

}  // namespace shapesense::cli
