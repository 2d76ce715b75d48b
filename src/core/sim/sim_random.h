/// \file sim_random.h
/// \brief The simulator's random numbers: a counter-based generator (SplitMix64 mixing) whose streams
/// are keyed by (seed, stream id), so that a scan, a map patch or a ray draws the same numbers whatever
/// thread computes it. Uniforms are built from the raw bits here, not by <random>'s distributions,
/// whose output the standard leaves to the library: the same seed must give the same files with
/// libstdc++ and libc++.
#pragma once

#include <cmath>
#include <cstdint>

namespace dw {
namespace sim {
namespace detail {

/// SplitMix64's finaliser: a bijection of 64-bit words with full avalanche.
inline std::uint64_t mix64(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  x ^= x >> 31;
  return x;
}

/// Key of stream `b` inside stream `a` (hierarchical streams: scan k, then ray j).
inline std::uint64_t streamKey(std::uint64_t a, std::uint64_t b) {
  return mix64(a ^ mix64(b + 0x9E3779B97F4A7C15ull));
}

class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t stream) : state_(streamKey(seed, stream)) {}

  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ull;
    return mix64(state_);
  }
  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n) (n > 0); the bias of the modulo is below 2^-40 for the n used here.
  std::uint64_t index(std::uint64_t n) { return next() % n; }
  bool chance(double p) { return uniform() < p; }
  /// Standard normal by Box-Muller (one value per call: the pair's twin is dropped, which keeps the
  /// generator stateless apart from its counter).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  std::uint64_t state_;
};

}  // namespace detail
}  // namespace sim
}  // namespace dw
