// Unit tests of the sparse hierarchical Hough space: parametrisation, sparse blocks, smoothing,
// maxima, decay.
#include "shapesense/core/planes/hough_accumulator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace shapesense {
namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Vector3d unit(double x, double y, double z) { return Eigen::Vector3d(x, y, z).normalized(); }

TEST(HoughAccumulator, LambertCellsRoundTripEverywhereVisible) {
  HoughAccumulator acc;                     // 1.5 deg cells
  for (double t = 0; t <= 100; t += 7)      // angle from -z (deg)
    for (double p = 0; p < 360; p += 23) {  // azimuth
      const Eigen::Vector3d n(std::sin(t * kDeg) * std::cos(p * kDeg),
                              std::sin(t * kDeg) * std::sin(p * kDeg), -std::cos(t * kDeg));
      int i, j, k;
      ASSERT_TRUE(acc.cellOf(n, 1.0, i, j, k)) << t << " " << p;
      const Eigen::Vector3d c = acc.cellCoordinates(n, 1.0);
      const Eigen::Vector3d back = acc.normalAt(c.x(), c.y());
      EXPECT_LT(std::acos(std::clamp(back.dot(n), -1.0, 1.0)) / kDeg, 1e-4) << t << " " << p;
      // A cell never spans more than ~2x its nominal angle (equal-area map, mild distortion).
      const Eigen::Vector3d nb = acc.normalAt(i + 1, j);
      EXPECT_LT(std::acos(std::clamp(nb.dot(acc.normalAt(i, j)), -1.0, 1.0)) / kDeg, 1.5 * 2.0)
          << t;
      EXPECT_NEAR(acc.dAt(c.z()), 1.0, 1e-9);
    }
}

// cellOf rounds without floor (a truncation after its range test): it must give the nearest
// cell centre, floor(c + 0.5) of cellCoordinates, and refuse exactly the planes whose nearest
// cell lies outside the space. vote() addresses blocks with shifts and masks, at() with
// divisions: a vote must land in cellOf's cell, or nowhere. Planes include cell boundaries,
// outside the Lambert square, behind the camera and beyond max_d_m.
TEST(HoughAccumulator, VoteLandsInTheCellOfCellOf) {
  HoughAccumulator acc;
  std::uint32_t rng = 12345u;
  auto uniform = [&rng](double lo, double hi) {
    rng = rng * 1664525u + 1013904223u;
    return lo + (hi - lo) * static_cast<double>(rng >> 8) / static_cast<double>(1u << 24);
  };
  std::vector<std::pair<Eigen::Vector3d, double>> planes;
  for (int t = 0; t < 3000; ++t)  // anywhere on the sphere, d from -1 to 9 m
    planes.emplace_back(unit(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)), uniform(-1.0, 9.0));
  for (int t = 0; t < 500; ++t) {  // on cell boundaries (half-integer cell coordinates)
    const double i = std::floor(uniform(0, acc.cellsA())) + 0.5;
    const double j = std::floor(uniform(0, acc.cellsA())) + 0.5;
    const double k = std::floor(uniform(0, acc.cellsD())) + 0.5;
    planes.emplace_back(acc.normalAt(i, j), acc.dAt(k));
  }
  planes.emplace_back(unit(0, 0, 1), 1.0);  // pointing away from the camera: the pole
  int inside = 0;
  for (const auto& [n, d] : planes) {
    acc.clear();
    acc.vote(n, d);
    const Eigen::Vector3d c = acc.cellCoordinates(n, d);
    const double fi = std::floor(c.x() + 0.5), fj = std::floor(c.y() + 0.5),
                 fk = std::floor(c.z() + 0.5);
    const bool nearest_inside = fi >= 0 && fj >= 0 && fk >= 0 && fi < acc.cellsA() &&
                                fj < acc.cellsA() && fk < acc.cellsD();
    int i, j, k;
    const bool inside_space = acc.cellOf(n, d, i, j, k);
    ASSERT_EQ(inside_space, nearest_inside) << n.transpose() << " " << d;
    if (inside_space) {
      EXPECT_EQ(i, fi);
      EXPECT_EQ(j, fj);
      EXPECT_EQ(k, fk);
      ++inside;
      EXPECT_EQ(acc.at(i, j, k), 1.0f) << n.transpose() << " " << d;
      EXPECT_EQ(acc.totalMass(), 1.0) << n.transpose() << " " << d;
    } else {
      EXPECT_EQ(acc.totalMass(), 0.0) << n.transpose() << " " << d;
    }
  }
  EXPECT_GT(inside, 1000);  // both cases are exercised
  EXPECT_LT(inside, static_cast<int>(planes.size()) - 500);
}

