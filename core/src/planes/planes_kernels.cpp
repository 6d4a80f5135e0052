// Highway kernels of plane detection and labelling (see planes_kernels.h), compiled once per
// SIMD target. Each kernel's vector loop is followed by the same expression in scalar form for
// the last pixels or points.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "planes/planes_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "planes/planes_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace shapesense::planes_kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Eight floats at most: the per-sample and per-pixel loops run over short stretches (runs of a
// row, candidate sets), where wider registers leave more of the work to the last partial step.
using DF = hn::CappedTag<float, 8>;
using DI = hn::RebindToSigned<DF>;
using DU8 = hn::Rebind<std::uint8_t, DF>;
using DU16 = hn::Rebind<std::uint16_t, DF>;

// Flags 0 / 1 of a mask, one byte per lane.
HWY_INLINE hn::Vec<DU8> MaskBytes(hn::Mask<DF> m) {
  const DI di;
  return hn::DemoteTo(DU8(), hn::IfThenElseZero(hn::RebindMask(di, m), hn::Set(di, 1)));
}

// Depths in metres of lanes u.. of a row, as static_cast<float>(depth) * 0.001f.
HWY_INLINE hn::Vec<DF> DepthMetres(const std::uint16_t* depth_mm) {
  const DF df;
  const hn::Vec<DI> mm = hn::PromoteTo(DI(), hn::LoadU(DU16(), depth_mm));
  return hn::Mul(hn::ConvertTo(df, mm), hn::Set(df, 0.001f));
}

void GateFlags(const PlaneGates& g, const SampleArrays& a, const std::uint8_t* alive,
               std::uint8_t* in, int count) {
  const DF d;
  const DU8 du8;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const auto px = hn::Set(d, g.nx), py = hn::Set(d, g.ny), pz = hn::Set(d, g.nz),
             pd = hn::Set(d, g.d), mult = hn::Set(d, g.gate_mult), cos_n = hn::Set(d, g.cos_normal);
  const bool unit_gate = g.gate_mult == 1.0f;  // 1 x the tolerance is the tolerance itself
  int k = 0;
  for (; k + lanes <= count; k += lanes) {
    const auto dot = hn::Add(
        hn::Add(hn::Add(hn::Mul(px, hn::LoadU(d, a.x + k)), hn::Mul(py, hn::LoadU(d, a.y + k))),
                hn::Mul(pz, hn::LoadU(d, a.z + k))),
        pd);
    const auto tol = hn::LoadU(d, a.tol + k);
    const auto within = hn::Le(hn::Abs(dot), unit_gate ? tol : hn::Mul(mult, tol));
    const auto agree = hn::Ge(
        hn::Add(hn::Add(hn::Mul(px, hn::LoadU(d, a.nx + k)), hn::Mul(py, hn::LoadU(d, a.ny + k))),
                hn::Mul(pz, hn::LoadU(d, a.nz + k))),
        cos_n);
    auto flags = MaskBytes(hn::And(within, agree));
    if (alive != nullptr) flags = hn::And(flags, hn::LoadU(du8, alive + k));
    hn::StoreU(flags, du8, in + k);
  }
  for (; k < count; ++k) {
    const float dist = std::fabs(g.nx * a.x[k] + g.ny * a.y[k] + g.nz * a.z[k] + g.d);
    const bool within = dist <= (unit_gate ? a.tol[k] : g.gate_mult * a.tol[k]);
    const bool agree = g.nx * a.nx[k] + g.ny * a.ny[k] + g.nz * a.nz[k] >= g.cos_normal;
    in[k] = static_cast<std::uint8_t>((alive == nullptr || alive[k]) && within && agree);
  }
}

