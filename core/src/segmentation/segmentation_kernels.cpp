// The SIMD kernels of segmentation, written once with Google Highway and compiled for every
// target (see segmentation_kernels.h). Unsigned 16-bit differences are taken as
// (x -sat y) | (y -sat x), and |x - y| > t as |x - y| -sat t != 0: the same integers on every
// target.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "segmentation/segmentation_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
// Highway's foreach_target must come before highway.h.
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>

#include "segmentation/segmentation_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::segmentation {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// ---------------------------------------------------------------------------------------------
// Depth-step counts

template <class D>
hn::Vec<D> absDiff(D, hn::Vec<D> x, hn::Vec<D> y) {
  return hn::Or(hn::SaturatedSub(x, y), hn::SaturatedSub(y, x));
}

/// countDepthSteps for the Lanes(d) pixels from u, whose windows lie inside the row. R is a
/// template argument so that the offset loops unroll.
template <int R, class D>
void countBlock(D d, const std::uint16_t* centre, const StepWindow& w, int u, std::uint8_t* e) {
  const hn::Vec<D> zero = hn::Zero(d), one = hn::Set(d, 1);
  const hn::Vec<D> x = hn::LoadU(d, centre + u);
  hn::Vec<D> t[R];
  for (int k = 0; k < R; ++k) t[k] = hn::LoadU(d, w.thresholds[k] + u);
  hn::Vec<D> misses = zero;  // neighbours without depth or without a step
  for (int dv = -R; dv <= R; ++dv) {
    const std::uint16_t* row = w.rows[dv + R];
    if (row == nullptr) continue;
    for (int du = -R; du <= R; ++du) {
      if (du == 0 && dv == 0) continue;
      const hn::Vec<D> ring_t = t[std::max(std::abs(du), std::abs(dv)) - 1];
      const hn::Vec<D> y = hn::LoadU(d, row + u + du);
      const auto miss =
          hn::Or(hn::Eq(hn::SaturatedSub(absDiff(d, x, y), ring_t), zero), hn::Eq(y, zero));
      misses = hn::Add(misses, hn::IfThenElseZero(miss, one));
    }
  }
  const hn::Vec<D> count = hn::Sub(hn::Set(d, static_cast<std::uint16_t>(w.offsets)), misses);
  const hn::Vec<D> out = hn::IfThenElse(hn::Eq(x, zero), hn::Set(d, kNoDepth), count);
  const hn::RebindToSigned<D> di;
  const hn::Rebind<std::uint8_t, D> d8;
  hn::StoreU(hn::DemoteTo(d8, hn::BitCast(di, out)), d8, e + u);
}

/// countDepthSteps for one pixel, any column.
std::uint8_t countPixel(const std::uint16_t* centre, const StepWindow& w, int u, int cols) {
  const int r = w.radius;
  const std::uint16_t x = centre[u];
  int count = 0;
  for (int dv = -r; dv <= r; ++dv) {
    const std::uint16_t* row = w.rows[dv + r];
    if (row == nullptr) continue;
    for (int du = -r; du <= r; ++du) {
      const int uq = u + du;
      if ((du == 0 && dv == 0) || uq < 0 || uq >= cols) continue;
      const std::uint16_t y = row[uq];
      const std::uint16_t diff = x > y ? x - y : y - x;
      const int ring = std::max(std::abs(du), std::abs(dv));
      count += (y != 0) & (diff > w.thresholds[ring - 1][u]);
    }
  }
  return x == 0 ? kNoDepth : static_cast<std::uint8_t>(count);
}

template <int R>
void countVectorColumns(const std::uint16_t* centre, const StepWindow& w, int begin, int end,
                        std::uint8_t* e) {
  const hn::ScalableTag<std::uint16_t> d;
  const int n = static_cast<int>(hn::Lanes(d));
  // The last block overlaps the one before: the same values are written twice.
  for (int u = begin;; u += n) {
    u = std::min(u, end - n);
    countBlock<R>(d, centre, w, u, e);
    if (u == end - n) break;
  }
}

