#pragma once
// Local Binary Patterns over a 3x3 grid of rectangular cells (multi-block LBP), as used by the
// seed's bowl detector: each cell is cw x ch pixels (1 or 2 each in the seed: "LBP in size of
// 2x2 pixels"), the 8 outer cells are compared with the centre cell by their pixel sums, and
// the comparison bits form an 8-bit code. Cell sums come from an integral image, so a code
// costs 16 reads whatever the cell size and window position.
//
// Bit order (fixed, part of the model format): neighbour k sets bit k when its sum is >= the
// centre's, k = 0..7 clockwise from the top-left cell:
//   0 1 2
//   7 . 3
//   6 5 4

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace shapesense {

/// One LBP feature inside a detection window: the 3x3 grid's top-left corner (window pixels)
/// and the cell size. The grid covers 3*cw x 3*ch pixels.
struct LbpFeature {
  int x = 0;
  int y = 0;
  int cw = 1;
  int ch = 1;
  bool operator==(const LbpFeature&) const = default;
};

/// Every feature whose grid fits in a win_w x win_h window, cell sizes 1..max_cell each way.
std::vector<LbpFeature> enumerateLbpFeatures(int win_w, int win_h, int max_cell = 2);

/// The code by direct summation over a CV_8UC1 image (reference implementation, for tests).
std::uint8_t lbpCodeDirect(const cv::Mat& image8, int x, int y, int cw, int ch);

/// Integral image of a CV_8UC1 image as CV_32SC1 of size (rows+1) x (cols+1).
cv::Mat lbpIntegral(const cv::Mat& image8);

/// The 16 integral-image offsets (in elements, relative to the window's top-left integral
/// element) of the 4x4 grid corners of `f`, row-major, for an integral image with `stride`
/// elements per row.
struct LbpOffsets {
  std::int32_t o[16];
};
LbpOffsets lbpOffsets(const LbpFeature& f, int stride);

/// The code from an integral image: `origin` points at the integral element of the window's
/// top-left pixel, `off` from lbpOffsets with the image's stride.
inline std::uint8_t lbpCodeIntegral(const std::int32_t* origin, const LbpOffsets& off) {
  const std::int32_t* p = origin;
  const std::int32_t* o = off.o;
  // Cell (i, j) sum = A(i,j) - A(i,j+1) - A(i+1,j) + A(i+1,j+1) with A the 4x4 corners.
  std::int32_t a[16];
  for (int k = 0; k < 16; ++k) a[k] = p[o[k]];
  auto cell = [&](int i, int j) {
    return a[i * 4 + j] - a[i * 4 + j + 1] - a[(i + 1) * 4 + j] + a[(i + 1) * 4 + j + 1];
  };
  const std::int32_t c = cell(1, 1);
  std::uint8_t code = 0;
  code |= static_cast<std::uint8_t>((cell(0, 0) >= c) << 0);
  code |= static_cast<std::uint8_t>((cell(0, 1) >= c) << 1);
  code |= static_cast<std::uint8_t>((cell(0, 2) >= c) << 2);
  code |= static_cast<std::uint8_t>((cell(1, 2) >= c) << 3);
  code |= static_cast<std::uint8_t>((cell(2, 2) >= c) << 4);
  code |= static_cast<std::uint8_t>((cell(2, 1) >= c) << 5);
  code |= static_cast<std::uint8_t>((cell(2, 0) >= c) << 6);
  code |= static_cast<std::uint8_t>((cell(1, 0) >= c) << 7);
  return code;
}

/// The codes of every grid position for one cell size, from the CV_8UC1 image itself: a CV_8UC1
/// image of its size whose element (y, x) is the code of the grid with top-left pixel (x, y) and
/// cw x ch cells; positions whose grid does not fit hold 0. Equal to lbpCodeIntegral wherever the
/// grid fits. A detector that evaluates most positions of a level with several features of few
/// cell sizes computes codes once here, in vectorised row loops, instead of 16 scattered
/// integral reads per feature and window; a cell sum is 1-4 byte reads, and the sums live in a
/// few cache-resident rows. `cw` and `ch` must be 1 or 2.
/// With `rows` (one flag per image row) only the rows y with rows[y] != 0 are computed and the
/// others hold 0: a detector that knows which window rows it will scan (the depth gate rejects
/// every window of many rows) skips the rest. Empty = every row.
cv::Mat lbpCodeImage(const cv::Mat& image8, int cw, int ch,
                     const std::vector<std::uint8_t>& rows = {});

/// Convenience: the code of feature `f` for the window at (wx, wy) of integral image `ii`.
std::uint8_t lbpCodeAt(const cv::Mat& ii, const LbpFeature& f, int wx, int wy);

}  // namespace shapesense