TEST(HoughAccumulator, VoteBatchIsVoteInOrder) {
  // Float normals and distances anywhere on the sphere (some outside the space, some at the
  // pole), an odd count (the unpaired tail): the batch fills exactly the cells, with exactly
  // the sums, of one vote() per plane.
  std::uint32_t rng = 777u;
  auto uniform = [&rng](double lo, double hi) {
    rng = rng * 1664525u + 1013904223u;
    return lo + (hi - lo) * static_cast<double>(rng >> 8) / static_cast<double>(1u << 24);
  };
  std::vector<float> nx, ny, nz, d;
  for (int t = 0; t < 2001; ++t) {
    // Clustered (many votes per cell, sums in order) and scattered.
    const Eigen::Vector3d n =
        t % 3 ? unit(uniform(-0.05, 0.05), uniform(-1, -0.9), uniform(-0.3, -0.2))
              : unit(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    nx.push_back(static_cast<float>(n.x()));
    ny.push_back(static_cast<float>(n.y()));
    nz.push_back(static_cast<float>(n.z()));
    d.push_back(static_cast<float>(t % 3 ? uniform(0.9, 1.0) : uniform(-1.0, 9.0)));
  }
  nx.push_back(0.0f), ny.push_back(0.0f), nz.push_back(1.0f), d.push_back(1.0f);  // the pole
  HoughAccumulator one, batch;
  for (std::size_t v = 0; v < nx.size(); ++v)
    one.vote(Eigen::Vector3d(nx[v], ny[v], nz[v]), d[v], 0.7f);
  batch.voteBatch(nx.data(), ny.data(), nz.data(), d.data(), static_cast<int>(nx.size()), 0.7f);
  ASSERT_EQ(batch.allocatedBlocks(), one.allocatedBlocks());
  EXPECT_EQ(batch.totalMass(), one.totalMass());
  int cells = 0;
  for (std::size_t v = 0; v < nx.size(); ++v) {
    int i, j, k;
    if (!one.cellOf(Eigen::Vector3d(nx[v], ny[v], nz[v]), d[v], i, j, k)) continue;
    EXPECT_EQ(batch.at(i, j, k), one.at(i, j, k)) << v;
    ++cells;
  }
  EXPECT_GT(cells, 1500);
  EXPECT_GT(one.totalMass(), 1000.0);
}

TEST(HoughAccumulator, AllocatesOnlyWhereVotesLandAndRecyclesBlocks) {
  HoughAccumulator acc;
  const std::size_t dense = static_cast<std::size_t>(acc.cellsA()) * acc.cellsA() * acc.cellsD();
  EXPECT_GT(dense, 5'000'000u);  // 1.5 deg x 2 cm over 8 m: a dense float grid would be > 20 MB
  EXPECT_EQ(acc.allocatedBlocks(), 0u);
  for (int r = 0; r < 1000; ++r) acc.vote(unit(0, 0, -1), 2.0);
  EXPECT_EQ(acc.allocatedBlocks(), 1u);
  acc.vote(unit(0, -1, -0.3), 1.0);
  EXPECT_EQ(acc.allocatedBlocks(), 2u);
  EXPECT_DOUBLE_EQ(acc.totalMass(), 1001.0);
  int i, j, k;
  ASSERT_TRUE(acc.cellOf(unit(0, 0, -1), 2.0, i, j, k));
  EXPECT_FLOAT_EQ(acc.at(i, j, k), 1000.0f);
  acc.clear();
  EXPECT_EQ(acc.allocatedBlocks(), 0u);
  EXPECT_FLOAT_EQ(acc.at(i, j, k), 0.0f);
  acc.vote(unit(0, 0, -1), 2.0);
  EXPECT_EQ(acc.allocatedBlocks(), 1u);
  // Out of range votes are dropped.
  acc.vote(unit(0, 0, -1), 100.0);
  acc.vote(unit(0, 0, 1), 1.0);
  EXPECT_DOUBLE_EQ(acc.totalMass(), 1.0);
}

TEST(HoughAccumulator, SmoothingIsANormalisedGaussianWithTheGivenSigmas) {
  HoughSpaceParams sp;
  HoughAccumulator acc(sp), smooth(sp);
  const Eigen::Vector3d n = unit(0.1, -0.2, -1);
  int i, j, k;
  ASSERT_TRUE(acc.cellOf(n, 2.0, i, j, k));
  acc.addToCell(i, j, k, 100.0f);
  const double sa = 1.5, sd = 0.02;  // one cell sigma in every axis
  acc.smoothInto(smooth, sa, sd, 1.0f);
  // Mass conserved (the kernel fits into the block neighbourhood).
  EXPECT_NEAR(smooth.totalMass(), 100.0, 1e-3);
  // Peak = 100 x central weight; one cell away = exp(-1/2) of it along each axis.
  EXPECT_NEAR(smooth.at(i, j, k), 100.0 * smooth.kernelPeak(sa, sd), 1e-3);
  const double c = smooth.at(i, j, k);
  EXPECT_NEAR(smooth.at(i + 1, j, k) / c, std::exp(-0.5), 1e-4);
  EXPECT_NEAR(smooth.at(i, j - 1, k) / c, std::exp(-0.5), 1e-4);
  EXPECT_NEAR(smooth.at(i, j, k + 1) / c, std::exp(-0.5), 1e-4);
  EXPECT_NEAR(smooth.at(i + 2, j, k + 2) / c, std::exp(-4.0), 1e-4);
  // A block holding less than min_block_mass is not evaluated.
  acc.clear();
  acc.addToCell(i, j, k, 1.0f);
  acc.smoothInto(smooth, sa, sd, 2.0f);
  EXPECT_EQ(smooth.allocatedBlocks(), 0u);
}

// The separable smoothing as its definition states it, on a dense grid: per axis (x, then y,
// then z) out(c) = sum over t in [-r, r], ascending, of w[t] * in(c + t), zero outside the
// space, float sums from 0. Taps computed as smoothInto documents them.
std::vector<float> denseSmoothing(const HoughAccumulator& acc, double sigma_angle_deg,
                                  double sigma_d_m) {
  const int na = acc.cellsA(), nd = acc.cellsD();
  auto taps = [](double sigma_cells) {
    if (!(sigma_cells > 1e-6)) return std::vector<float>{1.0f};
    const int r = std::min(static_cast<int>(std::ceil(2.5 * sigma_cells)), 4);
    std::vector<float> w(2 * r + 1);
    double sum = 0;
    for (int t = -r; t <= r; ++t) {
      const double v = std::exp(-0.5 * t * t / (sigma_cells * sigma_cells));
      w[t + r] = static_cast<float>(v);
      sum += v;
    }
    for (auto& v : w) v = static_cast<float>(v / sum);
    return w;
  };
  const double a_cell = std::max(1e-4, acc.params().angle_cell_deg * kDeg);
  const std::vector<float> wa = taps(sigma_angle_deg * kDeg / a_cell),
                           wd = taps(sigma_d_m / acc.params().d_cell_m);
  const std::size_t size = static_cast<std::size_t>(na) * na * nd;
  auto idx = [&](int i, int j, int k) { return (static_cast<std::size_t>(k) * na + j) * na + i; };
  std::vector<float> a(size), b(size);
  for (int k = 0; k < nd; ++k)
    for (int j = 0; j < na; ++j)
      for (int i = 0; i < na; ++i) a[idx(i, j, k)] = acc.at(i, j, k);
  auto pass = [&](const std::vector<float>& in, std::vector<float>& out, int axis,
                  const std::vector<float>& w) {
    const int r = static_cast<int>(w.size() / 2);
    for (int k = 0; k < nd; ++k)
      for (int j = 0; j < na; ++j)
        for (int i = 0; i < na; ++i) {
          float sum = 0.0f;
          for (int t = -r; t <= r; ++t) {
            int c[3] = {i, j, k};
            c[axis] += t;
            if (c[axis] < 0 || c[axis] >= (axis == 2 ? nd : na)) continue;
            sum += w[t + r] * in[idx(c[0], c[1], c[2])];
          }
          out[idx(i, j, k)] = sum;
        }
  };
  pass(a, b, 0, wa);
  pass(b, a, 1, wa);
  pass(a, b, 2, wd);
  return b;
}

TEST(HoughAccumulator, SmoothingIsBitIdenticalToTheDenseSeparableDefinition) {
  // A small space (partial blocks at the far borders) with random clusters and scattered
  // votes, including the borders; every block heavy (min_block_mass 0), so the sparse
  // evaluation must give exactly the dense passes everywhere.
  HoughSpaceParams sp;
  sp.lambert_extent = 0.3;  // 23 cells per Lambert axis
  sp.max_d_m = 0.5;         // 25 cells along d
  HoughAccumulator acc(sp), smooth(sp);
  ASSERT_NE(acc.cellsA() % HoughAccumulator::kBlock, 0);
  std::uint32_t rng = 777;
  auto uniform = [&rng](int n) {
    rng = rng * 1664525u + 1013904223u;
    return static_cast<int>((rng >> 8) % static_cast<std::uint32_t>(n));
  };
  for (int cluster = 0; cluster < 6; ++cluster) {
    const int ci = uniform(acc.cellsA()), cj = uniform(acc.cellsA()), ck = uniform(acc.cellsD());
    for (int v = 0; v < 40; ++v)
      acc.addToCell(ci + uniform(5) - 2, cj + uniform(5) - 2, ck + uniform(5) - 2,
                    0.25f + 0.125f * static_cast<float>(uniform(8)));
  }
  for (int v = 0; v < 30; ++v)
    acc.addToCell(uniform(acc.cellsA()), uniform(acc.cellsA()), uniform(acc.cellsD()), 1.0f);
  acc.addToCell(0, 0, 0, 3.0f);
  acc.addToCell(acc.cellsA() - 1, acc.cellsA() - 1, acc.cellsD() - 1, 2.0f);
  for (const auto& [sa, sd] : {std::pair{2.0, 0.03}, std::pair{1.0, 0.01}, std::pair{0.0, 0.02}}) {
    acc.smoothInto(smooth, sa, sd, 0.0f);
    const std::vector<float> expected = denseSmoothing(acc, sa, sd);
    int mismatches = 0;
    std::size_t c = 0;
    for (int k = 0; k < acc.cellsD(); ++k)
      for (int j = 0; j < acc.cellsA(); ++j)
        for (int i = 0; i < acc.cellsA(); ++i, ++c) mismatches += smooth.at(i, j, k) != expected[c];
    EXPECT_EQ(mismatches, 0) << "sigmas " << sa << " deg, " << sd << " m";
  }
}

TEST(HoughAccumulator, SlidingWindowMaximaWithSubCellPrecision) {
  HoughAccumulator acc, smooth;
  // Two planes 30 deg apart, 400 and 200 votes spread over +-1 deg / +-1 cm, plus a single
  // far-away vote that must not produce a maximum.
  const Eigen::Vector3d n1 = unit(0, -1, -0.5),
                        n2 = Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitX()) * n1;
  for (int r = 0; r < 400; ++r) {
    const double a = ((r % 7) - 3) / 3.0 * kDeg, dd = ((r % 5) - 2) * 0.005;
    acc.vote((Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()) * n1).normalized(), 1.2 + dd);
  }
  for (int r = 0; r < 200; ++r) acc.vote(n2, 0.8 + ((r % 3) - 1) * 0.005);
  acc.vote(unit(0.8, 0, -0.5), 3.0);
  acc.smoothInto(smooth, 2.0, 0.03, 2.0f);
  const auto maxima = smooth.findMaxima(static_cast<float>(20 * smooth.kernelPeak(2.0, 0.03)));
  ASSERT_EQ(maxima.size(), 2u);
  EXPECT_GT(maxima[0].value, maxima[1].value);  // strongest first
  EXPECT_LT(std::acos(std::min(1.0, maxima[0].normal.dot(n1))) / kDeg,
            1.0);  // 2/3 of a 1.5-deg cell
  EXPECT_NEAR(maxima[0].d, 1.2, 0.01);
  EXPECT_LT(std::acos(std::min(1.0, maxima[1].normal.dot(n2))) / kDeg, 1.0);
  EXPECT_NEAR(maxima[1].d, 0.8, 0.01);
}