void NormalAgreement(const float* normals, int offset, float cos_max, int begin, int end,
                     std::uint8_t* agree) {
  const DF d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const float* m = normals + 3 * offset;
  const auto cos_v = hn::Set(d, cos_max);
  int i = begin;
  for (; i + lanes <= end; i += lanes) {
    hn::Vec<DF> ax, ay, az, bx, by, bz;
    hn::LoadInterleaved3(d, normals + 3 * i, ax, ay, az);
    hn::LoadInterleaved3(d, m + 3 * i, bx, by, bz);
    const auto dot = hn::Add(hn::Add(hn::Mul(ax, bx), hn::Mul(ay, by)), hn::Mul(az, bz));
    hn::StoreU(MaskBytes(hn::Ge(dot, cos_v)), DU8(), agree + i);
  }
  for (; i < end; ++i)
    agree[i] =
        static_cast<std::uint8_t>(normals[3 * i] * m[3 * i] + normals[3 * i + 1] * m[3 * i + 1] +
                                      normals[3 * i + 2] * m[3 * i + 2] >=
                                  cos_max);
}

std::size_t CountWithin(double nx, double ny, double nz, double d, const double* x, const double* y,
                        const double* z, const double* tol, std::size_t n) {
  const hn::ScalableTag<double> dd;
  const std::size_t lanes = hn::Lanes(dd);
  const auto vnx = hn::Set(dd, nx), vny = hn::Set(dd, ny), vnz = hn::Set(dd, nz),
             vd = hn::Set(dd, d);
  std::size_t count = 0, k = 0;
  for (; k + lanes <= n; k += lanes) {
    const auto dot = hn::Add(
        hn::Add(hn::Add(hn::Mul(vnx, hn::LoadU(dd, x + k)), hn::Mul(vny, hn::LoadU(dd, y + k))),
                hn::Mul(vnz, hn::LoadU(dd, z + k))),
        vd);
    count += hn::CountTrue(dd, hn::Le(hn::Abs(dot), hn::LoadU(dd, tol + k)));
  }
  for (; k < n; ++k) count += std::fabs(nx * x[k] + ny * y[k] + nz * z[k] + d) <= tol[k];
  return count;
}

void SampleRowPoints(const std::uint16_t* depth_mm, const float* rx, float ry, int cols,
                     float* points) {
  const DF d;
  const DI di;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const auto vry = hn::Set(d, ry), nan = hn::Set(d, std::numeric_limits<float>::quiet_NaN());
  int c = 0;
  for (; c + lanes <= cols; c += lanes) {
    const auto mm = hn::PromoteTo(di, hn::LoadU(DU16(), depth_mm + c));
    const auto z = hn::Mul(hn::ConvertTo(d, mm), hn::Set(d, 0.001f));
    const auto valid = hn::RebindMask(d, hn::Gt(mm, hn::Zero(di)));
    hn::StoreInterleaved3(hn::IfThenElse(valid, hn::Mul(hn::LoadU(d, rx + c), z), nan),
                          hn::IfThenElse(valid, hn::Mul(vry, z), nan),
                          hn::IfThenElse(valid, z, nan), d, points + 3 * c);
  }
  for (; c < cols; ++c) {
    const bool valid = depth_mm[c] != 0;
    const float z = static_cast<float>(depth_mm[c]) * 0.001f;
    const float q = std::numeric_limits<float>::quiet_NaN();
    points[3 * c] = valid ? rx[c] * z : q;
    points[3 * c + 1] = valid ? ry * z : q;
    points[3 * c + 2] = valid ? z : q;
  }
}

// |z ((a u + bv) + c) + d| of one plane, for lanes of columns fu and depths z.
HWY_INLINE hn::Vec<DF> PixelDistance(hn::Vec<DF> z, hn::Vec<DF> fu, const PixelPlane& p) {
  const DF d;
  const auto bracket =
      hn::Add(hn::Add(hn::Mul(hn::Set(d, p.a), fu), hn::Set(d, p.bv)), hn::Set(d, p.c));
  return hn::Abs(hn::Add(hn::Mul(z, bracket), hn::Set(d, p.d)));
}

float ScalarPixelDistance(float z, float fu, const PixelPlane& p) {
  return std::fabs(z * (p.a * fu + p.bv + p.c) + p.d);
}

