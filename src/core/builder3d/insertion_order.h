/// \file insertion_order.h
/// \brief Biased randomised insertion order (BRIO; Amenta, Choi, Rote 2003) with a Morton sort inside
/// each round: randomisation bounds the expected cavity work, the spatial sort inside a round keeps
/// consecutive insertions close so the walking point location takes a few steps.
#pragma once

#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace builder3d {

/// The hash that picks a point's round (splitmix64's finaliser).
inline std::uint64_t brioHash(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// How fast the rounds grow. A whole build sweeps the mesh built so far once per round, so fewer,
/// bigger rounds keep more of each cavity in cache: fourfold (1M uniform points: insertion 7 %
/// faster than with doubling). Points added to an existing triangulation (a sliding window's new
/// points) sweep only their own region, and there doubling rounds create fewer tetrahedra on
/// surface-like data (bench_sliding_window_core, synthetic LiDAR, 10 % slides of a 200k window:
/// 1.19-1.24 s with doubling rounds, 1.34-1.35 s with fourfold ones, alternated).
enum class BrioGrowth { kDoubling = 1, kFourfold = 2 };

/// The round structure every BRIO order here shares (the single-process builders' and the MPI
/// ranks'): how many rounds n points get, and each point's round, chosen by a hash of its id so that
/// it does not depend on which subset the point is in. Round count - 1 is the last and largest.
struct BrioRounds {
  BrioRounds(std::size_t n, BrioGrowth growth, std::uint64_t seed = 0)
      : growth_bits(static_cast<unsigned>(growth)), seed_mix(seed * 0xD1B54A32D192ED03ull) {
    while (count < 15 && (n >> (growth_bits * count)) > 512) ++count;
  }
  /// Trailing zero bits of the hash, in groups of growth_bits, at most count - 1 groups (a count,
  /// not a loop: how far a loop runs is a coin flip to the branch predictor).
  unsigned round(index_t id) const {
    const std::uint64_t h = brioHash(id ^ seed_mix) | (std::uint64_t(1) << (growth_bits * (count - 1)));
    return count - 1 - static_cast<unsigned>(__builtin_ctzll(h)) / growth_bits;
  }
  unsigned growth_bits;
  std::uint64_t seed_mix;
  unsigned count = 1;
};

/// The BRIO order of points[0..n): a permutation of 0..n-1. Round r holds about (g - 1) / g^(R-r) of
/// the points for growth g (the last about 3/4 with kFourfold), each round in Morton order over the
/// bounding box. The "random" choice is a hash of the index and `seed`, so the order (and thus every
/// perturbation-independent result, and the speed) is reproducible.
std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::uint64_t seed = 0,
                               BrioGrowth growth = BrioGrowth::kFourfold);

/// The BRIO order of the subset `ids` of `points` (ids must be < points.size(); the result is a
/// permutation of them). The rounds' random choice hashes the id, so a point's round does not depend
/// on which subset it is in. Doubling by default: subsets are mostly points added to a triangulation.
std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::vector<index_t> ids,
                               std::uint64_t seed = 0, BrioGrowth growth = BrioGrowth::kDoubling);

/// brioOrder() of all points, also giving where each round starts in the result (ascending, the
/// first is 0): the batches of Triangulation3D::build's parallel form. Computed on `num_threads`
/// threads (0: all); the result does not depend on it.
std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::vector<std::size_t>& round_begin,
                               std::uint64_t seed = 0, unsigned num_threads = 1);

}  // namespace builder3d
}  // namespace dw