// findMaxima by its definition, as (value, k, j, i), strongest first: a cell of the space that
// is >= min_value and that no cell of its window beats (larger, or equal and earlier in (k, j,
// i) order), the window read through at() (0 outside the space).
std::vector<std::tuple<float, int, int, int>> bruteForceMaxima(const HoughAccumulator& acc,
                                                               float min_value, int wa, int wd) {
  std::vector<std::tuple<float, int, int, int>> maxima;
  for (int k = 0; k < acc.cellsD(); ++k)
    for (int j = 0; j < acc.cellsA(); ++j)
      for (int i = 0; i < acc.cellsA(); ++i) {
        const float v = acc.at(i, j, k);
        if (!(v >= min_value)) continue;
        bool is_max = true;
        for (int dk = -wd; dk <= wd && is_max; ++dk)
          for (int dj = -wa; dj <= wa && is_max; ++dj)
            for (int di = -wa; di <= wa && is_max; ++di) {
              const float o = acc.at(i + di, j + dj, k + dk);
              const bool earlier = std::make_tuple(dk, dj, di) < std::make_tuple(0, 0, 0);
              if (o > v || (o == v && earlier)) is_max = false;
            }
        if (is_max) maxima.emplace_back(v, k, j, i);
      }
  std::sort(maxima.begin(), maxima.end(), [](const auto& a, const auto& b) {
    return std::get<0>(a) > std::get<0>(b) ||
           (std::get<0>(a) == std::get<0>(b) &&
            std::tie(std::get<1>(a), std::get<2>(a), std::get<3>(a)) <
                std::tie(std::get<1>(b), std::get<2>(b), std::get<3>(b)));
  });
  return maxima;
}

