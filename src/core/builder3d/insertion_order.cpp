#include "insertion_order.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include "core/util/page_memory.h"
#include "core/util/parallel_bucket.h"
#include "core/util/parallel_sort.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/util/uninitialised_allocator.h"

namespace dw {
namespace builder3d {
namespace {

// A point's sort key (its BRIO round in the top bits, then its Morton code) and its id.
struct KeyId {
  std::uint64_t key;
  index_t id;
  bool operator<(const KeyId& o) const { return key != o.key ? key < o.key : id < o.id; }
};
constexpr unsigned kRoundShift = 59;
// Unwritten until the parallel loops fill them: value-initialised, each 16 bytes per point was zeroed
// (and its pages faulted in) on one thread before the threads started.
using KeyIds = std::vector<KeyId, UninitialisedAllocator<KeyId>>;

// Sorts kv, partitioned by round, when it is nearly sorted within each round, which is what the
// builders are handed: ids in Morton order (buildDelaunayGraph's cells, over global coordinates,
// differ from these only by rounding: 0-2 entries out of place on the LiDAR frame, the dragon-100k
// and the bunny). Insertion sort of each worker's block with a budget of moves, then a check that the
// blocks meet in order; false when a budget runs out or they do not (kv still a permutation), and the
// caller sorts. Either way the result is the one order a sort gives, the key order being total.
// The whole order of 1M uniform points on one thread took 0.082-0.087 s with a full sort, 0.042-0.044 s
// with this on one block, and 0.025-0.027 s (0.018-0.024 s on two threads) since the keys go straight
// to their rounds, every pass runs on all workers, and the cells are truncated instead of floored.
bool sortNearlySorted(KeyIds& kv, unsigned workers) {
  const std::size_t n = kv.size();
  std::vector<char> done(workers, 0);
  parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    done[w] = detail::insertionSortWithBudget(kv.begin() + b, kv.begin() + e);
  });
  for (unsigned w = 0; w < workers; ++w)
    if (!done[w]) return false;
  const std::size_t chunk = (n + workers - 1) / workers;  // parallelFor's blocks
  for (std::size_t b = chunk; b < n; b += chunk)
    if (kv[b] < kv[b - 1]) return false;
  return true;
}

// The subset form, also reporting where each round starts.
std::vector<index_t> brioOrderInRounds(const std::vector<Vec3f>& points, std::vector<index_t> ids,
                                       std::uint64_t seed, std::vector<std::size_t>& round_begin,
                                       unsigned num_threads, BrioGrowth growth);

}  // namespace

std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::uint64_t seed, BrioGrowth growth) {
  std::vector<index_t> ids(points.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<index_t>(i);
  return brioOrder(points, std::move(ids), seed, growth);
}

std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::vector<index_t> ids, std::uint64_t seed,
                               BrioGrowth growth) {
  std::vector<std::size_t> unused;
  return brioOrderInRounds(points, std::move(ids), seed, unused, 1, growth);
}