void CountDepthSteps(const std::uint16_t* centre, const StepWindow& w, int cols,
                     std::uint8_t* edges) {
  const int r = w.radius;
  const int n = static_cast<int>(hn::Lanes(hn::ScalableTag<std::uint16_t>()));
  // Columns whose window row lies inside the image go a vector at a time, the first and last
  // r one at a time.
  int begin = 0, end = 0;
  if (cols - 2 * r >= n) {
    begin = r;
    end = cols - r;
    switch (r) {
      case 1:
        countVectorColumns<1>(centre, w, begin, end, edges);
        break;
      case 2:
        countVectorColumns<2>(centre, w, begin, end, edges);
        break;
      case 3:
        countVectorColumns<3>(centre, w, begin, end, edges);
        break;
      case 4:
        countVectorColumns<4>(centre, w, begin, end, edges);
        break;
      case 5:
        countVectorColumns<5>(centre, w, begin, end, edges);
        break;
      case 6:
        countVectorColumns<6>(centre, w, begin, end, edges);
        break;
      default:
        countVectorColumns<7>(centre, w, begin, end, edges);
        break;
    }
  }
  for (int u = 0; u < begin; ++u) edges[u] = countPixel(centre, w, u, cols);
  for (int u = std::max(end, begin); u < cols; ++u) edges[u] = countPixel(centre, w, u, cols);
}

// ---------------------------------------------------------------------------------------------
// 2x2 reduction

/// reduceBlock for the Lanes(d32) output pixels from u, in 32-bit lanes: the same integer
/// steps, the same float products for the limit, and the rounded mean as a float division,
/// which is exact here (sum < 2^19 and n <= 4: the quotient never rounds to the next integer).
template <class D32>
void reduceBlocks(D32 d32, const std::uint16_t* a, const std::uint16_t* b, int u, float k,
                  std::uint16_t* out) {
  using V = hn::Vec<D32>;
  const hn::Repartition<std::uint16_t, D32> d16;
  const hn::RebindToSigned<D32> di;
  const hn::Rebind<float, D32> df;
  const hn::Rebind<std::uint16_t, D32> d16_out;
  const V low16 = hn::Set(d32, 0xFFFF), zero = hn::Zero(d32), one = hn::Set(d32, 1);
  const V ra = hn::BitCast(d32, hn::LoadU(d16, a + 2 * u));
  const V rb = hn::BitCast(d32, hn::LoadU(d16, b + 2 * u));
  const V q[4] = {hn::And(ra, low16), hn::ShiftRight<16>(ra), hn::And(rb, low16),
                  hn::ShiftRight<16>(rb)};
  V nearest = low16;  // as reduceBlock: 0xFFFF means no reading below it
  for (const V& x : q) nearest = hn::Min(nearest, hn::IfThenElse(hn::Eq(x, zero), low16, x));
  const auto nf = hn::ConvertTo(df, hn::BitCast(di, nearest));
  const V limit = hn::Add(
      hn::Add(nearest,
              hn::BitCast(d32, hn::ConvertTo(di, hn::Mul(hn::Mul(hn::Set(df, k), nf), nf)))),
      one);
  V sum = zero, n = zero;
  for (const V& x : q) {
    const auto out_of_block = hn::Or(hn::Eq(x, zero), hn::Gt(x, limit));
    sum = hn::Add(sum, hn::IfThenZeroElse(out_of_block, x));
    n = hn::Add(n, hn::IfThenZeroElse(out_of_block, one));
  }
  // Where the block has no reading n = 0; divided by 1 instead, and the result set to 0.
  const auto mean = hn::Div(hn::ConvertTo(df, hn::BitCast(di, hn::Add(sum, hn::ShiftRight<1>(n)))),
                            hn::ConvertTo(df, hn::BitCast(di, hn::Max(n, one))));
  const auto value = hn::IfThenZeroElse(hn::Eq(hn::BitCast(di, nearest), hn::BitCast(di, low16)),
                                        hn::ConvertTo(di, mean));
  hn::StoreU(hn::DemoteTo(d16_out, value), d16_out, out + u);
}