// findMaxima(min_value, wa, wd) equals bruteForceMaxima, with finite centroids.
void expectBruteForceMaxima(const HoughAccumulator& acc, float min_value, int wa, int wd,
                            std::size_t min_count) {
  const auto expected = bruteForceMaxima(acc, min_value, wa, wd);
  const auto got = acc.findMaxima(min_value, wa, wd);
  ASSERT_EQ(got.size(), expected.size()) << "window " << wa << ", " << wd;
  ASSERT_GE(got.size(), min_count) << "window " << wa << ", " << wd;
  for (std::size_t m = 0; m < got.size(); ++m) {
    EXPECT_EQ(got[m].value, std::get<0>(expected[m]));
    EXPECT_EQ(
        std::tie(got[m].k, got[m].j, got[m].i),
        std::tie(std::get<1>(expected[m]), std::get<2>(expected[m]), std::get<3>(expected[m])))
        << "window " << wa << ", " << wd;
    EXPECT_TRUE(got[m].normal.allFinite() && std::isfinite(got[m].d))
        << "window " << wa << ", " << wd << " cell " << got[m].i << " " << got[m].j << " "
        << got[m].k;
  }
}

TEST(HoughAccumulator, MaximaAreTheBruteForceWindowMaximaWithPlateaus) {
  // Small integer values (many ties, plateaus across block borders), compared with the
  // definition.
  HoughSpaceParams sp;
  sp.lambert_extent = 0.3;
  sp.max_d_m = 0.5;
  HoughAccumulator acc(sp);
  std::uint32_t rng = 4242;
  auto uniform = [&rng](int n) {
    rng = rng * 1664525u + 1013904223u;
    return static_cast<int>((rng >> 8) % static_cast<std::uint32_t>(n));
  };
  for (int v = 0; v < 3000; ++v)
    acc.addToCell(uniform(acc.cellsA()), uniform(acc.cellsA()), uniform(acc.cellsD()),
                  static_cast<float>(uniform(3)));
  for (int k = 6; k < 10; ++k)  // a plateau across a block border
    for (int j = 2; j < 6; ++j)
      for (int i = 2; i < 7; ++i) acc.addToCell(i, j, k, 50.0f - acc.at(i, j, k));
  for (const auto& [wa, wd] : {std::pair{2, 2}, std::pair{1, 3}, std::pair{0, 1}})
    expectBruteForceMaxima(acc, 2.0f, wa, wd, 11);
  // A negative half-size counts as 0.
  for (const auto& [wa, wd] : {std::pair{2, -1}, std::pair{-1, 1}, std::pair{-3, -2}}) {
    const auto got = acc.findMaxima(2.0f, wa, wd);
    const auto expected = acc.findMaxima(2.0f, std::max(wa, 0), std::max(wd, 0));
    ASSERT_EQ(got.size(), expected.size()) << "window " << wa << ", " << wd;
    for (std::size_t m = 0; m < got.size(); ++m)
      EXPECT_EQ(std::tie(got[m].i, got[m].j, got[m].k, got[m].value),
                std::tie(expected[m].i, expected[m].j, expected[m].k, expected[m].value));
  }
}

