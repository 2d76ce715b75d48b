#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>

#include "core/util/multiversioning.h"
#include "core/util/page_memory.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/util/uninitialised_allocator.h"

namespace dw {

namespace {
[[noreturn]] void broken(const std::string& what) {
  throw Error("pcl_delaunay_walk: invalid graph: " + what);
}
}  // namespace

namespace {
/// Runs fn(v) for every vertex v < n on up to `threads` threads, in contiguous blocks. The first error
/// of the lowest failing block is rethrown, which is the error of the lowest failing vertex: a check's
/// message is the same as a one-thread pass gives.
template <typename Fn>
void forEachVertex(std::size_t n, unsigned threads, Fn&& fn) {
  parallelFor(n, workerCount(n, threads, 1u << 15), [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t v = b; v < e; ++v) fn(v);
  });
}
}  // namespace

void DelaunayGraph::validate(unsigned num_threads) const {
  const std::size_t n = points.size();
  if (dimension < 0 || dimension > 3) broken("dimension out of range");
  for (double o : origin)
    if (!std::isfinite(o)) broken("non-finite origin");
  if (offsets.size() != n + 1 || offsets.front() != 0) broken("offsets size");
  if (offsets.back() != edges.size()) broken("offsets do not end at the edge count");
  forEachVertex(n, num_threads, [&](std::size_t v) {
    if (offsets[v] > offsets[v + 1]) broken("offsets not monotonic at vertex " + std::to_string(v));
    if (!std::isfinite(points[v].x) || !std::isfinite(points[v].y) || !std::isfinite(points[v].z))
      broken("non-finite vertex " + std::to_string(v));
  });
  // One pass over the records (a loaded file's largest array), vertex by vertex: the offsets checked
  // above cover [0, edges.size()) exactly, so every record is seen once.
  forEachVertex(n, num_threads, [&](std::size_t v) {
    for (index_t k = offsets[v]; k < offsets[v + 1]; ++k) {
      const EdgeRecord& e = edges[k];
      if (e.j >= n) broken("edge neighbour out of range");
      if (!(e.m >= 0.f) || !std::isfinite(e.ex) || !std::isfinite(e.ey) || !std::isfinite(e.ez))
        broken("non-finite edge record");
      if (k > offsets[v] && !(edges[k - 1].m <= e.m))  // the walk's early stop relies on this order
        broken("edges of vertex " + std::to_string(v) + " not sorted by length");
    }
  });
  if (!safe_radius2.empty()) {
    if (safe_radius2.size() != n) broken("safe radii size");
    forEachVertex(n, num_threads, [&](std::size_t v) {
      float r = INFINITY;
      for (index_t e = offsets[v]; e < offsets[v + 1]; ++e) r = std::min(r, edges[e].m);
      // A radius larger than half the nearest-neighbour distance would stop walks at the wrong vertex.
      if (!(safe_radius2[v] >= 0.f) || (safe_radius2[v] > 0.f && !(double(safe_radius2[v]) < double(r) * r)))
        broken("safe radius too large at vertex " + std::to_string(v));
    });
  }
  if (originals_offsets.size() != n + 1 || originals_offsets.front() != 0 ||
      originals_offsets.back() != originals.size())
    broken("originals offsets");
  const std::size_t num_input = input_to_vertex.size();
  forEachVertex(n, num_threads, [&](std::size_t v) {
    if (originals_offsets[v] >= originals_offsets[v + 1]) broken("vertex without an input point");
    for (index_t k = originals_offsets[v]; k < originals_offsets[v + 1]; ++k) {
      const index_t i = originals[k];
      if (i >= num_input || input_to_vertex[i] != v) broken("originals do not match input_to_vertex");
      if (k > originals_offsets[v] && originals[k - 1] >= i) broken("originals not ascending");
    }
  });
  std::size_t mapped = 0;
  for (index_t v : input_to_vertex) {
    if (v == kInvalidIndex) continue;
    if (v >= n) broken("input_to_vertex out of range");
    ++mapped;
  }
  if (mapped != originals.size()) broken("input_to_vertex count differs from originals");
}

std::size_t DelaunayGraph::memoryBytes() const {
  return points.size() * sizeof(Vec3f) + offsets.size() * sizeof(index_t) +
         edges.size() * sizeof(EdgeRecord) + input_to_vertex.size() * sizeof(index_t) +
         originals_offsets.size() * sizeof(index_t) + originals.size() * sizeof(index_t) +
         safe_radius2.size() * sizeof(float);
}