void ReduceRow(const std::uint16_t* a, const std::uint16_t* b, int cols, float k,
               std::uint16_t* out) {
  int u = 0;
#if HWY_TARGET != HWY_SCALAR  // a 32-bit lane holds two 16-bit ones
  const hn::ScalableTag<std::uint32_t> d32;
  const int n = static_cast<int>(hn::Lanes(d32));
  for (; u + n <= cols; u += n) reduceBlocks(d32, a, b, u, k, out);
#endif
  for (; u < cols; ++u) {
    const std::uint16_t q[4] = {a[2 * u], a[2 * u + 1], b[2 * u], b[2 * u + 1]};
    out[u] = reduceBlock(q, k);
  }
}

// ---------------------------------------------------------------------------------------------
// Flood seeds

void seedPixel(const std::int32_t* L, const std::uint8_t* E, int rows, int cols, int v, int u,
               std::array<std::vector<int>, 256>& buckets) {
  const int i = v * cols + u;
  if (L[i] <= 0) return;
  const bool border = (u > 0 && L[i - 1] <= 0) || (u + 1 < cols && L[i + 1] <= 0) ||
                      (v > 0 && L[i - cols] <= 0) || (v + 1 < rows && L[i + cols] <= 0);
  if (border) buckets[E[i]].push_back(i);
}

void CollectFloodSeeds(const std::int32_t* L, const std::uint8_t* E, int rows, int cols,
                       std::array<std::vector<int>, 256>& buckets) {
  const hn::ScalableTag<std::int32_t> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto one = hn::Set(d, 1), zero = hn::Zero(d);
  for (int v = 0; v < rows; ++v) {
    int u = 0;
    // Inside the image's border, a vector of pixels per step: most are interior marker pixels
    // or unlabelled, so the set bits are few.
    if (v > 0 && v + 1 < rows && cols > 2) {
      seedPixel(L, E, rows, cols, v, 0, buckets);
      for (u = 1; u + n + 1 <= cols; u += n) {  // pixels u..u+n-1 and their right neighbours
        const int i = v * cols + u;
        const auto unlabelled_neighbour = hn::Or(
            hn::Or(hn::Lt(hn::LoadU(d, L + i - 1), one), hn::Lt(hn::LoadU(d, L + i + 1), one)),
            hn::Or(hn::Lt(hn::LoadU(d, L + i - cols), one),
                   hn::Lt(hn::LoadU(d, L + i + cols), one)));
        const auto border = hn::And(hn::Gt(hn::LoadU(d, L + i), zero), unlabelled_neighbour);
        if (hn::AllFalse(d, border)) continue;
        std::uint8_t bytes[8] = {};
        hn::StoreMaskBits(d, border, bytes);
        std::uint64_t bits;
        std::memcpy(&bits, bytes, sizeof bits);
        for (; bits != 0; bits &= bits - 1) {
          const int j = i + __builtin_ctzll(bits);
          buckets[E[j]].push_back(j);
        }
      }
    }
    for (; u < cols; ++u) seedPixel(L, E, rows, cols, v, u, buckets);
  }
}

// ---------------------------------------------------------------------------------------------
// Upsampling

