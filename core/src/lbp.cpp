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

namespace {

/// Cell sums of every position: element (y, x) = sum of the cw x ch pixels from (x, y). At most
/// 4 * 255, so 16 bits hold them and the code loop below runs on 8 lanes instead of 4.
template <int CW>
void cellSums(const cv::Mat& integral, int ch, cv::Mat& sums) {
  const int rows = integral.rows - 1 - (ch - 1), cols = integral.cols - 1 - (CW - 1);
  sums.create(rows, cols, CV_16SC1);
  for (int y = 0; y < rows; ++y) {
    const auto* top = integral.ptr<std::int32_t>(y);
    const auto* bottom = integral.ptr<std::int32_t>(y + ch);
    auto* out = sums.ptr<std::int16_t>(y);
    for (int x = 0; x < cols; ++x)
      out[x] = static_cast<std::int16_t>(bottom[x + CW] - top[x + CW] - bottom[x] + top[x]);
  }
}

template <int CW>
void codesFromCellSums(const cv::Mat& sums, int ch, cv::Mat& codes) {
  const int out_rows = sums.rows - 2 * ch, out_cols = sums.cols - 2 * CW;
  for (int y = 0; y < out_rows; ++y) {
    const auto* r0 = sums.ptr<std::int16_t>(y);
    const auto* r1 = sums.ptr<std::int16_t>(y + ch);
    const auto* r2 = sums.ptr<std::int16_t>(y + 2 * ch);
    auto* out = codes.ptr<std::uint8_t>(y);
    for (int x = 0; x < out_cols; ++x) {
      const std::int16_t c = r1[x + CW];
      // Bit k for neighbour k, clockwise from the top-left (see the header).
      const unsigned code = static_cast<unsigned>(r0[x] >= c) | static_cast<unsigned>(r0[x + CW] >= c) << 1 |
                            static_cast<unsigned>(r0[x + 2 * CW] >= c) << 2 |
                            static_cast<unsigned>(r1[x + 2 * CW] >= c) << 3 |
                            static_cast<unsigned>(r2[x + 2 * CW] >= c) << 4 |
                            static_cast<unsigned>(r2[x + CW] >= c) << 5 | static_cast<unsigned>(r2[x] >= c) << 6 |
                            static_cast<unsigned>(r1[x] >= c) << 7;
      out[x] = static_cast<std::uint8_t>(code);
    }
  }
}

}  // namespace

cv::Mat lbpCodeImage(const cv::Mat& integral, int cw, int ch) {
  CV_Assert(integral.type() == CV_32SC1 && integral.rows >= 1 && integral.cols >= 1);
  if (cw < 1 || cw > 2 || ch < 1 || ch > 2) throw std::invalid_argument("lbpCodeImage: cells must be 1 or 2 pixels");
  cv::Mat codes = cv::Mat::zeros(integral.rows - 1, integral.cols - 1, CV_8UC1);
  if (codes.rows < 3 * ch || codes.cols < 3 * cw) return codes;
  cv::Mat sums;
  if (cw == 1) {
    cellSums<1>(integral, ch, sums);
    codesFromCellSums<1>(sums, ch, codes);
  } else {
    cellSums<2>(integral, ch, sums);
    codesFromCellSums<2>(sums, ch, codes);
  }
  return codes;
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
