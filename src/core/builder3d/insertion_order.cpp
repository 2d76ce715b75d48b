#include "pcl_delaunay_walk/core/builder3d/insertion_order.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "../page_memory.h"
#include "../parallel_sort.h"
#include "pcl_delaunay_walk/core/parallel_for.h"
#include "pcl_delaunay_walk/core/space_filling_curve.h"

namespace dw {
namespace builder3d {
namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// A point's sort key (its BRIO round in the top bits, then its Morton code) and its id.
struct KeyId {
  std::uint64_t key;
  index_t id;
  bool operator<(const KeyId& o) const { return key != o.key ? key < o.key : id < o.id; }
};
constexpr unsigned kRoundShift = 59;

// Sorts kv when it is nearly sorted within each round, which is what the builders are handed: ids in
// Morton order (buildDelaunayGraph's cells, over global coordinates, differ from these only by
// rounding: 0-2 entries out of place on the LiDAR frame, the dragon-100k and the bunny). A stable
// partition by round, then insertion sort with a budget of moves; returns false when the budget runs
// out (kv still a permutation), and the caller sorts. Either way the result is the one order a sort
// gives, the key order being total. 1M uniform points, one thread: the order took 0.042-0.044 s
// instead of 0.082-0.087 s.
bool sortNearlySorted(std::vector<KeyId>& kv, unsigned rounds) {
  const std::size_t n = kv.size();
  std::vector<std::size_t> begin(rounds + 1, 0);
  for (const KeyId& e : kv) ++begin[(e.key >> kRoundShift) + 1];
  for (unsigned r = 0; r < rounds; ++r) begin[r + 1] += begin[r];
  std::vector<KeyId> out(n);
  std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
  for (const KeyId& e : kv) out[fill[e.key >> kRoundShift]++] = e;
  // Moves allowed: a few per point, so that input in no particular order gives up early.
  std::size_t budget = n / 4 + 64;
  for (std::size_t i = 1; i < n; ++i) {
    const KeyId e = out[i];
    std::size_t j = i;
    for (; j > 0 && e < out[j - 1]; --j) {
      if (budget-- == 0) {
        out[j] = e;  // still a permutation
        kv.swap(out);
        return false;
      }
      out[j] = out[j - 1];
    }
    out[j] = e;
  }
  kv.swap(out);
  detail::freeScratch(out);
  return true;
}

// The subset form, also reporting where each round starts.
std::vector<index_t> brioOrderInRounds(const std::vector<Vec3f>& points, std::vector<index_t> ids,
                                       std::uint64_t seed, std::vector<std::size_t>& round_begin,
                                       unsigned num_threads);

}  // namespace

std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::uint64_t seed) {
  std::vector<index_t> ids(points.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<index_t>(i);
  return brioOrder(points, std::move(ids), seed);
}

std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::vector<index_t> ids,
                               std::uint64_t seed) {
  std::vector<std::size_t> unused;
  return brioOrderInRounds(points, std::move(ids), seed, unused, 1);
}

std::vector<index_t> brioOrder(const std::vector<Vec3f>& points, std::vector<std::size_t>& round_begin,
                               std::uint64_t seed, unsigned num_threads) {
  std::vector<index_t> ids(points.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<index_t>(i);
  return brioOrderInRounds(points, std::move(ids), seed, round_begin, num_threads);
}

namespace {

std::vector<index_t> brioOrderInRounds(const std::vector<Vec3f>& points, std::vector<index_t> ids,
                                       std::uint64_t seed, std::vector<std::size_t>& round_begin,
                                       unsigned num_threads) {
  round_begin.clear();
  const std::size_t n = ids.size();
  std::vector<index_t> order(std::move(ids));
  if (n == 0) return order;
  for (index_t id : order)
    if (id >= points.size()) throw Error("dw::builder3d::brioOrder: point id out of range");

  const Vec3f& p0 = points[order[0]];
  float lo[3] = {p0.x, p0.y, p0.z}, hi[3] = {lo[0], lo[1], lo[2]};
  for (index_t id : order) {
    const Vec3f& p = points[id];
    const float c[3] = {p.x, p.y, p.z};
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], c[k]);
      hi[k] = std::max(hi[k], c[k]);
    }
  }
  // One cubic grid over the box (equal cell size on every axis keeps the curve's locality).
  const double extent =
      std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2], 1e-30});
  const double scale = double((1u << 21) - 1) / extent;

  // Rounds: the first small enough to be cheap whatever its order, then doubling.
  unsigned rounds = 1;
  while (rounds < 15 && (n >> rounds) > 512) ++rounds;

  // One key per point: its round above its Morton code; ids break ties, so the order is unique.
  std::vector<KeyId> kv(n);
  const unsigned workers = workerCount(n, num_threads, std::size_t(1) << 16);
  parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t k = b; k < e; ++k) {
      const index_t i = order[k];
      const Vec3f& p = points[i];
      const auto cell = [&](float v, int axis) {
        const double c = std::floor((double(v) - lo[axis]) * scale);
        return static_cast<std::uint32_t>(std::min(std::max(c, 0.0), double((1u << 21) - 1)));
      };
      const std::uint64_t morton = mortonKey(cell(p.x, 0), cell(p.y, 1), cell(p.z, 2));
      // Round R-1 with probability 1/2, R-2 with 1/4, ...; round 0 takes the remainder.
      const std::uint64_t h = splitmix64(i ^ (seed * 0xD1B54A32D192ED03ull));
      unsigned tz = 0;
      while (tz + 1 < rounds && ((h >> tz) & 1u) == 0) ++tz;
      const std::uint64_t round = rounds - 1 - tz;
      kv[k] = {(round << kRoundShift) | (morton >> 4), i};
    }
  });
  if (!sortNearlySorted(kv, rounds)) detail::parallelSort(kv, std::less<KeyId>(), num_threads);
  for (std::size_t k = 0; k < n; ++k) {
    order[k] = kv[k].id;
    if (k == 0 || (kv[k].key >> kRoundShift) != (kv[k - 1].key >> kRoundShift)) round_begin.push_back(k);
  }
  detail::freeScratch(kv);
  return order;
}

}  // namespace

}  // namespace builder3d
}  // namespace dw