void ExpandBlockRow(const std::uint16_t* l, const std::uint16_t* dc, int working_cols, int cols,
                    float k, std::uint16_t* lab2, std::uint16_t* dep2, std::uint16_t* tol2) {
  int u = 0;
#if HWY_TARGET != HWY_SCALAR  // a 32-bit lane holds two 16-bit ones
  const hn::ScalableTag<std::uint16_t> d16;
  const hn::Repartition<std::uint32_t, decltype(d16)> d32;
  const hn::Rebind<std::uint16_t, decltype(d32)> d16_half;
  const hn::RebindToSigned<decltype(d32)> di;
  const hn::Rebind<float, decltype(d32)> df;
  const int n = static_cast<int>(hn::Lanes(d16));
  // Each 32-bit lane x | x << 16 is the 16-bit lanes x x.
  auto twice = [&](hn::Vec<decltype(d32)> x) {
    return hn::BitCast(d16, hn::Or(x, hn::ShiftLeft<16>(x)));
  };
  const auto kv = hn::Set(df, k), two = hn::Set(df, 2.0f), max16 = hn::Set(df, 65535.0f);
  for (; u + n <= cols && (u >> 1) + n / 2 <= working_cols; u += n) {
    const int uc = u >> 1;
    const auto z32 = hn::PromoteTo(d32, hn::LoadU(d16_half, dc + uc));
    const auto z = hn::ConvertTo(df, hn::BitCast(di, z32));
    const auto t = hn::Min(hn::Add(hn::Mul(hn::Mul(kv, z), z), two), max16);
    hn::StoreU(twice(hn::PromoteTo(d32, hn::LoadU(d16_half, l + uc))), d16, lab2 + u);
    hn::StoreU(twice(z32), d16, dep2 + u);
    hn::StoreU(twice(hn::BitCast(d32, hn::ConvertTo(di, t))), d16, tol2 + u);
  }
#endif
  for (; u < cols; u += 2) {
    const int uc = std::min(u >> 1, working_cols - 1);
    const std::uint16_t t = blockTolerance(k, dc[uc]);
    const int pixels = std::min(2, cols - u);
    for (int i = 0; i < pixels; ++i) {
      lab2[u + i] = l[uc];
      dep2[u + i] = dc[uc];
      tol2[u + i] = t;
    }
  }
}

bool LabelFullRow(const std::uint16_t* d, const std::uint16_t* lab2, const std::uint16_t* dep2,
                  const std::uint16_t* tol2, int cols, std::uint16_t* o, std::uint8_t* bad) {
  const hn::ScalableTag<std::uint16_t> d16;
  const hn::RebindToSigned<decltype(d16)> di16;
  const hn::Rebind<std::uint8_t, decltype(d16)> d8;
  const int n = static_cast<int>(hn::Lanes(d16));
  const auto zero = hn::Zero(d16), one = hn::Set(d16, 1);
  bool any_bad = false;
  int u = 0;
  for (; u + n <= cols; u += n) {
    const auto z = hn::LoadU(d16, d + u), c = hn::LoadU(d16, dep2 + u);
    const auto no_depth = hn::Eq(z, zero);
    const auto within =
        hn::Eq(hn::SaturatedSub(absDiff(d16, z, c), hn::LoadU(d16, tol2 + u)), zero);
    hn::StoreU(hn::IfThenZeroElse(no_depth, hn::LoadU(d16, lab2 + u)), d16, o + u);
    const auto is_bad = hn::Not(hn::Or(no_depth, within));
    hn::StoreU(hn::DemoteTo(d8, hn::BitCast(di16, hn::IfThenElseZero(is_bad, one))), d8, bad + u);
    any_bad |= !hn::AllFalse(d16, is_bad);
  }
  for (; u < cols; ++u) {
    const std::uint16_t z = d[u], c = dep2[u];
    const std::uint16_t diff = static_cast<std::uint16_t>(z > c ? z - c : c - z);
    o[u] = z != 0 ? lab2[u] : 0;
    bad[u] = static_cast<std::uint8_t>(z != 0 && diff > tol2[u]);
    any_bad |= bad[u] != 0;
  }
  return any_bad;
}

// ---------------------------------------------------------------------------------------------
// Plane prediction

