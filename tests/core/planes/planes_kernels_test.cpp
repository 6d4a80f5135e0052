// The plane detection and labelling Highway kernels on every SIMD target this machine runs, bit
// for bit against their scalar definitions (planes_kernels.h), on lengths that leave every
// possible tail.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../../core/src/planes/planes_kernels.h"
#include "simd_targets.h"

namespace shapesense {
namespace {

namespace pk = planes_kernels;

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

constexpr int kMaxCount = 41;

// Points about 1-3 m away, unit normals mostly towards the camera, tolerances of a few cm; a
// NaN normal now and then.
struct Samples {
  std::vector<float> x, y, z, nx, ny, nz, tol;
  std::vector<std::uint8_t> alive;
  pk::SampleArrays arrays() const {
    return {x.data(), y.data(), z.data(), nx.data(), ny.data(), nz.data(), tol.data()};
  }
};

Samples randomSamples(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Samples s;
  for (int k = 0; k < kMaxCount; ++k) {
    s.x.push_back(u(rng)), s.y.push_back(u(rng)), s.z.push_back(2.0f + u(rng));
    float a = 0.3f * u(rng), b = 0.3f * u(rng), c = -1.0f;
    const float n = std::sqrt(a * a + b * b + c * c);
    if (k % 9 == 4) a = std::numeric_limits<float>::quiet_NaN();
    s.nx.push_back(a / n), s.ny.push_back(b / n), s.nz.push_back(c / n);
    s.tol.push_back(0.02f + 0.02f * u(rng));
    s.alive.push_back(static_cast<std::uint8_t>(rng() % 5 != 0));
  }
  return s;
}

TEST(PlanesKernels, GateFlagsAreTheirDefinitionOnEveryTarget) {
  std::mt19937 rng(1);
  const Samples s = randomSamples(rng);
  const pk::PlaneGates gates[] = {{0.05f, -0.1f, -0.99f, 2.0f, 1.0f, 0.95f},
                                  {0.05f, -0.1f, -0.99f, 2.0f, 2.0f, 0.9f}};
  testing::forEachSimdTarget([&](const std::string& target) {
    for (const pk::PlaneGates& g : gates)
      for (const bool with_alive : {false, true})
        for (int count = 0; count <= kMaxCount; ++count) {
          std::vector<std::uint8_t> in(count + 1, 7);
          const std::uint8_t* alive = with_alive ? s.alive.data() : nullptr;
          pk::gateFlags(g, s.arrays(), alive, in.data(), count);
          for (int k = 0; k < count; ++k) {
            const float dist = std::fabs(g.nx * s.x[k] + g.ny * s.y[k] + g.nz * s.z[k] + g.d);
            const bool agree = g.nx * s.nx[k] + g.ny * s.ny[k] + g.nz * s.nz[k] >= g.cos_normal;
            const bool want = (!alive || alive[k]) && dist <= g.gate_mult * s.tol[k] && agree;
            ASSERT_EQ(in[k], want ? 1 : 0) << target << " count " << count << " k " << k;
          }
          EXPECT_EQ(in[count], 7) << target << ": wrote past the end";
        }
  });
}

TEST(PlanesKernels, NormalAgreementIsItsDefinitionOnEveryTarget) {
  std::mt19937 rng(2);
  const Samples s = randomSamples(rng);
  std::vector<float> normals;
  for (int k = 0; k < kMaxCount; ++k) normals.insert(normals.end(), {s.nx[k], s.ny[k], s.nz[k]});
  testing::forEachSimdTarget([&](const std::string& target) {
    for (const int offset : {1, 5})
      for (int begin = 0; begin < 3; ++begin)
        for (int end = begin; end + offset <= kMaxCount; ++end) {
          std::vector<std::uint8_t> agree(kMaxCount, 7);
          pk::normalAgreement(normals.data(), offset, 0.97f, begin, end, agree.data());
          for (int i = 0; i < kMaxCount; ++i) {
            if (i < begin || i >= end) {
              ASSERT_EQ(agree[i], 7) << target << ": wrote outside [begin, end)";
              continue;
            }
            const float* a = &normals[3 * i];
            const float* b = &normals[3 * (i + offset)];
            const bool want = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] >= 0.97f;
            ASSERT_EQ(agree[i], want ? 1 : 0) << target << " offset " << offset << " i " << i;
          }
        }
  });
}

TEST(PlanesKernels, CountWithinIsItsDefinitionOnEveryTarget) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> x, y, z, tol;
  for (int k = 0; k < kMaxCount; ++k)
    x.push_back(u(rng)), y.push_back(u(rng)), z.push_back(2.0 + 0.05 * u(rng)), tol.push_back(0.03);
  testing::forEachSimdTarget([&](const std::string& target) {
    for (std::size_t n = 0; n <= kMaxCount; ++n) {
      std::size_t want = 0;
      for (std::size_t k = 0; k < n; ++k)
        want += std::fabs(0.01 * x[k] + -0.02 * y[k] + -0.999 * z[k] + 2.0) <= tol[k];
      EXPECT_EQ(
          pk::countWithin(0.01, -0.02, -0.999, 2.0, x.data(), y.data(), z.data(), tol.data(), n),
          want)
          << target << " n " << n;
    }
  });
}

