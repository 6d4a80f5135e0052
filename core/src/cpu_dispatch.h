// Runtime choice of the AVX2 code paths of core/. The build has no -march (packages must run on
// any x86-64), so AVX2 functions are compiled for AVX2 with `#pragma GCC target("avx2")` and are
// called only where the CPU reports AVX2; they compute the same bits as the SSE2 or scalar paths
// they replace (the build has -ffp-contract=off, so nothing is fused into FMA). GCC only: clang
// does not apply the pragma to the lambdas inside those functions.
#pragma once

#if defined(__SSE2__) && defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#define SHAPESENSE_AVX2_PATHS 1  // AVX2 functions compiled in, used where the CPU has AVX2
#endif

namespace shapesense::detail {

#if defined(SHAPESENSE_AVX2_PATHS)
/// True when the CPU (and the OS, which must save the AVX state) supports AVX2; checked once.
inline bool cpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#endif

}  // namespace shapesense::detail