void InverseDepthGradientRow(const float* up, const float* row, const float* down, int g, int cols,
                             float* gx, float* gy) {
  std::fill(gx, gx + cols, 0.0f);
  std::fill(gy, gy + cols, 0.0f);
  int u = g;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto zero = hn::Zero(df), span = hn::Set(df, static_cast<float>(g)),
             two_spans = hn::Set(df, 2.0f * static_cast<float>(g));
  // inverseDepthSlope, every branch computed and the applicable one kept.
  const auto slope = [&](auto before, auto centre, auto after) {
    const auto has_before = hn::Gt(before, zero), has_after = hn::Gt(after, zero),
               has_centre = hn::Gt(centre, zero);
    const auto central = hn::Div(hn::Sub(after, before), two_spans);
    const auto backward = hn::Div(hn::Sub(centre, before), span);
    const auto forward = hn::Div(hn::Sub(after, centre), span);
    return hn::IfThenElse(
        hn::And(has_before, has_after), central,
        hn::IfThenElse(hn::And(has_before, has_centre), backward,
                       hn::IfThenElseZero(hn::And(has_after, has_centre), forward)));
  };
  for (; u + lanes <= cols - g; u += lanes) {
    const auto centre = hn::LoadU(df, row + u);
    hn::StoreU(slope(hn::LoadU(df, row + u - g), centre, hn::LoadU(df, row + u + g)), df, gx + u);
    hn::StoreU(
        slope(up ? hn::LoadU(df, up + u) : zero, centre, down ? hn::LoadU(df, down + u) : zero), df,
        gy + u);
  }
#endif
  for (; u < cols - g; ++u) {
    gx[u] = inverseDepthSlope(row[u - g], row[u], row[u + g], g);
    gy[u] = inverseDepthSlope(up ? up[u] : 0.0f, row[u], down ? down[u] : 0.0f, g);
  }
}

void PredictionEdgesRow(const float* inverse, const float* smoothed, const float* gx,
                        const float* gy, const PredictionNeighbour* neighbours, int count, int cols,
                        std::uint8_t* edges, std::uint8_t* short_edges) {
  int short_end = 0;
  while (short_end < count && !neighbours[short_end].long_range) ++short_end;
  int u = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint8_t, decltype(df)> d8;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto zero = hn::Zero(df);
  const auto no_depth = hn::Set(di, kNoDepth);
  for (; u + lanes <= cols; u += lanes) {
    const auto reading = hn::LoadU(df, inverse + u), smooth = hn::LoadU(df, smoothed + u);
    const auto c = hn::IfThenElse(hn::Gt(smooth, zero), smooth, reading);
    const auto g_x = hn::LoadU(df, gx + u), g_y = hn::LoadU(df, gy + u);
    auto along_v = c;
    // Anomalies of neighbours [begin, end), as a negative count (a mask lane is all ones: -1 as
    // an integer, so adding it counts down).
    const auto count_anomalies = [&](int begin, int end) {
      auto negative_count = hn::Zero(di);
      for (int k = begin; k < end; ++k) {
        const PredictionNeighbour& q = neighbours[k];
        // As the scalar rule: multiplies and adds apart, in its order.
        if (k == 0 || q.dv != neighbours[k - 1].dv)
          along_v = hn::Add(c, hn::Mul(g_y, hn::Set(df, static_cast<float>(q.dv))));
        const auto predicted =
            hn::Add(along_v, hn::Mul(g_x, hn::Set(df, static_cast<float>(q.du))));
        const auto y = hn::LoadU(df, q.row + u + q.du);
        const auto anomaly = hn::Gt(hn::Abs(hn::Sub(y, predicted)), hn::Set(df, q.threshold));
        negative_count = hn::Add(negative_count, hn::BitCast(di, hn::VecFromMask(df, anomaly)));
      }
      return hn::Neg(negative_count);
    };
    const auto short_count = count_anomalies(0, short_end);
    const auto all_count = hn::Add(short_count, count_anomalies(short_end, count));
    const auto without_depth = hn::RebindMask(di, hn::Eq(reading, zero));
    hn::StoreU(hn::DemoteTo(d8, hn::IfThenElse(without_depth, no_depth, all_count)), d8, edges + u);
    if (short_edges)
      hn::StoreU(hn::DemoteTo(d8, hn::IfThenElse(without_depth, no_depth, short_count)), d8,
                 short_edges + u);
  }
#endif
  for (; u < cols; ++u) {
    const float c = smoothed[u] > 0.0f ? smoothed[u] : inverse[u];
    int short_count = 0, long_count = 0;
    for (int k = 0; k < count; ++k) {
      const PredictionNeighbour& q = neighbours[k];
      const bool anomaly =
          predictionAnomaly(c, gx[u], gy[u], q.row[u + q.du], static_cast<float>(q.du),
                            static_cast<float>(q.dv), q.threshold);
      (k < short_end ? short_count : long_count) += anomaly;
    }
    const bool without_depth = inverse[u] == 0.0f;
    edges[u] = without_depth ? kNoDepth : static_cast<std::uint8_t>(short_count + long_count);
    if (short_edges)
      short_edges[u] = without_depth ? kNoDepth : static_cast<std::uint8_t>(short_count);
  }
}

