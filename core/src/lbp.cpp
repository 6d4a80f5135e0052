#include "shapesense/core/lbp.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace shapesense {

std::vector<LbpFeature> enumerateLbpFeatures(int win_w, int win_h, int max_cell) {
  std::vector<LbpFeature> out;
  for (int ch = 1; ch <= max_cell; ++ch)
    for (int cw = 1; cw <= max_cell; ++cw)
      for (int y = 0; y + 3 * ch <= win_h; ++y)
        for (int x = 0; x + 3 * cw <= win_w; ++x) out.push_back({x, y, cw, ch});
  return out;
}

std::uint8_t lbpCodeDirect(const cv::Mat& image8, int x, int y, int cw, int ch) {
  CV_Assert(image8.type() == CV_8UC1);
  if (x < 0 || y < 0 || x + 3 * cw > image8.cols || y + 3 * ch > image8.rows)
    throw std::out_of_range("lbpCodeDirect: grid outside the image");
  long s[3][3] = {};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int yy = 0; yy < ch; ++yy)
        for (int xx = 0; xx < cw; ++xx) s[i][j] += image8.at<std::uint8_t>(y + i * ch + yy, x + j * cw + xx);
  const long c = s[1][1];
  const long nb[8] = {s[0][0], s[0][1], s[0][2], s[1][2], s[2][2], s[2][1], s[2][0], s[1][0]};
  std::uint8_t code = 0;
  for (int k = 0; k < 8; ++k)
    if (nb[k] >= c) code |= static_cast<std::uint8_t>(1u << k);
  return code;
}

cv::Mat lbpIntegral(const cv::Mat& image8) {
  CV_Assert(image8.type() == CV_8UC1);
  cv::Mat ii;
  cv::integral(image8, ii, CV_32S);
  return ii;
}

LbpOffsets lbpOffsets(const LbpFeature& f, int stride) {
  LbpOffsets off{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) off.o[i * 4 + j] = (f.y + i * f.ch) * stride + (f.x + j * f.cw);
  return off;
}

std::uint8_t lbpCodeAt(const cv::Mat& ii, const LbpFeature& f, int wx, int wy) {
  CV_Assert(ii.type() == CV_32SC1);
  const int stride = static_cast<int>(ii.step1());
  return lbpCodeIntegral(ii.ptr<std::int32_t>(wy) + wx, lbpOffsets(f, stride));
}

}  // namespace shapesense
