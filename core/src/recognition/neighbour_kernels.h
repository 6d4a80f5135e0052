#pragma once
// The SIMD kernel of the point grid's radius queries (Google Highway, dispatched at run time).
// The same arithmetic as the scalar loop, in the same order, without fused multiply-adds
// (-ffp-contract=off), so every target keeps the same points.

#include <cstddef>
#include <cstdint>

namespace shapesense::detail {

/// Candidate points side by side, for radius tests over contiguous memory.
struct CandidateColumns {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const std::uint32_t* index = nullptr;  ///< each candidate's point index
  std::size_t count = 0;
};

/// Writes the indices of the candidates within sqrt(radius2) of (cx, cy, cz) (squared distance
/// at most radius2) to `out`, in candidate order, and returns how many there are. `out` must
/// hold count + 64 entries: whole vectors are stored past the last one kept.
std::size_t indicesWithin(const CandidateColumns& candidates, float cx, float cy, float cz,
                          float radius2, std::uint32_t* out);

/// Room `out` needs beyond the candidates' count.
inline constexpr std::size_t kIndicesWithinSlack = 64;

}  // namespace shapesense::detail