TEST(HoughAccumulator, NaNCellsAreNoMaxima) {
  // NaN cells (one alone, one in a peak's window, one in a plateau's) are never reported and
  // beat no neighbour: the brute-force definition with ordered compares. (Not within a
  // maximum's 3x3x3 cells: its centroid would be NaN.)
  HoughAccumulator acc;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  acc.addToCell(20, 20, 20, nan);
  acc.addToCell(40, 40, 40, 5.0f);
  acc.addToCell(42, 40, 40, nan);
  acc.addToCell(60, 60, 60, 3.0f);
  acc.addToCell(61, 60, 60, 3.0f);
  acc.addToCell(60, 62, 59, nan);
  for (const auto& [wa, wd] : {std::pair{2, 2}, std::pair{1, 0}, std::pair{0, 0}}) {
    expectBruteForceMaxima(acc, 1.0f, wa, wd, 2);
    for (const auto& m : acc.findMaxima(1.0f, wa, wd)) EXPECT_FALSE(std::isnan(m.value));
  }
  for (const auto& m : acc.findMaxima(-1.0f, 1, 1)) EXPECT_FALSE(std::isnan(m.value));
}

TEST(HoughAccumulator, MaximaLieInTheSpaceWhenTheLastBlocksStickOut) {
  // nd = 401 (the last block along d has 1 cell in the space and 3 outside) and na = 123 (3
  // in, 1 outside), strong peaks at the far ends of the axes. The smoothing fills whole blocks,
  // so the cells outside the space hold values; only cells of the space may be maxima, the
  // window seeing 0 outside (as at() does), and every centroid is finite.
  HoughSpaceParams sp;
  sp.max_d_m = 8.01;
  HoughAccumulator acc(sp), smooth;
  const int na = acc.cellsA(), nd = acc.cellsD();
  ASSERT_EQ(nd, 401);
  ASSERT_EQ(na % HoughAccumulator::kBlock, 3);
  acc.addToCell(na - 1, na - 1, nd - 1, 100.0f);  // the far corner
  acc.addToCell(40, 40, nd - 1, 90.0f);           // the far d face
  acc.addToCell(na - 1, 60, nd - 2, 80.0f);
  acc.addToCell(70, na - 1, 200, 70.0f);  // far Lambert faces
  acc.addToCell(na - 2, 20, 100, 60.0f);
  acc.addToCell(10, 10, 10, 50.0f);  // inside
  acc.smoothInto(smooth, 2.0, 0.03, 0.0f);
  for (const auto& [wa, wd] : {std::pair{2, 2}, std::pair{1, 1}, std::pair{2, 0}, std::pair{0, 2},
                               std::pair{1, 0}, std::pair{0, 0}})
    expectBruteForceMaxima(smooth, 1e-3f, wa, wd, 6);
}

