#pragma once
// The draws the evaluation's scene distributions make: one draw per call, so that one draw per
// statement keeps a scene the same whichever compiler built it.

#include <random>

namespace shapesense::eval::detail {

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline int uniformInt(std::mt19937_64& rng, int lo, int hi) {
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}

inline bool chance(std::mt19937_64& rng, double p) { return uniform(rng, 0.0, 1.0) < p; }

}  // namespace shapesense::eval::detail