// The vector loop of both labelling kernels over pixels [u0, u1) of a row of `cols` pixels:
// step(w, counted) returns the labels of pixels w.. (32-bit lanes) and counts those of the lanes
// in `counted`. Whole registers first; the rest of the run, when the row holds a register's
// worth of pixels, as one register ending at the run's end or the row's end: its lanes outside
// the run are stored back as they were read (lanes before the run were written earlier in the
// row, lanes past it are written later: the runs of a row go left to right). Returns the first
// pixel left for the scalar loop (u1 when none).
template <class Step>
HWY_INLINE int LabelRunSteps(std::uint16_t* label_row, int cols, int u0, int u1, Step&& step) {
  const DI di;
  const DU16 du16;
  const int lanes = static_cast<int>(hn::Lanes(di));
  int u = u0;
  for (; u + lanes <= u1; u += lanes)
    hn::StoreU(hn::DemoteTo(du16, step(u, hn::FirstN(di, lanes))), du16, label_row + u);
  if (u == u1 || cols < lanes) return u;
  const int w = std::min(u, cols - lanes);
  const auto column = hn::Iota(di, w);
  const auto in_run = hn::And(hn::Gt(column, hn::Set(di, u - 1)), hn::Lt(column, hn::Set(di, u1)));
  const auto kept = hn::PromoteTo(di, hn::LoadU(du16, label_row + w));
  hn::StoreU(hn::DemoteTo(du16, hn::IfThenElse(in_run, step(w, in_run), kept)), du16,
             label_row + w);
  return u1;
}

int LabelSingleCandidateRun(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols,
                            int u0, int u1, const PixelPlane& plane, float tol_floor,
                            std::uint16_t label) {
  const DF d;
  const DI di;
  const auto coef = hn::Set(d, plane.tol_coef), floor = hn::Set(d, tol_floor);
  const auto vlabel = hn::Set(di, label);
  int n = 0;
  auto step = [&](int w, hn::Mask<DI> counted) {
    const auto z = DepthMetres(depth_row + w);
    const auto fu = hn::Iota(d, static_cast<float>(w));  // exact: columns are small integers
    const auto tol = hn::Max(hn::Mul(coef, hn::Mul(z, z)), floor);
    const auto inside = hn::RebindMask(
        di, hn::And(hn::Ne(z, hn::Zero(d)), hn::Le(PixelDistance(z, fu, plane), tol)));
    n += static_cast<int>(hn::CountTrue(di, hn::And(inside, counted)));
    return hn::IfThenElseZero(inside, vlabel);
  };
  for (int u = LabelRunSteps(label_row, cols, u0, u1, step); u < u1; ++u) {
    const float z = static_cast<float>(depth_row[u]) * 0.001f;
    const float dd = ScalarPixelDistance(z, static_cast<float>(u), plane);
    const int inside = static_cast<int>(depth_row[u] != 0) &
                       static_cast<int>(dd <= std::max(tol_floor, plane.tol_coef * (z * z)));
    label_row[u] = static_cast<std::uint16_t>(label * inside);
    n += inside;
  }
  return n;
}