// ---------------------------------------------------------------------------------------------
// Planes over object regions

void OverlayObjectsRow(const std::uint16_t* depth, const std::uint16_t* plane,
                       const std::uint16_t* object, int plane_count, int cols, std::int32_t* out) {
  int u = 0;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<std::int32_t> di;
  const hn::Rebind<std::uint16_t, decltype(di)> d16;
  const int lanes = static_cast<int>(hn::Lanes(di));
  const auto zero = hn::Zero(di), offset = hn::Set(di, plane_count);
  for (; u + lanes <= cols; u += lanes) {
    const auto z = hn::PromoteTo(di, hn::LoadU(d16, depth + u));
    const auto p = hn::PromoteTo(di, hn::LoadU(d16, plane + u));
    const auto o = hn::PromoteTo(di, hn::LoadU(d16, object + u));
    const auto is_object = hn::And(hn::Ne(z, zero), hn::Ne(o, zero));
    const auto below = hn::IfThenElseZero(is_object, hn::Add(offset, o));
    hn::StoreU(hn::IfThenElse(hn::Ne(p, zero), p, below), di, out + u);
  }
#endif
  for (; u < cols; ++u)
    out[u] = plane[u] ? plane[u] : (depth[u] && object[u] ? plane_count + object[u] : 0);
}

// ---------------------------------------------------------------------------------------------
// Uniform label windows

void UniformLabelRow(const std::int32_t* above, const std::int32_t* row, const std::int32_t* below,
                     int cols, std::uint8_t* out) {
  if (cols <= 0) return;
  out[0] = 0;
  int u = 1;
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<std::int32_t> di;
  const hn::Rebind<std::uint8_t, decltype(di)> d8;
  const int lanes = static_cast<int>(hn::Lanes(di));
  const auto all_ones = hn::Set(di, 255);
  for (; u + lanes + 1 <= cols; u += lanes) {
    const auto centre = hn::LoadU(di, row + u);
    auto same = hn::Eq(hn::LoadU(di, row + u - 1), centre);
    same = hn::And(same, hn::Eq(hn::LoadU(di, row + u + 1), centre));
    for (const std::int32_t* r : {above, below})
      for (int du = -1; du <= 1; ++du)
        same = hn::And(same, hn::Eq(hn::LoadU(di, r + u + du), centre));
    hn::StoreU(hn::DemoteTo(d8, hn::IfThenElseZero(same, all_ones)), d8, out + u);
  }
#endif
  for (; u + 1 < cols; ++u) {
    const std::int32_t c = row[u];
    bool same = true;
    for (int du = -1; du <= 1; ++du)
      same = same & (above[u + du] == c) & (row[u + du] == c) & (below[u + du] == c);
    out[u] = same ? 255 : 0;
  }
  if (cols > 1) out[cols - 1] = 0;
}

// ---------------------------------------------------------------------------------------------
// Label runs