namespace {

// The safe-ball radius squared stored for a vertex whose shortest half-length is r (see
// computeSafeRadii); 0 disables the ball.
float safeRadius2(float r) {
  if (!std::isfinite(r)) return 0.f;  // isolated vertex (a one-point graph): no bound
  const double r2 = double(r) * double(r) * (1.0 - 1e-5);
  const float f = static_cast<float>(r2);
  // Kept only where float holds it below r^2 (r^2 beyond float's range, from a file's huge edge
  // lengths, would round to inf): the invariant validate() checks.
  return r2 >= 1e-30 && std::isfinite(f) && double(f) < double(r) * double(r) ? f : 0.f;
}

// rank[k]: how many of the n (<= N) keys are smaller than keys[k], which is keys[k]'s place in
// ascending order when the keys are distinct. keys holds N entries, those past n padded with the
// largest key. Counted without a branch over a fixed N, which the compiler unrolls and, for
// x86-64-v3, vectorises (four 64-bit compares at once): an insertion sort's comparisons were coin flips
// to the branch predictor, ~16 mispredictions per vertex, more than the rest of the assembly together.
template <int N>
[[gnu::always_inline]] inline void rankPadded(const std::int64_t* keys, index_t* rank) {
  std::int64_t r[N] = {};
  for (int i = 0; i < N; ++i) {
    const std::int64_t x = keys[i];
    for (int k = 0; k < N; ++k) r[k] += x < keys[k];
  }
  for (int k = 0; k < N; ++k) rank[k] = static_cast<index_t>(r[k]);
}

constexpr index_t kRankedMax = 64;  // above, a sort: ~16 neighbours on volumetric input, 64 is rare

template <int N>
void rankBaseline(const std::int64_t* keys, index_t* rank) {
  rankPadded<N>(keys, rank);
}

template <int N>
DW_TARGET_V3 void rankV3(const std::int64_t* keys, index_t* rank) {
  rankPadded<N>(keys, rank);
}

template <int N>
void rankOnThisCpu(const std::int64_t* keys, index_t* rank) {
  detail::cpuHasX86_64V3() ? rankV3<N>(keys, rank) : rankBaseline<N>(keys, rank);
}

// The ranks of n keys (non-negative; keys has room for max(n, kRankedMax) entries, the padding is
// overwritten). Equal keys share a rank.
void rankKeys(std::int64_t* keys, index_t n, index_t* rank) {
  if (n <= kRankedMax) {
    const index_t padded = n <= 16 ? 16 : n <= 32 ? 32 : kRankedMax;
    std::fill(keys + n, keys + padded, std::numeric_limits<std::int64_t>::max());
    if (padded == 16)
      rankOnThisCpu<16>(keys, rank);
    else if (padded == 32)
      rankOnThisCpu<32>(keys, rank);
    else
      rankOnThisCpu<kRankedMax>(keys, rank);
    return;
  }
  std::vector<std::pair<std::int64_t, index_t>> sorted(n);
  for (index_t k = 0; k < n; ++k) sorted[k] = {keys[k], k};
  std::sort(sorted.begin(), sorted.end());
  index_t r = 0;
  for (index_t k = 0; k < n; ++k) {
    if (k > 0 && sorted[k].first != sorted[k - 1].first) r = k;
    rank[sorted[k].second] = r;
  }
}

// x += 1, atomically where other threads add to the same counters.
template <bool kShared>
inline index_t fetchIncrement(index_t& x) {
  if constexpr (kShared) return __atomic_fetch_add(&x, 1u, __ATOMIC_RELAXED);
  return x++;
}

}  // namespace

