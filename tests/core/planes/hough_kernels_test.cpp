// The Hough accumulator's Highway kernels on every SIMD target this machine runs, bit for bit
// against their scalar definitions (hough_kernels.h).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../../core/src/planes/hough_kernels.h"
#include "simd_targets.h"

namespace shapesense {
namespace {

using hough_kernels::kBlock;
using hough_kernels::kBlockCells;
using hough_kernels::kTaps;

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// The definition of a smoothing pass along the axis whose cells are `stride` apart.
void smoothReference(const float* const (&blocks)[3], const float* taps, int stride, float* out) {
  for (int c = 0; c < kBlockCells; ++c) {
    const int t = (c / stride) % kBlock;
    float acc = 0.0f;
    for (int s = 0; s < 3; ++s) {
      if (blocks[s] == nullptr) continue;
      for (int r = 0; r < kBlock; ++r) {
        const int u = s * kBlock + r - kBlock - t;
        if (u >= -kBlock && u <= kBlock) {
          const float product = taps[u + kBlock] * blocks[s][c + (r - t) * stride];
          acc = acc + product;
        }
      }
    }
    out[c] = acc;
  }
}

TEST(HoughKernels, SmoothingPassesAreTheirDefinitionOnEveryTarget) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> value(0.0f, 3.0f);
  std::vector<float> data(3 * kBlockCells);
  for (float& v : data) v = rng() % 3 == 0 ? 0.0f : value(rng);
  float taps[kTaps];
  for (float& w : taps) w = value(rng) / 7.0f;
  using Pass = void (*)(hough_kernels::BlockTriple, const float*, float*);
  const Pass passes[3] = {hough_kernels::smoothBlockX, hough_kernels::smoothBlockY,
                          hough_kernels::smoothBlockZ};
  const int strides[3] = {1, kBlock, kBlock * kBlock};
  testing::forEachSimdTarget([&](const std::string& target) {
    for (int axis = 0; axis < 3; ++axis)
      for (int present = 1; present < 8; ++present) {
        const float* blocks[3];
        for (int s = 0; s < 3; ++s)
          blocks[s] = (present >> s) & 1 ? &data[s * kBlockCells] : nullptr;
        float got[kBlockCells], want[kBlockCells];
        passes[axis](blocks, taps, got);
        smoothReference(blocks, taps, strides[axis], want);
        for (int c = 0; c < kBlockCells; ++c)
          ASSERT_TRUE(sameBits(got[c], want[c]))
              << target << " axis " << axis << " present " << present << " cell " << c;
      }
  });
}

TEST(HoughKernels, CellMasksAreTheirDefinitionOnEveryTarget) {
  std::mt19937 rng(5);
  testing::forEachSimdTarget([&](const std::string& target) {
    for (int trial = 0; trial < 50; ++trial) {
      float cells[kBlockCells];
      // Few distinct values, so ties (plateaus) are common; a NaN now and then.
      for (float& v : cells)
        v = rng() % 41 == 0 ? std::numeric_limits<float>::quiet_NaN()
                            : static_cast<float>(rng() % 4);
      const float min_value = static_cast<float>(rng() % 4);
      std::uint64_t at_least = 0;
      for (int c = 0; c < kBlockCells; ++c)
        at_least |= static_cast<std::uint64_t>(cells[c] >= min_value) << c;
      EXPECT_EQ(hough_kernels::cellsAtLeast(cells, min_value), at_least) << target;
      for (const bool lambert : {false, true})
        for (const bool depth : {false, true}) {
          std::uint64_t beaten = 0;
          for (int c = 0; c < kBlockCells; ++c) {
            const int i = c % kBlock, j = (c / kBlock) % kBlock, k = c / (kBlock * kBlock);
            const float v = cells[c];
            bool b = false;
            if (lambert) {
              b |= i > 0 && cells[c - 1] >= v;
              b |= i + 1 < kBlock && cells[c + 1] > v;
              b |= j > 0 && cells[c - kBlock] >= v;
              b |= j + 1 < kBlock && cells[c + kBlock] > v;
            }
            if (depth) {
              b |= k > 0 && cells[c - kBlock * kBlock] >= v;
              b |= k + 1 < kBlock && cells[c + kBlock * kBlock] > v;
            }
            beaten |= static_cast<std::uint64_t>(b) << c;
          }
          EXPECT_EQ(hough_kernels::cellsBeatenInBlock(cells, lambert, depth), beaten)
              << target << " lambert " << lambert << " depth " << depth;
        }
    }
  });
}

TEST(HoughKernels, VoteCellCoordinatesAreTheirDefinitionOnEveryTarget) {
  std::mt19937 rng(3);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  const int n = 37;  // not a multiple of any lane count: the scalar tail runs too
  std::vector<float> nx(n), ny(n), nz(n), d(n);
  for (int v = 0; v < n; ++v) {
    float x = gauss(rng), y = gauss(rng), z = -std::fabs(gauss(rng));
    if (v == 5) x = y = 0.0f, z = 1.0f;  // the pole
    const float norm = std::sqrt(x * x + y * y + z * z);
    nx[v] = x / norm, ny[v] = y / norm, nz[v] = z / norm;
    d[v] = std::fabs(gauss(rng)) * 3.0f;
  }
  nz[11] = std::numeric_limits<float>::quiet_NaN();
  const hough_kernels::VoteSpace space{1.6, 1.0 / (1.5 * M_PI / 180.0), 50.0};
  testing::forEachSimdTarget([&](const std::string& target) {
    for (const int count : {0, 1, 3, 8, 17, n}) {
      std::vector<double> ci(count), cj(count), ck(count);
      hough_kernels::voteCellCoordinates(nx.data(), ny.data(), nz.data(), d.data(), count, space,
                                         ci.data(), cj.data(), ck.data());
      for (int v = 0; v < count; ++v) {
        const double den = 1.0 - static_cast<double>(nz[v]);
        if (!(den > 1e-9)) {
          EXPECT_EQ(ci[v], -1.0) << target << " vote " << v;
          continue;
        }
        const double s = std::sqrt(2.0 / den);
        const double a = ((s * nx[v] + space.lambert_extent) * space.inv_a_cell - 0.5) + 0.5;
        const double b = ((s * ny[v] + space.lambert_extent) * space.inv_a_cell - 0.5) + 0.5;
        const double c = (static_cast<double>(d[v]) * space.inv_d_cell - 0.5) + 0.5;
        EXPECT_TRUE(sameBits(ci[v], a) && sameBits(cj[v], b) && sameBits(ck[v], c))
            << target << " count " << count << " vote " << v;
      }
    }
  });
}

}  // namespace
}  // namespace shapesense