TEST(PlanesKernels, SampleRowPointsAreTheirDefinitionOnEveryTarget) {
  std::vector<std::uint16_t> depth(kMaxCount);
  std::vector<float> rx(kMaxCount);
  for (int c = 0; c < kMaxCount; ++c) {
    depth[c] = c % 6 == 2 ? 0 : static_cast<std::uint16_t>(600 + 97 * c);
    rx[c] = (static_cast<float>(c) - 20.5f) * 0.0019f;
  }
  const float ry = -0.37f;
  testing::forEachSimdTarget([&](const std::string& target) {
    for (int cols = 0; cols <= kMaxCount; ++cols) {
      std::vector<float> points(3 * cols + 1, 7.0f);
      pk::sampleRowPoints(depth.data(), rx.data(), ry, cols, points.data());
      for (int c = 0; c < cols; ++c) {
        const float* p = &points[3 * c];
        if (depth[c] == 0) {
          EXPECT_TRUE(std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2])) << target;
          continue;
        }
        const float z = static_cast<float>(depth[c]) * 0.001f;
        EXPECT_TRUE(sameBits(p[0], rx[c] * z) && sameBits(p[1], ry * z) && sameBits(p[2], z))
            << target << " cols " << cols << " c " << c;
      }
      EXPECT_EQ(points[3 * cols], 7.0f) << target << ": wrote past the end";
    }
  });
}

// A row of depths on two planes with holes, and the pixel-plane forms of three planes.
struct LabelRow {
  std::vector<std::uint16_t> depth;
  pk::PixelPlane planes[4];
  std::uint16_t labels[4] = {3, 9, 12, 40};
};

LabelRow labelRow() {
  LabelRow row;
  for (int u = 0; u < kMaxCount; ++u)
    row.depth.push_back(u % 7 == 3 ? 0 : static_cast<std::uint16_t>(u % 10 < 5 ? 1500 + u : 1530));
  // Planes n . X + d = 0 facing the camera at about 1.5 m, in pinhole form (fx = fy = 500).
  const float d[4] = {-1.52f, -1.53f, -1.50f, -1.58f};
  for (int k = 0; k < 4; ++k) row.planes[k] = {0.0004f * k, 0.3f * 0.002f, 1.0f, d[k], 0.012f};
  return row;
}

float pixelDistance(float z, float fu, const pk::PixelPlane& p) {
  return std::fabs(z * (p.a * fu + p.bv + p.c) + p.d);
}

TEST(PlanesKernels, LabelRunsAreTheirDefinitionOnEveryTarget) {
  const LabelRow row = labelRow();
  const float floor = 0.004f;
  testing::forEachSimdTarget([&](const std::string& target) {
    for (int u0 = 0; u0 < 3; ++u0)
      for (int u1 = u0; u1 <= kMaxCount; ++u1) {
        for (int k = 1; k <= 4; ++k) {
          std::vector<std::uint16_t> got(kMaxCount, 7);
          int counts[4] = {0, 0, 0, 0};
          if (k == 1)
            counts[0] = pk::labelSingleCandidateRun(row.depth.data(), got.data(), kMaxCount, u0, u1,
                                                    row.planes[0], floor, row.labels[0]);
          else
            pk::labelCandidatesRun(row.depth.data(), got.data(), kMaxCount, u0, u1, row.planes,
                                   row.labels, k, floor, counts);
          int want_counts[4] = {0, 0, 0, 0};
          for (int u = 0; u < kMaxCount; ++u) {
            if (u < u0 || u >= u1) {
              ASSERT_EQ(got[u], 7) << target << ": wrote outside the run";
              continue;
            }
            const float z = static_cast<float>(row.depth[u]) * 0.001f;
            float best = std::numeric_limits<float>::max();
            std::uint16_t want = 0;
            for (int c = 0; c < k; ++c) {
              const float dd = pixelDistance(z, static_cast<float>(u), row.planes[c]);
              if (dd <= best && dd <= std::max(floor, row.planes[c].tol_coef * (z * z))) {
                best = dd;
                want = row.labels[c];
              }
            }
            if (row.depth[u] == 0) want = 0;
            ASSERT_EQ(got[u], want)
                << target << " k " << k << " run " << u0 << ".." << u1 << " pixel " << u;
            for (int c = 0; c < k; ++c) want_counts[c] += want != 0 && want == row.labels[c];
          }
          for (int c = 0; c < k; ++c)
            EXPECT_EQ(counts[c], want_counts[c]) << target << " k " << k << " candidate " << c;
        }
      }
  });
}

}  // namespace
}  // namespace shapesense