namespace {

// The builder's edge list normalised (u < v), checked, made distinct and rid of loops. Builders may
// report an edge once per incident simplex.
void normaliseEdgeList(std::vector<std::pair<index_t, index_t>>& undirected, std::size_t n, bool distinct,
                       unsigned threads) {
  const unsigned list_workers = workerCount(undirected.size(), threads, std::size_t(1) << 16);
  std::vector<char> out_of_range(list_workers, 0), loops(list_workers, 0);
  parallelFor(undirected.size(), list_workers, [&](std::size_t b, std::size_t e, unsigned w) {
    bool bad = false, loop = false;
    for (std::size_t k = b; k < e; ++k) {
      auto& edge = undirected[k];
      if (edge.first > edge.second) std::swap(edge.first, edge.second);
      bad |= edge.second >= n;
      loop |= edge.first == edge.second;
    }
    out_of_range[w] = bad;
    loops[w] = loop;
  });
  if (std::count(out_of_range.begin(), out_of_range.end(), 1) > 0)
    throw Error("pcl_delaunay_walk: builder returned an edge to a missing vertex");
  // A list known to be distinct skips the sort/unique (3 % of a LiDAR frame's build); the records'
  // order comes from the per-vertex ordering either way.
  if (!distinct) {
    std::sort(undirected.begin(), undirected.end());
    undirected.erase(std::unique(undirected.begin(), undirected.end()), undirected.end());
  }
  if (std::count(loops.begin(), loops.end(), 1) > 0)
    undirected.erase(std::remove_if(undirected.begin(), undirected.end(),
                                    [](const std::pair<index_t, index_t>& e) { return e.first == e.second; }),
                     undirected.end());
  if (2 * undirected.size() > static_cast<std::size_t>(kInvalidIndex))
    throw Error("pcl_delaunay_walk: graph has more than 2^32 directed edges");
}

// Degrees, then the records, scattered from the list on all threads into each vertex's part (in an
// order that depends on the threads; orderNeighbourhoods fixes it). An edge's two records are made
// together: u -> v is (d / |d|, |d| / 2, v) for d = x_v - x_u, and v -> u is made from x_u - x_v,
// which is -d but for the signs of zeros, so the length and the division serve both. Made per vertex
// instead, from a list of neighbour ids, each would be computed twice and the list would take 8 bytes
// per edge besides. Frees the list.
void scatterEdgeRecords(DelaunayGraph& g, std::vector<std::pair<index_t, index_t>>& undirected,
                        unsigned threads) {
  const std::size_t n = g.points.size();
  const unsigned workers = workerCount(undirected.size(), threads, std::size_t(1) << 16);
  std::vector<index_t> fill(n, 0);
  auto scatter = [&](auto shared, auto&& fn) {
    parallelFor(undirected.size(), workers, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t k = b; k < e; ++k) {
        const auto [u, v] = undirected[k];
        fn(u, v, fetchIncrement<decltype(shared)::value>(fill[u]),
           fetchIncrement<decltype(shared)::value>(fill[v]));
      }
    });
  };
  auto scatterAll = [&](auto&& fn) {
    if (workers > 1)
      scatter(std::true_type{}, fn);
    else
      scatter(std::false_type{}, fn);
  };
  scatterAll([](index_t, index_t, index_t, index_t) {});  // degrees
  g.offsets.assign(n + 1, 0);
  for (std::size_t v = 0; v < n; ++v) {
    g.offsets[v + 1] = g.offsets[v] + fill[v];
    fill[v] = g.offsets[v];
  }
  // Sized unwritten: its pages are mapped by the threads that write the records.
  g.edges.clear();
  g.edges.resize(g.offsets[n]);
  EdgeRecord* const records = g.edges.data();
  const Vec3f* const points = g.points.data();
  scatterAll([&](index_t u, index_t v, index_t at_u, index_t at_v) {
    const Vec3f d = points[v] - points[u], back = points[u] - points[v];
    const double len = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
    const double inv = len > 0.0 ? 1.0 / len : 0.0;
    const float m = float(0.5 * len);
    records[at_u] = {float(d.x * inv), float(d.y * inv), float(d.z * inv), m, v};
    records[at_v] = {float(back.x * inv), float(back.y * inv), float(back.z * inv), m, u};
  });
  detail::freeScratch(undirected);
  detail::freeScratch(fill);
}