std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::vector<std::size_t>& round_begin,
                               std::uint64_t seed, unsigned num_threads) {
  std::vector<index_t> ids(points.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<index_t>(i);
  return brioOrderInRounds(points, std::move(ids), seed, round_begin, num_threads, BrioGrowth::kFourfold);
}

namespace {

std::vector<index_t> brioOrderInRounds(const std::vector<Vec3f>& points, std::vector<index_t> ids,
                                       std::uint64_t seed, std::vector<std::size_t>& round_begin,
                                       unsigned num_threads, BrioGrowth growth) {
  round_begin.clear();
  const std::size_t n = ids.size();
  std::vector<index_t> order(std::move(ids));
  if (n == 0) return order;
  for (index_t id : order)
    if (id >= points.size()) throw Error("dw::builder3d::brioOrder: point id out of range");

  const unsigned workers = workerCount(n, num_threads, std::size_t(1) << 16);
  // The bounding box, per worker block then combined.
  std::vector<std::array<float, 6>> box(workers);
  parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned w) {
    const Vec3f& p0 = points[order[0]];                          // any point of the set starts the box
    std::array<float, 6> m{p0.x, p0.y, p0.z, p0.x, p0.y, p0.z};  // lo, hi
    for (std::size_t k = b; k < e; ++k) {
      const Vec3f& p = points[order[k]];
      const float c[3] = {p.x, p.y, p.z};
      for (int a = 0; a < 3; ++a) {
        m[a] = std::min(m[a], c[a]);
        m[a + 3] = std::max(m[a + 3], c[a]);
      }
    }
    box[w] = m;
  });
  float lo[3] = {box[0][0], box[0][1], box[0][2]}, hi[3] = {box[0][3], box[0][4], box[0][5]};
  for (const auto& m : box)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], m[a]);
      hi[a] = std::max(hi[a], m[a + 3]);
    }
  // One cubic grid over the box (equal cell size on every axis keeps the curve's locality).
  const double extent =
      std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2], 1e-30});
  const double scale = double((1u << 21) - 1) / extent;

  // Rounds: the first small enough to be cheap whatever its order, then growing by 2^growth_bits.
  // Fourfold: round R-1 takes a point with probability 3/4, R-2 with 3/16, ...; round 0 the
  // remainder. Fewer rounds than doubling ones: each round sweeps the whole mesh built so far, and
  // with fourfold growth more of a cavity was made by the same sweep, still in cache. 1M uniform
  // points: insertion -7 % on one thread and -8 % on two; the dragon -7 % and -11 % (medians of 5-8
  // alternated runs; growth by 8 was faster on uniform points, slower on the dragon, whose cavity
  // work rose 8 %).
  // Each round 2^bits - 1 times all before it.
  const BrioRounds brio_rounds(n, growth, seed);
  const unsigned rounds = brio_rounds.count;
  auto roundOf = [&](index_t i) { return brio_rounds.round(i); };

  // One key per point: its round above its Morton code; ids break ties, so the order is unique. The
  // keys are written straight to their round's part (counted first, per worker block, so that the
  // parts stay in input order): no partition afterwards, and no second buffer to fault in.
  KeyIds kv(n);
  std::vector<std::size_t> part_begin(rounds, 0);
  detail::parallelBucket(
      n, workers, rounds, [&](std::size_t k) { return roundOf(order[k]); },
      [&](const std::vector<std::size_t>& sizes) {
        std::size_t total = 0;
        for (unsigned r = 0; r < rounds; total += sizes[r], ++r) {
          part_begin[r] = total;
          if (sizes[r] > 0) round_begin.push_back(total);  // where each round that has points begins
        }
      },
      [&](std::size_t k, unsigned round, std::size_t rank) {
        const index_t i = order[k];
        const Vec3f& p = points[i];
        // v >= lo: clamped, the truncation is the floor (std::floor is a library call on baseline
        // x86-64, three per point: half of this loop's time).
        const auto cell = [&](float v, int axis) {
          const double c = (double(v) - lo[axis]) * scale;
          return static_cast<std::uint32_t>(std::min(std::max(c, 0.0), double((1u << 21) - 1)));
        };
        const std::uint64_t morton = mortonKey(cell(p.x, 0), cell(p.y, 1), cell(p.z, 2));
        kv[part_begin[round] + rank] = {(std::uint64_t(round) << kRoundShift) | (morton >> 4), i};
      });
  // The round of a key is in its top bits, so a sort leaves the rounds where they are.
  if (!sortNearlySorted(kv, workers)) detail::parallelSort(kv, std::less<KeyId>(), num_threads);
  parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t k = b; k < e; ++k) order[k] = kv[k].id;
  });
  detail::freeScratch(kv);
  return order;
}

}  // namespace

}  // namespace builder3d
}  // namespace dw
