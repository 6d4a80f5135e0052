#pragma once
// Random numbers of the synthetic scene. std::mt19937_64's output sequence is fixed by the
// standard, but the standard distributions are not, so the conversions are done here to keep
// scenes identical across standard libraries.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <random>

#include <Eigen/Core>

namespace shapesense::synthetic::detail {

inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Separate streams so that, e.g., the noise of frame 3 never depends on the layout draws.
constexpr std::uint64_t kLayoutStream = 0x4C41594F5554ull;
constexpr std::uint64_t kFrameStream = 0x4652414D45ull;
// The wider distribution's features (issue #18) draw only from these, so scenes with the
// features off keep every draw of the streams above.
constexpr std::uint64_t kExtraLayoutStream = 0x5749444552ull;  // layout additions
constexpr std::uint64_t kArtefactStream = 0x415254454641ull;   // flying pixels, holes

/// Seed of the generator the optional layout additions of scene `seed` draw from.
inline std::uint64_t extraLayoutSeed(std::uint64_t seed) {
  return mix64(seed ^ kExtraLayoutStream);
}

/// Seed of the optional sensor artefacts of the frame whose noise seed is `frame_seed`.
inline std::uint64_t artefactSeed(std::uint64_t frame_seed) {
  return mix64(frame_seed ^ kArtefactStream);
}

/// Seed of the one generator whose draws define the layout of scene `seed`.
inline std::uint64_t layoutSeed(std::uint64_t seed) { return mix64(seed ^ kLayoutStream); }

/// Seed of the sensor noise of frame `index`: independent of every other frame.
inline std::uint64_t frameNoiseSeed(std::uint64_t seed, std::uint64_t index) {
  return mix64(mix64(seed ^ kFrameStream) + index);
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int uniformInt(int lo, int hi) {  // inclusive
    if (hi <= lo) return lo;
    return lo + static_cast<int>(engine_() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }
  // A point of the box [lo, hi], its components drawn last to first: that order defines the
  // scenes of every seed. Two draws in one argument list would leave the order to the compiler
  // (GCC and clang differ), and the scenes with it.
  Eigen::Vector2d uniform2(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
    const double y = uniform(lo.y(), hi.y());
    return {uniform(lo.x(), hi.x()), y};
  }
  Eigen::Vector3d uniform3(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    const double z = uniform(lo.z(), hi.z());
    const double y = uniform(lo.y(), hi.y());
    return {uniform(lo.x(), hi.x()), y, z};
  }

 private:
  std::mt19937_64 engine_;
};

/// Counter-based random numbers for the per-frame noise: a pixel's draws depend only on
/// (frame seed, pixel, draw), so the noise at one pixel never depends on which other pixels were
/// valid, and a change in one part of the model does not reshuffle the noise everywhere.
class PixelNoise {
 public:
  explicit PixelNoise(std::uint64_t frame_seed) : seed_(frame_seed) {}
  static constexpr unsigned kDrawsPerPixel = 8;

  std::uint64_t bits(std::size_t pixel, unsigned draw) const {
    return mix64(seed_ + pixel * kDrawsPerPixel + draw);
  }
  double uniform(std::size_t pixel, unsigned draw) const {
    return static_cast<double>(bits(pixel, draw) >> 11) * 0x1.0p-53;
  }
  /// A standard normal from draws first_draw .. kDrawsPerPixel - 1 (Marsaglia's polar method:
  /// no trigonometry; all but 1e-4 of the pixels accept within the available draws).
  double normal(std::size_t pixel, unsigned first_draw) const {
    for (unsigned draw = first_draw; draw < kDrawsPerPixel; ++draw) {
      const std::uint64_t b = bits(pixel, draw);
      const double x = static_cast<double>(b >> 32) * 0x1.0p-31 - 1.0;
      const double y = static_cast<double>(b & 0xFFFFFFFFu) * 0x1.0p-31 - 1.0;
      const double s = x * x + y * y;
      if (s > 0.0 && s < 1.0) return x * std::sqrt(-2.0 * std::log(s) / s);
    }
    const double u1 =
        (static_cast<double>(bits(pixel, first_draw) >> 11) + 1.0) * 0x1.0p-53;  // Box-Muller
    return std::sqrt(-2.0 * std::log(u1)) *
           std::cos(2.0 * std::numbers::pi * uniform(pixel, first_draw + 1));
  }

 private:
  std::uint64_t seed_;
};

}  // namespace shapesense::synthetic::detail