void LabelRuns(const std::int32_t* row, int cols, std::vector<LabelRun>& runs) {
  runs.clear();
#if HWY_TARGET != HWY_SCALAR
  const hn::ScalableTag<std::int32_t> di;
  const int lanes = static_cast<int>(hn::Lanes(di));
#endif
  int u = 0;
  while (u < cols) {
    const std::int32_t label = row[u];
    int end = u + 1;
    bool found = false;
#if HWY_TARGET != HWY_SCALAR
    // Regions are wide: a whole vector of the same label is the common case.
    const auto same = hn::Set(di, label);
    for (; end + lanes <= cols; end += lanes) {
      const intptr_t other = hn::FindFirstTrue(di, hn::Ne(hn::LoadU(di, row + end), same));
      if (other >= 0) {
        end += static_cast<int>(other);
        found = true;
        break;
      }
    }
#endif
    if (!found)
      while (end < cols && row[end] == label) ++end;
    runs.push_back({u, end, label});
    u = end;
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::segmentation
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::segmentation {

HWY_EXPORT(CountDepthSteps);
HWY_EXPORT(ReduceRow);
HWY_EXPORT(CollectFloodSeeds);
HWY_EXPORT(ExpandBlockRow);
HWY_EXPORT(LabelFullRow);
HWY_EXPORT(InverseDepthGradientRow);
HWY_EXPORT(PredictionEdgesRow);
HWY_EXPORT(OverlayObjectsRow);
HWY_EXPORT(UniformLabelRow);
HWY_EXPORT(LabelRuns);

void countDepthSteps(const std::uint16_t* centre, const StepWindow& window, int cols,
                     std::uint8_t* edges) {
  HWY_DYNAMIC_DISPATCH(CountDepthSteps)(centre, window, cols, edges);
}

void reduceRow(const std::uint16_t* a, const std::uint16_t* b, int cols, float k,
               std::uint16_t* out) {
  HWY_DYNAMIC_DISPATCH(ReduceRow)(a, b, cols, k, out);
}

void collectFloodSeeds(const std::int32_t* labels, const std::uint8_t* edges, int rows, int cols,
                       std::array<std::vector<int>, 256>& buckets) {
  HWY_DYNAMIC_DISPATCH(CollectFloodSeeds)(labels, edges, rows, cols, buckets);
}

void expandBlockRow(const std::uint16_t* labels, const std::uint16_t* depth, int working_cols,
                    int cols, float k, std::uint16_t* labels2, std::uint16_t* depth2,
                    std::uint16_t* tolerance2) {
  HWY_DYNAMIC_DISPATCH(ExpandBlockRow)
  (labels, depth, working_cols, cols, k, labels2, depth2, tolerance2);
}

bool labelFullRow(const std::uint16_t* depth, const std::uint16_t* labels2,
                  const std::uint16_t* depth2, const std::uint16_t* tolerance2, int cols,
                  std::uint16_t* out, std::uint8_t* bad) {
  return HWY_DYNAMIC_DISPATCH(LabelFullRow)(depth, labels2, depth2, tolerance2, cols, out, bad);
}

void inverseDepthGradientRow(const float* up, const float* row, const float* down, int g, int cols,
                             float* gx, float* gy) {
  HWY_DYNAMIC_DISPATCH(InverseDepthGradientRow)(up, row, down, g, cols, gx, gy);
}

void predictionEdgesRow(const float* inverse, const float* smoothed, const float* gx,
                        const float* gy, const PredictionNeighbour* neighbours, int count, int cols,
                        std::uint8_t* edges, std::uint8_t* short_edges) {
  HWY_DYNAMIC_DISPATCH(PredictionEdgesRow)
  (inverse, smoothed, gx, gy, neighbours, count, cols, edges, short_edges);
}

void uniformLabelRow(const std::int32_t* above, const std::int32_t* row, const std::int32_t* below,
                     int cols, std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(UniformLabelRow)(above, row, below, cols, out);
}

void overlayObjectsRow(const std::uint16_t* depth, const std::uint16_t* plane,
                       const std::uint16_t* object, int plane_count, int cols, std::int32_t* out) {
  HWY_DYNAMIC_DISPATCH(OverlayObjectsRow)(depth, plane, object, plane_count, cols, out);
}

void labelRuns(const std::int32_t* row, int cols, std::vector<LabelRun>& runs) {
  HWY_DYNAMIC_DISPATCH(LabelRuns)(row, cols, runs);
}

}  // namespace shapesense::segmentation
#endif  // HWY_ONCE