TEST(HoughAccumulator, SmoothingPrunedForAPeakThresholdFindsTheSameMaxima) {
  // Scattered votes (a curved surface) around three planes of 60, 25 and 12 votes: with the
  // peak threshold of ~20 votes the pruned smoothing evaluates fewer blocks, yet every maximum
  // and the values around it are bit-identical.
  HoughAccumulator acc, full, pruned;
  const Eigen::Vector3d n1 = unit(0, -1, -0.5), n2 = unit(0.3, 0.1, -1), n3 = unit(-0.4, 0.2, -1);
  for (int r = 0; r < 60; ++r) acc.vote(n1, 1.2 + ((r % 5) - 2) * 0.004);
  for (int r = 0; r < 25; ++r) acc.vote(n2, 2.0 + ((r % 3) - 1) * 0.004);
  for (int r = 0; r < 12; ++r) acc.vote(n3, 0.9);
  std::uint32_t rng = 12345;
  auto uniform = [&rng] {
    rng = rng * 1664525u + 1013904223u;
    return static_cast<double>(rng >> 8) / (1u << 24);
  };
  for (int r = 0; r < 600; ++r)
    acc.vote(unit(uniform() - 0.5, uniform() - 0.5, -1), 0.5 + 2.5 * uniform());
  const double sa = 2.0, sd = 0.03;
  const float min_peak = static_cast<float>(20 * acc.kernelPeak(sa, sd));
  acc.smoothInto(full, sa, sd, 1.0f);
  acc.smoothInto(pruned, sa, sd, 1.0f, min_peak);
  EXPECT_LT(pruned.allocatedBlocks(), full.allocatedBlocks());
  const auto expected = full.findMaxima(min_peak), got = pruned.findMaxima(min_peak);
  ASSERT_EQ(got.size(), expected.size());
  ASSERT_GE(got.size(), 2u);
  for (std::size_t m = 0; m < got.size(); ++m) {
    EXPECT_EQ(std::tie(got[m].i, got[m].j, got[m].k),
              std::tie(expected[m].i, expected[m].j, expected[m].k));
    EXPECT_EQ(got[m].value, expected[m].value);
    EXPECT_EQ(got[m].normal, expected[m].normal);
    EXPECT_EQ(got[m].d, expected[m].d);
    for (int dk = -2; dk <= 2; ++dk)
      for (int dj = -2; dj <= 2; ++dj)
        for (int di = -2; di <= 2; ++di) {
          const int i = got[m].i + di, j = got[m].j + dj, k = got[m].k + dk;
          EXPECT_EQ(pruned.at(i, j, k), full.at(i, j, k));
        }
  }
}

TEST(HoughAccumulator, DecayThinsAndFreesBlocks) {
  HoughAccumulator acc;
  acc.addGaussian(unit(0, 0, -1), 2.0, 10.0, 1.5, 0.02);
  EXPECT_NEAR(acc.totalMass(), 10.0, 1e-3);
  const std::size_t blocks = acc.allocatedBlocks();
  EXPECT_GT(blocks, 1u);
  acc.decay(0.5f, 0.0f);
  EXPECT_NEAR(acc.totalMass(), 5.0, 1e-3);
  acc.decay(1.0f, 10.0f);  // thinning removes everything
  EXPECT_EQ(acc.allocatedBlocks(), 0u);
  EXPECT_DOUBLE_EQ(acc.totalMass(), 0.0);
}

}  // namespace
}  // namespace shapesense