template <int K>
void LabelCandidatesRunK(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols, int u0,
                         int u1, const PixelPlane* planes, const std::uint16_t* labels,
                         float tol_floor, int* counts) {
  const DF d;
  const DI di;
  const auto floor = hn::Set(d, tol_floor), far = hn::Set(d, std::numeric_limits<float>::max());
  int n[K] = {};
  auto step = [&](int w, hn::Mask<DI> counted) {
    const auto z = DepthMetres(depth_row + w);
    const auto fu = hn::Iota(d, static_cast<float>(w));
    const auto z2 = hn::Mul(z, z);
    auto best = far;
    auto best_label = hn::Zero(di);
    for (int k = 0; k < K; ++k) {
      const auto dd = PixelDistance(z, fu, planes[k]);
      const auto tol = hn::Max(hn::Mul(hn::Set(d, planes[k].tol_coef), z2), floor);
      const auto take = hn::And(hn::Le(dd, best), hn::Le(dd, tol));
      best = hn::IfThenElse(take, dd, best);
      best_label = hn::IfThenElse(hn::RebindMask(di, take), hn::Set(di, labels[k]), best_label);
    }
    const auto out = hn::IfThenElseZero(hn::RebindMask(di, hn::Ne(z, hn::Zero(d))), best_label);
    for (int k = 0; k < K; ++k)
      n[k] += static_cast<int>(
          hn::CountTrue(di, hn::And(hn::Eq(out, hn::Set(di, labels[k])), counted)));
    return out;
  };
  for (int u = LabelRunSteps(label_row, cols, u0, u1, step); u < u1; ++u) {
    const float z = static_cast<float>(depth_row[u]) * 0.001f;
    const float fu = static_cast<float>(u), z2 = z * z;
    float best = std::numeric_limits<float>::max();
    std::uint16_t best_label = 0;
    for (int k = 0; k < K; ++k) {
      const float dd = ScalarPixelDistance(z, fu, planes[k]);
      const bool take = (dd <= best) & (dd <= std::max(tol_floor, planes[k].tol_coef * z2));
      best = take ? dd : best;
      best_label = take ? labels[k] : best_label;
    }
    const auto out = static_cast<std::uint16_t>(best_label * (depth_row[u] != 0));
    label_row[u] = out;
    for (int k = 0; k < K; ++k) n[k] += out == labels[k];
  }
  for (int k = 0; k < K; ++k) counts[k] += n[k];
}

void LabelCandidatesRun(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols, int u0,
                        int u1, const PixelPlane* planes, const std::uint16_t* labels, int k,
                        float tol_floor, int* counts) {
  if (k == 2)
    LabelCandidatesRunK<2>(depth_row, label_row, cols, u0, u1, planes, labels, tol_floor, counts);
  else if (k == 3)
    LabelCandidatesRunK<3>(depth_row, label_row, cols, u0, u1, planes, labels, tol_floor, counts);
  else
    LabelCandidatesRunK<4>(depth_row, label_row, cols, u0, u1, planes, labels, tol_floor, counts);
}

}  // namespace HWY_NAMESPACE
}  // namespace shapesense::planes_kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace shapesense::planes_kernels {

HWY_EXPORT(GateFlags);
HWY_EXPORT(NormalAgreement);
HWY_EXPORT(CountWithin);
HWY_EXPORT(SampleRowPoints);
HWY_EXPORT(LabelSingleCandidateRun);
HWY_EXPORT(LabelCandidatesRun);

void gateFlags(const PlaneGates& gates, const SampleArrays& samples, const std::uint8_t* alive,
               std::uint8_t* in, int count) {
  HWY_DYNAMIC_DISPATCH(GateFlags)(gates, samples, alive, in, count);
}
void normalAgreement(const float* normals, int offset, float cos_max, int begin, int end,
                     std::uint8_t* agree) {
  HWY_DYNAMIC_DISPATCH(NormalAgreement)(normals, offset, cos_max, begin, end, agree);
}
std::size_t countWithin(double nx, double ny, double nz, double d, const double* x, const double* y,
                        const double* z, const double* tol, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(CountWithin)(nx, ny, nz, d, x, y, z, tol, n);
}
void sampleRowPoints(const std::uint16_t* depth_mm, const float* rx, float ry, int cols,
                     float* points) {
  HWY_DYNAMIC_DISPATCH(SampleRowPoints)(depth_mm, rx, ry, cols, points);
}
int labelSingleCandidateRun(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols,
                            int u0, int u1, const PixelPlane& plane, float tol_floor,
                            std::uint16_t label) {
  return HWY_DYNAMIC_DISPATCH(LabelSingleCandidateRun)(depth_row, label_row, cols, u0, u1, plane,
                                                       tol_floor, label);
}
void labelCandidatesRun(const std::uint16_t* depth_row, std::uint16_t* label_row, int cols, int u0,
                        int u1, const PixelPlane* planes, const std::uint16_t* labels, int k,
                        float tol_floor, int* counts) {
  HWY_DYNAMIC_DISPATCH(LabelCandidatesRun)
  (depth_row, label_row, cols, u0, u1, planes, labels, k, tol_floor, counts);
}

}  // namespace shapesense::planes_kernels
#endif  // HWY_ONCE
