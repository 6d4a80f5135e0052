#include "shapesense/core/bowls/lbp.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "bowls/bowl_preprocess_kernels.h"

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
        for (int xx = 0; xx < cw; ++xx)
          s[i][j] += image8.at<std::uint8_t>(y + i * ch + yy, x + j * cw + xx);
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

/// Sums of the CW x CH cells starting at each x of pixel row `y` (cols - CW + 1 of them).
template <int CW, int CH>
void cellSumRowFromPixels(const cv::Mat& image8, int y, std::int16_t* out) {
  const int n = image8.cols - (CW - 1);
  const std::uint8_t* p0 = image8.ptr<std::uint8_t>(y);
  const std::uint8_t* p1 = image8.ptr<std::uint8_t>(y + CH - 1);
  for (int x = 0; x < n; ++x) {
    int sum = p0[x];
    if constexpr (CW == 2) sum += p0[x + 1];
    if constexpr (CH == 2) sum += p1[x];
    if constexpr (CW == 2 && CH == 2) sum += p1[x + 1];
    out[x] = static_cast<std::int16_t>(sum);
  }
}

/// lbpCodeImage for one cell size. The cell sums of the 2 * CH + 1 pixel rows a code
/// row reads are kept in a ring of rows, so each is computed once and stays in cache. With
/// `rows` (not null) only the code rows flagged there are computed, the others are 0.
template <int CW, int CH>
void codesFromPixels(const cv::Mat& image8, cv::Mat& codes, const std::uint8_t* rows) {
  const int out_rows = image8.rows - 3 * CH + 1, out_cols = image8.cols - 3 * CW + 1;
  constexpr int kRing = 2 * CH + 1;
  const int sum_cols = image8.cols - (CW - 1);
  std::vector<std::int16_t> ring(static_cast<std::size_t>(kRing * sum_cols));
  auto ringRow = [&](int y) {
    return ring.data() + static_cast<std::ptrdiff_t>(y % kRing) * sum_cols;
  };
  int next_sum_row = 0;  // the first pixel row whose cell sums are not in the ring yet
  for (int y = 0; y < out_rows; ++y) {
    std::uint8_t* out = codes.ptr<std::uint8_t>(y);
    if (rows && !rows[y]) {
      std::fill(out, out + codes.cols, std::uint8_t{0});
      continue;
    }
    // After skipped rows the ring restarts at y; the sums of rows before y are not read again.
    next_sum_row = std::max(next_sum_row, y);
    for (; next_sum_row <= y + 2 * CH; ++next_sum_row)
      cellSumRowFromPixels<CW, CH>(image8, next_sum_row, ringRow(next_sum_row));
    bowls::lbpCodeRow(ringRow(y), ringRow(y + CH), ringRow(y + 2 * CH), CW, out, out_cols);
    std::fill(out + out_cols, out + codes.cols, std::uint8_t{0});
  }
  for (int y = std::max(out_rows, 0); y < codes.rows; ++y) codes.row(y).setTo(0);
}

}  // namespace

cv::Mat lbpCodeImage(const cv::Mat& image8, int cw, int ch, const std::vector<std::uint8_t>& rows) {
  CV_Assert(image8.type() == CV_8UC1);
  if (cw < 1 || cw > 2 || ch < 1 || ch > 2)
    throw std::invalid_argument("lbpCodeImage: cells must be 1 or 2 pixels");
  if (!rows.empty() && static_cast<int>(rows.size()) != image8.rows)
    throw std::invalid_argument("lbpCodeImage: one row flag per image row");
  if (image8.rows < 3 * ch || image8.cols < 3 * cw) return cv::Mat::zeros(image8.size(), CV_8UC1);
  cv::Mat codes(image8.size(), CV_8UC1);
  const std::uint8_t* flags = rows.empty() ? nullptr : rows.data();
  switch (cw + 2 * ch) {
    case 3:
      codesFromPixels<1, 1>(image8, codes, flags);
      break;
    case 4:
      codesFromPixels<2, 1>(image8, codes, flags);
      break;
    case 5:
      codesFromPixels<1, 2>(image8, codes, flags);
      break;
    default:
      codesFromPixels<2, 2>(image8, codes, flags);
      break;
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