// Each neighbourhood in order, vertex by vertex on all threads: ordered by (m, j) through one 64-bit
// key per record, each record is copied to its key's rank. Sorting the 20-byte records in place costs
// about half of a one-thread assembly, and an insertion sort of the keys loses much of its time to
// mispredicted comparisons; the branch-free ranking (rankKeys) avoids both. Sets the safe radii;
// throws if the builder gave an edge twice.
void orderNeighbourhoods(DelaunayGraph& g, unsigned threads) {
  const std::size_t n = g.points.size();
  EdgeRecord* const records = g.edges.data();
  const unsigned vertex_workers = workerCount(n, threads, std::size_t(1) << 14);
  g.safe_radius2.assign(n, 0.f);
  // Per worker, the first repeated edge found (kInvalidIndex: none).
  std::vector<std::pair<index_t, index_t>> repeated(vertex_workers, {kInvalidIndex, kInvalidIndex});
  parallelFor(n, vertex_workers, [&](std::size_t b, std::size_t e, unsigned w) {
    // Per record: a copy, its key (m's float bits above j: m >= 0, so the bits order like the value,
    // and the top bit is clear) and the key's rank, which is the record's place.
    std::vector<EdgeRecord> made;
    std::vector<std::int64_t> keys;
    std::vector<index_t> rank;
    for (std::size_t v = b; v < e; ++v) {
      const index_t first = g.offsets[v], count = g.offsets[v + 1] - first;
      EdgeRecord* const out = records + first;
      made.assign(out, out + count);
      keys.resize(std::max(count, kRankedMax));
      rank.resize(std::max(count, kRankedMax));
      for (index_t k = 0; k < count; ++k) {
        std::uint32_t bits;
        std::memcpy(&bits, &made[k].m, sizeof bits);
        keys[k] = static_cast<std::int64_t>(std::uint64_t(bits) << 32 | made[k].j);
      }
      rankKeys(keys.data(), count, rank.data());
      std::uint64_t rank_sum = 0;
      for (index_t k = 0; k < count; ++k) {
        out[rank[k]] = made[k];
        rank_sum += rank[k];
      }
      // Distinct keys take the ranks 0 .. count - 1. A repeated edge gives two equal keys (same length,
      // same j), which share a rank: the sum falls short (and a record's place keeps a stale copy, but
      // the build fails below).
      const std::uint64_t distinct_sum = count == 0 ? 0 : std::uint64_t(count) * (count - 1) / 2;
      if (rank_sum != distinct_sum && repeated[w].first == kInvalidIndex) {
        std::sort(keys.begin(), keys.begin() + count);
        for (index_t k = 1; k < count; ++k)
          if (keys[k] == keys[k - 1]) repeated[w] = {index_t(v), static_cast<index_t>(keys[k])};
      }
      if (count > 0) g.safe_radius2[v] = safeRadius2(out[0].m);
    }
  });
  for (const auto& [v, j] : repeated)
    if (v != kInvalidIndex)
      throw Error("pcl_delaunay_walk: builder returned edge (" + std::to_string(v) + ", " +
                  std::to_string(j) + ") twice");
}

}  // namespace

void assembleEdges(DelaunayGraph& g, std::vector<std::pair<index_t, index_t>> undirected, bool distinct,
                   unsigned num_threads) {
  const unsigned threads = resolveThreads(num_threads);
  normaliseEdgeList(undirected, g.points.size(), distinct, threads);
  scatterEdgeRecords(g, undirected, threads);
  orderNeighbourhoods(g, threads);
}

namespace {
// Shortest edge first (the walk stops reading a neighbourhood at the first edge longer than 2|u|);
// ties by neighbour id, so files are deterministic.
bool shorterEdge(const EdgeRecord& a, const EdgeRecord& b) {
  return a.m < b.m || (a.m == b.m && a.j < b.j);
}
}  // namespace

void sortNeighbourhoods(DelaunayGraph& g, unsigned num_threads) {
  // Runs on loaded data before validate(): leave anything malformed (bad offsets, NaN lengths, which
  // would break std::sort's ordering contract) untouched for validate() to report. The offsets are
  // checked whole first, so that the neighbourhoods sorted in parallel cannot overlap.
  const std::size_t nv = g.offsets.size() - (g.offsets.empty() ? 0 : 1);
  std::atomic<bool> malformed{false};
  forEachVertex(nv, num_threads, [&](std::size_t v) {
    if (g.offsets[v] > g.offsets[v + 1] || g.offsets[v + 1] > g.edges.size())
      malformed.store(true, std::memory_order_relaxed);
  });
  if (malformed) return;
  forEachVertex(nv, num_threads, [&](std::size_t v) {
    const auto first = g.edges.begin() + g.offsets[v], last = g.edges.begin() + g.offsets[v + 1];
    if (std::is_sorted(first, last, shorterEdge)) return;
    if (std::any_of(first, last, [](const EdgeRecord& r) { return !std::isfinite(r.m); })) return;
    std::sort(first, last, shorterEdge);
  });
}

void computeSafeRadii(DelaunayGraph& g, unsigned num_threads) {
  g.safe_radius2.assign(g.points.size(), 0.f);
  forEachVertex(g.points.size(), num_threads, [&](std::size_t v) {
    float r = INFINITY;
    for (index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) r = std::min(r, g.edges[k].m);
    g.safe_radius2[v] = safeRadius2(r);
  });
}

}  // namespace dw
