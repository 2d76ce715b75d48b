// Incremental Bowyer-Watson on flat arrays. See triangulation_3d.h for the representation.
#include "triangulation_3d.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <memory>
#include <numeric>
#include <string>
#include <thread>
#include <type_traits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/util/multiversioning.h"
#include "core/util/page_memory.h"
#include "core/util/parallel_bucket.h"
#include "core/util/parallel_sort.h"
#include "core/geometry/affine_span.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"
#include "core/geometry/predicates_3d_simd.h"
#include "core/util/process_memory.h"

// The insertion (insertCore with the walk and the linking inlined) is compiled twice, for baseline
// x86-64 and for x86-64-v3, and each call takes the version the CPU can run (multiversioning.h).

namespace dw {
namespace builder3d {
namespace {

constexpr std::uint32_t kNoTet = 0xFFFFFFFFu;

inline std::size_t hashKey(std::uint64_t k, unsigned bits) {
  return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> (64 - bits));
}

// Scratch of at least n entries, grown (never shrunk) to the largest need seen.
template <class T>
inline T* atLeast(SlotArray<T>& v, std::size_t n) {
  if (v.size() < n) v.resize(std::max(n, 2 * v.size()));
  return v.data();
}

// Bits of an open-addressing table for at least `entries` slots (64 at the least).
inline unsigned tableBits(std::size_t entries) {
  // No loop: asked per insertion and per vertex of the edge extraction, whose sizes vary.
  const unsigned bits = entries <= 1 ? 0u : 64u - static_cast<unsigned>(__builtin_clzll(entries - 1));
  return std::max(bits, 6u);
}

// The three positions other than f.
constexpr unsigned kOtherThree[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};

// kForwardEdge[j][f] = {x, y}: face j (opposite vertex j) of a positively oriented tetrahedron, read
// outward, is the cycle (f, x, y) for any f != j. Outward cycles: face 0 (1, 3, 2), face 1 (0, 2, 3),
// face 2 (0, 3, 1), face 3 (0, 1, 2) (an even permutation puts the opposite vertex last; orient3d > 0
// means the first three turn counter-clockwise seen from outside).
constexpr unsigned kForwardEdge[4][4][2] = {
    {{0, 0}, {3, 2}, {1, 3}, {2, 1}},
    {{2, 3}, {0, 0}, {3, 0}, {0, 2}},
    {{3, 1}, {0, 3}, {0, 0}, {1, 0}},
    {{1, 2}, {2, 0}, {0, 1}, {0, 0}},
};

// kFaceLinks[f]: for a new tetrahedron whose boundary face is opposite position f (the new point at
// f), its three faces through the new point, each as {j, x, y}: face j passes the boundary edge from
// position x to position y, read outward (kOtherThree and kForwardEdge combined: one load, not two
// dependent ones, in the linking's inner loop).
struct FaceLink {
  std::uint8_t j, x, y;
};
struct FaceLinkTable {
  FaceLink at[4][3];
};
constexpr FaceLinkTable makeFaceLinks() {
  FaceLinkTable t{};
  for (unsigned f = 0; f < 4; ++f)
    for (unsigned i = 0; i < 3; ++i) {
      const unsigned j = kOtherThree[f][i];
      t.at[f][i] = {static_cast<std::uint8_t>(j), static_cast<std::uint8_t>(kForwardEdge[j][f][0]),
                    static_cast<std::uint8_t>(kForwardEdge[j][f][1])};
    }
  return t;
}
constexpr FaceLinkTable kFaceLinks = makeFaceLinks();

}  // namespace

void Triangulation3D::setPoints(const Vec3f* points, std::size_t n) {
  if (n > kMaxVertices)
    throw Error("dw::Triangulation3D: " + std::to_string(n) + " points exceed the kernel's limit of " +
                std::to_string(kMaxVertices));
  if (n > 0 && points == nullptr) throw Error("dw::Triangulation3D: null point array");
  points_ = points;
  num_points_ = n;
  if (vertex_tet_.size() < n) vertex_tet_.resize(n, kNoVertexTet);
}

void Triangulation3D::reserveSlots(std::size_t slots) {
  tet_v_.reserve(4 * slots);
  // A quarter more address space for the adjacency: its storage becomes the edge extraction's lists
  // (listByRange's donor), which hold each tetrahedron once per range of its three smallest ids, ~1.1
  // to 1.15 times the tetrahedra (since session 20 the infinite ones too: one per hull facet, few). Without
  // it the dragon's lists (8.2 per point) outgrew the 8 slots per point reserved and went into a new array,
  // 14k pages to map afresh. Untouched pages cost address space only.
  tet_n_.reserve(4 * (slots + slots / 4));
  mark_.reserve(slots);
}

index_t Triangulation3D::newTet() {
  ensureFreeSlots(1);
  const index_t t = free_.back();
  free_.pop_back();
  return t;
}

void Triangulation3D::ensureFreeSlots(std::size_t count) {
  while (free_.size() < count) {
    // Grown kNewTetBatch slots at a time, which go on the free list lowest on top (so they are taken
    // in order): one slot at a time, the three arrays' resizes cost 3 % of a build's instructions.
    constexpr std::size_t kNewTetBatch = 64;
    const std::size_t t = tet_v_.size() / 4;
    if (t + kNewTetBatch > (std::size_t(1) << 30))
      throw Error("dw::Triangulation3D: more than 2^30 tetrahedra (neighbour codes are 32-bit)");
    // Grow by a quarter rather than doubling: the arrays are most of the peak memory.
    if (4 * (t + kNewTetBatch) > tet_v_.capacity()) reserveSlots(t + t / 4 + kNewTetBatch);
    resizeSlots(t + kNewTetBatch);
    if (track_births_) birth_.resize(t + kNewTetBatch, static_cast<std::uint32_t>(num_inserted_));
    for (std::size_t k = t + kNewTetBatch; k-- > t;) free_.push_back(static_cast<index_t>(k));
  }
}

void Triangulation3D::initialTetrahedron(index_t a, index_t b, index_t c, index_t d) {
  double pa[3], pb[3], pc[3], pd[3];
  point(a, pa);
  point(b, pb);
  point(c, pc);
  point(d, pd);
  if (predicates::orient3d(pa, pb, pc, pd) < 0.0) std::swap(a, b);
  const index_t base[4] = {a, b, c, d};
  for (int k = 0; k < 5; ++k) newTet();
  std::copy(base, base + 4, &tet_v_[0]);
  for (unsigned i = 0; i < 4; ++i) {
    // Replace v_i by infinity; swapping two other vertices makes the far side of the facet positive.
    index_t* v = &tet_v_[4 * std::size_t(i + 1)];
    std::copy(base, base + 4, v);
    v[i] = kInfinite;
    std::swap(v[(i + 1) % 4], v[(i + 2) % 4]);
  }
  // Five tetrahedra: match faces by their vertex sets.
  auto faceSet = [&](index_t t, unsigned f) {
    std::array<index_t, 3> s{};
    unsigned k = 0;
    for (unsigned j = 0; j < 4; ++j)
      if (j != f) s[k++] = tet_v_[4 * std::size_t(t) + j];
    std::sort(s.begin(), s.end());
    return s;
  };
  for (index_t t = 0; t < 5; ++t)
    for (unsigned f = 0; f < 4; ++f)
      for (index_t u = 0; u < 5; ++u)
        for (unsigned g = 0; g < 4; ++g)
          if (u != t && faceSet(t, f) == faceSet(u, g)) tet_n_[4 * std::size_t(t) + f] = 4 * u + g;
  last_tet_ = 0;
}

void Triangulation3D::build(const index_t* order, std::size_t n,
                             const std::function<void(double)>& progress) {
  build(order, n, progress, {}, 1);
}

void Triangulation3D::build(const index_t* order, std::size_t n, const std::function<void(double)>& progress,
                             const std::vector<std::size_t>& batch_begin, unsigned num_threads) {
  buildBatches(order, n, progress, batch_begin, num_threads, nullptr);
}

void Triangulation3D::build(std::vector<index_t>&& order, const std::function<void(double)>& progress,
                             const std::vector<std::size_t>& batch_begin, unsigned num_threads) {
  buildBatches(order.data(), order.size(), progress, batch_begin, num_threads, &order);
}

void Triangulation3D::buildBatches(const index_t* order, std::size_t n,
                                    const std::function<void(double)>& progress,
                                    const std::vector<std::size_t>& batch_begin, unsigned num_threads,
                                    std::vector<index_t>* owned) {
  if (points_ == nullptr && n > 0) throw Error("dw::Triangulation3D::build: setPoints() was not called");
  tet_v_.clear();
  tet_n_.clear();
  mark_.clear();
  free_.clear();
  birth_.clear();
  num_inserted_ = 0;
  stats_ = Stats{};
  seq_ = Worker{};
  if (n < 4) throw Error("dw::Triangulation3D::build: a 3D triangulation needs at least 4 points");
  for (std::size_t i = 0; i < n; ++i)
    if (order[i] >= num_points_) throw Error("dw::Triangulation3D::build: vertex id out of range");

  // The first tetrahedron: order[0], order[1] (distinct by contract), then the first point off
  // their line, then the first point off their plane.
  if (points_[order[0]].x == points_[order[1]].x && points_[order[0]].y == points_[order[1]].y &&
      points_[order[0]].z == points_[order[1]].z)
    throw Error("dw::Triangulation3D::build: duplicate points (the input must be distinct)");
  std::size_t first[4];
  const int dim = affineSpan(points_, order, n, first);
  if (dim < 2) throw Error("dw::Triangulation3D::build: all points are collinear (not a 3D set)");
  if (dim < 3) throw Error("dw::Triangulation3D::build: all points are coplanar (not a 3D set)");
  const std::size_t kc = first[2], kd = first[3];  // first[1] is 1: order[1] differs from order[0]

  // ~6.75 per vertex on volumetric input, more on surfaces and with recycled slots; reserving 8 avoids
  // a late reallocation, which would hold old and new arrays at once (measured 324 B/point at 4M
  // points against 216 at 1M; the dragon 336 B/point with 7, 276 with 8). Pages never touched cost
  // address space only.
  const std::size_t expected_tets = n * 8 + 64;
  reserveSlots(expected_tets);
  initialTetrahedron(order[0], order[1], order[kc], order[kd]);
  num_inserted_ = 4;

  // Batches (BRIO rounds): each is inserted by insertParallel, which runs threads when it is big
  // enough; positions before the first batch go in one by one.
  std::vector<std::size_t> begin;
  for (std::size_t b : batch_begin)
    if (b > 2 && b < n && (begin.empty() || b > begin.back())) begin.push_back(b);
  begin.push_back(n);
  const std::size_t report_every = std::max<std::size_t>(1, n / 100);
  for (std::size_t i = 2; i < begin.front(); ++i) {
    if (i == kc || i == kd) continue;
    insert(order[i]);
    if (progress && i % report_every == 0) progress(static_cast<double>(i) / n);
  }
  // Each batch is copied (without the first tetrahedron's vertices) and handed over as the batch's
  // pending list. The last one is half the points: an order we own is freed before it goes in.
  for (std::size_t r = 0; r + 1 < begin.size(); ++r) {
    std::vector<index_t> batch;
    batch.reserve(begin[r + 1] - begin[r]);
    for (std::size_t i = begin[r]; i < begin[r + 1]; ++i)
      if (i != kc && i != kd) batch.push_back(order[i]);
    if (owned != nullptr && r + 2 == begin.size()) {
      detail::freeScratch(*owned);  // its pages leave the process (a plain free kept them in the heap)
      order = nullptr;
    }
    insertBatch(std::move(batch), num_threads);
    if (progress) progress(static_cast<double>(begin[r + 1]) / n);
  }
  if (progress) progress(1.0);
}

void Triangulation3D::Stats::add(const Stats& o) {
  walk_steps += o.walk_steps;
  conflict_tests += o.conflict_tests;
  created_tets += o.created_tets;
  fallback_locations += o.fallback_locations;
  deferred += o.deferred;
  parallel_passes += o.parallel_passes;
  parallel_inserted += o.parallel_inserted;
  parallel_seconds += o.parallel_seconds;
  parallel_busy_max += o.parallel_busy_max;
  parallel_busy_sum += o.parallel_busy_sum;
  parallel_setup_seconds += o.parallel_setup_seconds;
  handed_on += o.handed_on;
  rest_seconds += o.rest_seconds;
}

// The sequential insertion owns everything: no ownership checks, plain memory accesses.
struct Triangulation3D::Everything {
  static constexpr bool kShared = false;
  bool ownsVertex(index_t) const { return true; }
};

// The cells of one parallel pass: a k-d split of the pending points, one leaf per thread, each with
// the same number of points. Nodes are {direction, split, child below, child at or above}; direction
// -1 marks a leaf, whose `below` is the thread.
//
// Every pass after the first cuts along other directions. What a pass defers lies in thin sheets along
// its cuts; a later pass that cut along the same directions put its medians into those very sheets
// (measured at 16 threads on 1M points: third passes that inserted 11-17 % of their points, even with
// the cuts moved to gaps beside the sheets, which only placed them at a sheet's edge). Cut along other
// directions, an earlier sheet spreads over the whole range of the new coordinate, and only the lines
// where a new cut crosses it are deferred again (third passes then insert ~74 %). The directions have
// small integer components, so a float point's coordinate along one (three exact products summed in
// double in a fixed order) is the same wherever it is computed, with or without fused multiply-adds:
// every call site agrees on who owns a vertex.
struct Triangulation3D::CellSplit {
  struct Node {
    int direction;
    double split;
    unsigned below, above;
  };
  std::vector<Node> nodes;
  const double (*directions)[3] = nullptr;

  // Pass 0 cuts along the axes, later passes along orthogonal triples with one body diagonal each.
  // What two passes in a row leave lies along the line where their first cuts cross; the next pass's
  // first direction is independent of theirs, so its cut crosses that line instead of containing it
  // (in the former order, (1,0,0), (1,1,1) then (-1,1,1): two threads' third pass inserted 26 % of the
  // points left, in this order 93 %).
  static constexpr double kDirections[5][3][3] = {
      {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},    {{1, 1, 1}, {1, -1, 0}, {1, 1, -2}},
      {{1, -1, 1}, {1, 0, -1}, {1, 2, 1}},  {{-1, 1, 1}, {0, 1, -1}, {2, 1, 1}},
      {{1, 1, -1}, {1, 0, 1}, {1, -2, -1}},
  };

  double coordinate(const Vec3f& p, int direction) const {
    // Pass 0 reads the point's own coordinate (every point's cell is found once per pass, and a sparse
    // pass descends at each of its ~40 ownership tests per insertion).
    if (directions == kDirections[0]) return direction == 0 ? p.x : direction == 1 ? p.y : p.z;
    const double* d = directions[direction];
    return double(p.x) * d[0] + double(p.y) * d[1] + double(p.z) * d[2];
  }

  unsigned cellOf(const Vec3f& p) const {
    unsigned i = 0;
    while (nodes[i].direction >= 0)
      i = coordinate(p, nodes[i].direction) < nodes[i].split ? nodes[i].below : nodes[i].above;
    return nodes[i].below;
  }

  // The cells of pass `pass`: points[0..m) split among `count` threads, level by level. A segment is
  // split at the median of its coordinates along the level's direction (points equal to it go above),
  // its first `count / 2` threads below; the segments of a level are split on up to `workers` threads.
  // Each segment's keys are computed once, not at each comparison of the selection (a pass's cut, on
  // one thread, took 2-6 ms of its set-up on 16 device threads).
  void build(const Vec3f* points, std::size_t m, unsigned count, unsigned pass, unsigned workers) {
    nodes.assign(1, {-1, 0.0, 0, 0});
    directions = kDirections[pass == 0 ? 0 : 1 + (pass - 1) % 4];
    struct Segment {
      unsigned node;
      std::size_t begin, end;  // of `order`
      unsigned first, count;   // threads
    };
    std::vector<index_t> order(m);
    std::iota(order.begin(), order.end(), index_t(0));
    std::vector<Segment> level{{0, 0, m, 0, count}};
    for (unsigned depth = 0; !level.empty(); ++depth) {
      const int direction = static_cast<int>(depth % 3);
      std::vector<double> at(level.size());
      std::vector<std::size_t> cut(level.size());
      // Small samples stay on this thread: starting threads (no team in scope) would cost more.
      parallelFor(level.size(), m >= 16384 ? workers : 1u, [&](std::size_t b, std::size_t e, unsigned) {
        std::vector<std::pair<double, index_t>> keyed;
        for (std::size_t i = b; i < e; ++i) {
          const Segment& g = level[i];
          const std::size_t n = g.end - g.begin;
          if (g.count <= 1 || n < 2) continue;
          keyed.resize(n);
          for (std::size_t j = 0; j < n; ++j) {
            const index_t v = order[g.begin + j];
            keyed[j] = {coordinate(points[v], direction), v};
          }
          const std::size_t k = n * (g.count / 2) / g.count;
          std::nth_element(keyed.begin(), keyed.begin() + k, keyed.end(),
                           [](const auto& x, const auto& y) { return x.first < y.first; });
          at[i] = keyed[k].first;
          // Below first, then at or above (keeping the counts as even as ties allow).
          std::size_t below = g.begin;
          for (const auto& q : keyed)
            if (q.first < at[i]) order[below++] = q.second;
          cut[i] = below;
          for (const auto& q : keyed)
            if (!(q.first < at[i])) order[below++] = q.second;
        }
      });
      std::vector<Segment> next;
      for (std::size_t i = 0; i < level.size(); ++i) {
        const Segment& g = level[i];
        if (g.count <= 1 || g.end - g.begin < 2) {
          nodes[g.node] = {-1, 0.0, g.first, g.first};
          continue;
        }
        const unsigned left = g.count / 2;
        const unsigned below = static_cast<unsigned>(nodes.size()), above = below + 1;
        nodes.push_back({-1, 0.0, 0, 0});
        nodes.push_back({-1, 0.0, 0, 0});
        nodes[g.node] = {direction, at[i], below, above};
        next.push_back({below, g.begin, cut[i], g.first, left});
        next.push_back({above, cut[i], g.end, g.first + left, g.count - left});
      }
      level.swap(next);
    }
  }
};

// A thread of a parallel pass owns the vertices in its cell, and the tetrahedra whose four vertices
// it owns; the infinite vertex counts as everybody's. Only the owner changes a tetrahedron's vertices.
// A thread writes a neighbour code only across a face whose vertices it owns, and two faces of one
// tetrahedron always share a finite vertex, so every such code has one writer. A thread reads only
// tetrahedra it owns or that nobody owns (all share an owned face with one it owns), which nobody else
// writes, so those reads are plain; so are all neighbour codes, since no thread reads another's. The
// exceptions are a walk's start, a tetrahedron found through vertex_tet_ (ownsTet, startAtVertex),
// which may be another thread's: those reads, and every write of a vertex slot or of vertex_tet_ that
// they may meet, are relaxed atomics (plain moves on x86, but defined behaviour and TSan-clean).
struct Triangulation3D::Cell {
  static constexpr bool kShared = true;
  const CellSplit* split = nullptr;
  const Vec3f* points = nullptr;
  const std::uint8_t* cell_of = nullptr;  // every point's cell in this pass, when the pass has one
  std::size_t n = 0;
  unsigned me = 0;
  bool ownsVertex(index_t v) const {
    if (v >= n) return v == kInfinite;  // not kDead
    return cellOf(v) == me;
  }
  unsigned cellOf(index_t v) const { return cell_of != nullptr ? cell_of[v] : split->cellOf(points[v]); }
};

namespace {

template <bool kShared>
inline std::uint32_t load(const std::uint32_t& x) {
  if constexpr (kShared) return __atomic_load_n(&x, __ATOMIC_RELAXED);
  return x;
}

template <bool kShared>
inline void store(std::uint32_t& x, std::uint32_t value) {
  if constexpr (kShared)
    __atomic_store_n(&x, value, __ATOMIC_RELAXED);
  else
    x = value;
}

// Whether a tetrahedron's four vertex ids hold kInfinite (all ones): one compare of the four at once,
// asked ~43 times per inserted point (four compares and branches took ~12 instructions).
inline bool hasInfiniteVertex(const index_t* tv) {
#if defined(__SSE2__)
  const __m128i ids = _mm_loadu_si128(reinterpret_cast<const __m128i*>(tv));
  return _mm_movemask_epi8(_mm_cmpeq_epi32(ids, _mm_set1_epi32(-1))) != 0;
#else
  return tv[0] == Triangulation3D::kInfinite || tv[1] == Triangulation3D::kInfinite ||
         tv[2] == Triangulation3D::kInfinite || tv[3] == Triangulation3D::kInfinite;
#endif
}

inline unsigned nextRandom(std::uint32_t& rng) {
  rng ^= rng << 13;
  rng ^= rng >> 17;
  rng ^= rng << 5;
  return rng & 3u;
}

// A parallel pass gives up on a walk after this many steps (a foreign region changing underneath).
constexpr std::uint64_t kSharedWalkGuard = 4096;
// Nearby ids tried as walk starts when a parallel walk leaves the thread's tetrahedra.
constexpr index_t kRestartCandidates = 6;
// Fresh slots handed to a thread at a time. Only taken chunks are written (and so mapped); a thread's
// last chunk is partly unused, and with 1024 (when the whole range was written up front) the pass's
// slack of three chunks per thread held 4 B/pt of the dragon's peak at 16 threads.
constexpr std::size_t kSlotChunk = 256;
// Pending points sampled for a pass's cuts (at most about this many).
constexpr std::size_t kSplitSample = 1 << 15;

}  // namespace

template <class Owner>
bool Triangulation3D::ownsTet(index_t t, const Owner& own) const {
  if constexpr (!Owner::kShared) {
    return true;
  } else {
    for (unsigned k = 0; k < 4; ++k)
      if (!own.ownsVertex(load<true>(tet_v_[4 * std::size_t(t) + k]))) return false;
    return true;
  }
}

index_t Triangulation3D::locate(index_t v, index_t start) {
  return locateInline<false>(v, start);
}

template <bool kStopInConflict>
index_t Triangulation3D::locateInline(index_t v, index_t start) {
  double p[3];
  point(v, p);
  index_t t = start;
  if (t >= tet_v_.size() / 4 || tet_v_[4 * std::size_t(t)] == kDead) t = last_tet_;
  if (t >= tet_v_.size() / 4 || tet_v_[4 * std::size_t(t)] == kDead) {
    // After a parallel pass the remembered tetrahedron may be gone: any live one will do.
    t = 0;
    while (t + 1 < tet_v_.size() / 4 && tet_v_[4 * std::size_t(t)] == kDead) ++t;
  }
  // The visibility walk terminates in a Delaunay triangulation; the guard only protects against a
  // corrupted structure and falls back to a scan that cannot loop.
  const std::uint64_t guard = 64 + 4 * static_cast<std::uint64_t>(tet_v_.size() / 4);
  const index_t found = walkTo<kStopInConflict>(p, t, seq_, Everything{}, guard);
  stats_.walk_steps += seq_.stats.walk_steps;
  seq_.stats.walk_steps = 0;
  if (found != kNoTet) return found;
  ++stats_.fallback_locations;
  return locateByScan(v);
}

template <bool kStopInConflict, class Owner>
index_t Triangulation3D::walkTo(const double* p, index_t t, Worker& w, const Owner& own,
                                 std::uint64_t guard) const {
  // With a sharing owner: only through owned tetrahedra (stable under this thread). A walk that would
  // leave them ends at a point whose cavity would not be owned either, almost always, so the caller
  // defers the point at once.
  if (!ownsTet(t, own)) return kNoTet;
  const predicates::BroadcastPoint query(p);
  for (std::uint64_t steps = 0; steps < guard; ++steps) {
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    unsigned infinite = 4;
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] == kInfinite) infinite = k;
    if (infinite != 4) {
      if (steps > 0) return t;  // beyond the hull: the cavity starts here
      // A start on the hull: go to the finite side first (and test the way back like any face: the
      // point may lie beyond this very facet).
      const std::uint32_t nc = tet_n_[4 * std::size_t(t) + infinite];
      if (!own.ownsVertex(tet_v_[nc])) return kNoTet;
      t = nc >> 2;
      continue;
    }
    double o[4];
    w.stats.walk_steps += 1;
    const Vec3f &q0 = points_[tv[0]], &q1 = points_[tv[1]], &q2 = points_[tv[2]], &q3 = points_[tv[3]];
    if constexpr (kStopInConflict) {
      // An insertion needs a tetrahedron in conflict, not the one holding p: the cavity is connected,
      // so its search may start from any. The first one whose circumsphere holds p strictly (as the
      // filter decides; the sign is then exact) ends the walk, a few steps before the cavity's middle.
      // Such a sphere is empty, so p repeats no vertex. The insphere shares the orientations' differences.
      if (predicates::insideSphereOrFacesLanes(q0, q1, q2, q3, query, o)) return t;
    } else {
      predicates::orient3dFacesLanes(q0, q1, q2, q3, query, o);
    }
    const unsigned r = nextRandom(w.rng);
    // The first face, from a random one on, with p strictly beyond it (the face back to where the
    // walk came from is not: p was strictly beyond it from the other side). Picked from a bit mask
    // rather than by testing faces in turn: which faces are negative is a coin flip for the branch
    // predictor (~5 simulated mispredictions per inserted point).
    const unsigned negative = unsigned(o[0] < 0.0) | unsigned(o[1] < 0.0) << 1 | unsigned(o[2] < 0.0) << 2 |
                              unsigned(o[3] < 0.0) << 3;
    if (negative == 0) return t;
    const unsigned rotated = ((negative | negative << 4) >> r) & 15u;  // bit k: face (r + k) & 3
    const unsigned f = (r + static_cast<unsigned>(__builtin_ctz(rotated))) & 3u;
    const std::uint32_t nc = tet_n_[4 * std::size_t(t) + f];
    // The neighbour shares three owned vertices with t: it is owned when the fourth one is (and owned
    // by nobody else either way, so nobody writes it: a plain read).
    if (!own.ownsVertex(tet_v_[nc])) return kNoTet;
    t = nc >> 2;
  }
  return kNoTet;
}

index_t Triangulation3D::locateByScan(index_t v) const {
  const std::size_t nt = tet_v_.size() / 4;
  double p[3];
  point(v, p);
  const predicates::BroadcastPoint query(p);
  for (index_t t = 0; t < nt; ++t)
    if (tet_v_[4 * std::size_t(t)] != kDead && inConflict(t, v, query)) return t;
  throw Error("dw::Triangulation3D: no tetrahedron conflicts with vertex " + std::to_string(v) +
              " (duplicate point or corrupted triangulation)");
}

// Both conflict tests are inlined into the cavity search, which runs ~43 per inserted point: the
// finite case first, since the infinite tetrahedra are a sliver of the mesh; the simulated-simplicity
// tie and the hull's test stay out of line.
[[gnu::always_inline]] inline bool Triangulation3D::finiteInConflict(
    index_t t, index_t v, const predicates::BroadcastPoint& e) const {
  const index_t* tv = &tet_v_[4 * std::size_t(t)];
  const Vec3f &a = points_[tv[0]], &b = points_[tv[1]], &c = points_[tv[2]], &d = points_[tv[3]];
  double det;
  if (__builtin_expect(predicates::insphereLanesFilter(a, b, c, d, e, det), 1)) return det > 0.0;
  const double s = predicates::detail::insphereTailOfFloats(a, b, c, d, e.p);
  if (s != 0.0) return s > 0.0;
  double pa[3], pb[3], pc[3], pd[3];
  point(tv[0], pa);
  point(tv[1], pb);
  point(tv[2], pc);
  point(tv[3], pd);
  return predicates::insphereSoS(pa, pb, pc, pd, e.p, tv[0], tv[1], tv[2], tv[3], v) > 0;
}

[[gnu::always_inline]] inline bool Triangulation3D::inConflict(index_t t, index_t v,
                                                                const predicates::BroadcastPoint& p) const {
  if (__builtin_expect(!hasInfiniteVertex(&tet_v_[4 * std::size_t(t)]), 1)) return finiteInConflict(t, v, p);
  return infiniteInConflict(t, v, p);
}

bool Triangulation3D::infiniteInConflict(index_t t, index_t v,
                                          const predicates::BroadcastPoint& query) const {
  const double* p = query.p;
  const index_t* tv = &tet_v_[4 * std::size_t(t)];
  unsigned k = 0;
  while (tv[k] != kInfinite) ++k;
  // In conflict when v lies strictly beyond the hull facet. When v is coplanar with the facet, the
  // facet survives exactly when v is outside the facet's (perturbed) circumcircle, which is the
  // conflict test of the finite tetrahedron behind it; deciding both the same way keeps the cavity
  // connected and never creates a flat tetrahedron.
  double q[4][3];
  for (unsigned j = 0; j < 4; ++j) {
    if (j == k) {
      q[j][0] = p[0];
      q[j][1] = p[1];
      q[j][2] = p[2];
    } else {
      point(tv[j], q[j]);
    }
  }
  const double o = predicates::orient3d(q[0], q[1], q[2], q[3]);
  if (o != 0.0) return o > 0.0;
  return finiteInConflict(tet_n_[4 * std::size_t(t) + k] >> 2, v, query);
}

void Triangulation3D::sizeSlotsUnwritten(std::size_t slots) {
  tet_v_.resize(4 * slots);
  tet_n_.resize(4 * slots);
  mark_.resize(slots);
}

void Triangulation3D::resizeSlots(std::size_t slots) {
  const std::size_t old = tet_v_.size() / 4;
  sizeSlotsUnwritten(slots);
  // No other thread runs here (the sequential insertion, or between passes): plain fills, which the
  // compiler vectorises; slot by slot through clearSlot's atomic stores they were ~230 instructions
  // per inserted point.
  if (slots > old) {
    std::fill(tet_v_.begin() + 4 * old, tet_v_.end(), kDead);
    std::fill(tet_n_.begin() + 4 * old, tet_n_.end(), 0u);
    std::fill(mark_.begin() + old, mark_.end(), Mark::kUnknown);
  }
}

void Triangulation3D::clearSlot(std::size_t t) {
  for (unsigned j = 0; j < 4; ++j) {  // atomic like every write another thread may read
    store<true>(tet_v_[4 * t + j], kDead);
    store<true>(tet_n_[4 * t + j], 0);
  }
  mark_[t] = Mark::kUnknown;
}

bool Triangulation3D::takeSlots(Worker& w, std::size_t count) {
  // The pass's slot pool is the recycled slots (pool_, sorted) followed by the fresh range
  // [fresh_begin_, fresh_end_); threads take it in chunks as they need it.
  const std::size_t recycled = pool_.size(), total = recycled + (fresh_end_ - fresh_begin_);
  while (w.free.size() < count) {
    const std::size_t first = __atomic_fetch_add(&pool_next_, kSlotChunk, __ATOMIC_RELAXED);
    if (first >= total) return false;
    for (std::size_t k = first; k < std::min(first + kSlotChunk, total); ++k) {
      if (k < recycled) {
        w.free.push_back(pool_[k]);
        continue;
      }
      // The fresh range was sized unwritten. Only the mark is read before the slot becomes a
      // tetrahedron, whose creation writes everything else; a slot left unused is cleared when the
      // pass ends (clearing each one here, through atomic stores, cost ~210 instructions per point).
      const std::size_t t = fresh_begin_ + (k - recycled);
      mark_[t] = Mark::kUnknown;
      w.free.push_back(static_cast<index_t>(t));
    }
  }
  return true;
}

template <bool kShared>
index_t Triangulation3D::vertexTet(index_t u) const {
  return u < num_points_ ? load<kShared>(vertex_tet_[u]) : kNoVertexTet;  // also catches v - j wrapping
}

template <class Owner>
index_t Triangulation3D::startAtVertex(index_t u, const Owner& own) const {
  const index_t s = vertexTet<Owner::kShared>(u);
  return startHolds(s, u, own) ? s : kNoTet;
}

template <class Owner>
bool Triangulation3D::startHolds(index_t s, index_t u, const Owner& own) const {
  if (s >= kNoVertexTet) return false;  // not inserted yet
  if constexpr (Owner::kShared) {
    // Only a tetrahedron this thread owns, and one that still holds u (vertex removal may leave
    // vertex_tet_ stale); locate() checks a sequential start itself.
    if (s >= tet_v_.size() / 4 || !ownsTet(s, own)) return false;
    const index_t* sv = &tet_v_[4 * std::size_t(s)];
    if (load<true>(sv[0]) != u && load<true>(sv[1]) != u && load<true>(sv[2]) != u && load<true>(sv[3]) != u)
      return false;
  }
  return true;
}

template <class Owner>
index_t Triangulation3D::walkStart(index_t v, const double* p, const Worker& w, const Owner& own) const {
  // The last insertion's tetrahedron, or one holding a vertex whose id is next to v's, whichever
  // vertex is nearer to v. Ids follow a space-filling curve (buildDelaunayGraph), and in a BRIO round
  // the last insertion lies about the round's spacing away, an inserted id neighbour about the whole
  // cloud's (1M uniform points: 9.0 -> 7.3 walk steps per point in the last rounds). Comparing
  // distances keeps ids that follow no curve from costing long walks.
  auto distance2 = [&](index_t u) {
    const Vec3f& q = points_[u];
    const double dx = q.x - p[0], dy = q.y - p[1], dz = q.z - p[2];
    return dx * dx + dy * dy + dz * dz;
  };
  index_t start = w.last_tet;
  double best = w.last_vertex < num_points_ ? distance2(w.last_vertex) : HUGE_VAL;
  for (index_t k = 1; k <= 4; ++k) {
    const index_t u = (k & 1) ? v - (k + 1) / 2 : v + (k + 1) / 2;  // v-1, v+1, v-2, v+2
    // The distance first: a parallel pass's check of the start (its ownership, that it holds u) reads
    // a tetrahedron, and with the distance first it is made for ~1.4 candidates per point, not ~4.
    const index_t s = vertexTet<Owner::kShared>(u);
    if (s >= kNoVertexTet) continue;
    const double d = distance2(u);
    if (d >= best || !startHolds(s, u, own)) continue;
    best = d;
    start = s;
  }
  return start;
}

template <class Owner>
bool Triangulation3D::insertCore(index_t v, Worker& w, const Owner& own) {
  constexpr bool kShared = Owner::kShared;
  double p[3];
  point(v, p);
  index_t t;
  if constexpr (kShared) {
    const index_t start = walkStart(v, p, w, own);
    t = walkTo<true>(p, start, w, own, kSharedWalkGuard);
    // The start may lie across the cell (late passes hold scattered points), and a walk from there
    // often has to leave what this thread owns (measured: most deferrals at 16 threads). Ids follow a
    // space-filling curve, so a vertex with a nearby id is usually near v: walk again from a
    // tetrahedron holding it (vertex_tet_), if this thread owns it.
    for (index_t k = 1; t == kNoTet && k <= kRestartCandidates; ++k) {
      const index_t u = (k & 1) ? v + (k + 1) / 2 : v - (k + 1) / 2;  // v+1, v-1, v+2, ...
      const index_t s = startAtVertex(u, own);
      if (s != kNoTet && s != start) t = walkTo<true>(p, s, w, own, kSharedWalkGuard);
    }
    if (t == kNoTet || !ownsTet(t, own)) return false;
  } else {
    t = locateInline<true>(v, walkStart(v, p, w, own));
  }
  {
    // A walk that stops in a finite tetrahedron has v strictly inside its circumsphere: decided so, or
    // v lies in its closed hull and repeats none of its vertices. Checked instead of trusted: a wrong
    // root corrupts the mesh.
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    const Vec3f& pv = points_[v];
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == kInfinite) continue;
      const Vec3f& q = points_[tv[k]];
      if (q.x == pv.x && q.y == pv.y && q.z == pv.z)
        throw Error("dw::Triangulation3D::insert: vertex " + std::to_string(v) + " duplicates vertex " +
                    std::to_string(tv[k]));
    }
  }

  const predicates::BroadcastPoint query(p);
  // Cavity: every tetrahedron whose (perturbed) circumsphere contains v; connected, found by a
  // breadth-first search run level by level. Each level first visits the faces of the cavity
  // tetrahedra found by the last one, queueing every neighbour not seen before (marked queued) and
  // listing every face whose neighbour is not in the cavity as a candidate boundary face; then it
  // tests the queued neighbours, one after another. Whether a neighbour was seen before is a coin flip
  // (~19 of ~63 visits per point): tested at each visit, as before, that branch was mispredicted ~22
  // times per inserted point, more than all the insertion's other branches together. Queued, it is a
  // masked store; the levels' loop exits mispredict instead, a few times per cavity, and a candidate
  // is a boundary face when its neighbour ended outside (filtered after the search). Cachegrind, 100k
  // points: 40 -> 26 simulated mispredictions and 4 % more instructions per inserted point; 1M
  // points inserted 3 % faster on one thread. The visits and the tests come in the same order as in
  // a search that tests at each visit, so the cavity, the boundary and the new tetrahedra do too.
  // In a parallel pass a neighbour reached through a face of an owned tetrahedron holds that face's
  // three owned vertices: it is this thread's own, or nobody's (its fourth vertex foreign), and then
  // no other thread can reach it (no face of it holds three vertices of another cell). So its mark is
  // this thread's to use, and ownership need only be checked for the tetrahedra found in conflict,
  // when their faces are visited (~21 per point, not ~63 visits). The cavity list doubles as the
  // search's queue of levels.
  auto& cavity = w.cavity;
  auto& boundary = w.boundary;
  // The arrays through raw pointers in locals (none is resized during the search): through the
  // members, every push and mark store made the compiler reload their data pointers.
  const index_t* const tet_v = tet_v_.data();
  const std::uint32_t* const tet_n = tet_n_.data();
  Mark* const mark = mark_.data();
  std::uint64_t tests = 0;
  // The search's lists are filled through raw pointers with their own counts, and every entry is
  // written to the list it may join, which then advances by a flag. The lists' element types are
  // trivial and their allocator leaves resized storage unwritten, so sizing a list to its capacity
  // costs nothing; room is made before each level for every face it may visit.
  auto& entry = w.cavity_entry;  // per cavity tetrahedron, the face it was reached through
  // Every neighbour queued (n * 4 + n's face towards the tetrahedron that queued it): the cavity
  // but its first tetrahedron, the tetrahedra found outside, and a level's still untested ones.
  auto& queued = w.queued;
  std::size_t num_cavity = 0, num_candidates = 0, num_queued = 0, num_tested = 0;
  index_t* cav = nullptr;
  std::uint32_t* que = nullptr;
  std::uint8_t* ent = nullptr;
  BoundaryFace* bnd = nullptr;
  std::size_t room = 0;  // entries every list can take before the next makeRoom
  // The check is inline, the growth out of line: as one lambda, the whole was called per cavity
  // tetrahedron (29 instructions a call; the split saves 1.2 % of a 50k-point build's instructions).
  // GNU attributes, which bind to the call operator: written [[gnu::...]] there they name the type,
  // which Clang ignores, and GCC called the check out of line in the parallel pass's version (1.2 %
  // of a 200k-point build's instructions on two threads).
  auto growLists = [&](std::size_t extra) __attribute__((noinline)) {
    auto grow = [](auto& list, std::size_t needed) {
      if (list.size() < needed) list.resize(std::max(list.capacity(), 2 * needed + 60));
      if (list.size() < list.capacity()) list.resize(list.capacity());
      return list.data();
    };
    const std::size_t needed = std::max({num_cavity, num_candidates, num_queued}) + extra;
    cav = grow(cavity, needed);
    ent = grow(entry, needed);
    bnd = grow(boundary, needed);
    que = grow(queued, needed);
    room = std::min({cavity.size(), entry.size(), boundary.size(), queued.size()});
  };
  auto makeRoom = [&](std::size_t extra) __attribute__((always_inline)) {
    if (std::max({num_cavity, num_candidates, num_queued}) + extra > room) growLists(extra);
  };
  auto clearMarks = [&] {  // one loop: each exit of a loop of varying length is mispredicted
    mark[t] = Mark::kUnknown;
    for (std::size_t k = 0; k < num_queued; ++k) mark[que[k] >> 2] = Mark::kUnknown;
  };
  makeRoom(4);
  mark[t] = Mark::kCavity;
  cav[num_cavity] = t;
  ent[num_cavity++] = 0;  // the first tetrahedron's face 0 is visited first, as if it came through it
  // Visits face f of cavity tetrahedron c (vertex ids cv), whose neighbour code is nc: queues the
  // neighbour if it is new and lists the face as a candidate unless the neighbour is in the cavity.
  auto visitFace = [&](const index_t* cv, unsigned f, std::uint32_t nc) __attribute__((always_inline)) {
    BoundaryFace& bf = bnd[num_candidates];
    for (unsigned j = 0; j < 4; ++j) bf.v[j] = cv[j];
    bf.v[f] = v;
    bf.outer = nc;
    const index_t n = nc >> 2;
    const Mark m = mark[n];
    const bool fresh = m == Mark::kUnknown;
    mark[n] = fresh ? Mark::kQueued : m;
    que[num_queued] = nc;
    num_queued += fresh;
    __builtin_prefetch(&tet_v[nc & ~3u]);  // tested below, if queued
    bf.face = f;
    num_candidates += m != Mark::kCavity;
  };
  auto abandon = [&] {
    clearMarks();
    w.stats.conflict_tests += tests;
    return false;
  };
  // Each cavity tetrahedron but the first was reached through one of its faces, whose neighbour is
  // in the cavity: only the other three are visited. The first one's face 0 is visited here, and
  // the first one then counts as reached through it: every tetrahedron has three faces to visit, a
  // loop of fixed length (with three or four, its end was mispredicted ~12 times per point in
  // cachegrind's simulation).
  {
    index_t cv[4];
    for (unsigned j = 0; j < 4; ++j) cv[j] = tet_v[4 * std::size_t(t) + j];
    visitFace(cv, 0, tet_n[4 * std::size_t(t)]);
  }
  for (std::size_t level = 0; level < num_cavity;) {
    const std::size_t level_end = num_cavity;
    makeRoom(3 * (level_end - level));
    cav[level_end] = t;  // read ahead by the level's last one (no test for a next one: no branch)
    for (std::size_t next = level; next < level_end; ++next) {
      const index_t c = cav[next];
      const unsigned* const faces = kOtherThree[ent[next]];
      // The neighbours are scattered over a structure far larger than the caches: start all their
      // loads now so that the misses overlap instead of following one another, and the next
      // tetrahedron's too.
      std::uint32_t ncs[3];
      for (unsigned i = 0; i < 3; ++i) ncs[i] = tet_n[4 * std::size_t(c) + faces[i]];
      {
        const std::uint32_t* ahead = &tet_n[4 * std::size_t(cav[next + 1])];
        for (unsigned i = 0; i < 4; ++i) __builtin_prefetch(&mark[ahead[i] >> 2]);
      }
      index_t cv[4];
      for (unsigned j = 0; j < 4; ++j) cv[j] = tet_v[4 * std::size_t(c) + j];
      // c shares the face it was reached through with an owned tetrahedron: it is owned when the
      // vertex opposite that face is. A foreign one in conflict defers v, before anything is changed
      // and before its faces lead anywhere another thread might be writing.
      if (Owner::kShared && !own.ownsVertex(cv[ent[next]])) return abandon();
#pragma GCC unroll 3
      for (unsigned i = 0; i < 3; ++i) visitFace(cv, faces[i], ncs[i]);
    }
    // The level's tests: independent of one another, and no branch depends on their outcome.
    for (std::size_t k = num_tested; k < num_queued; ++k) {
      const std::uint32_t nc = que[k];
      const index_t n = nc >> 2;
      ++tests;
      const bool in = inConflict(n, v, query);
      mark[n] = in ? Mark::kCavity : Mark::kOutside;
      cav[num_cavity] = n;
      ent[num_cavity] = static_cast<std::uint8_t>(nc & 3u);  // n's face towards the tetrahedron before
      num_cavity += in;
      __builtin_prefetch(&tet_n[nc], 1);  // re-linked to a new tetrahedron below, if outside
    }
    num_tested = num_queued;
    level = level_end;
  }
  // The boundary: the candidates whose neighbour ended outside, compacted in place.
  std::size_t num_boundary = 0;
  for (std::size_t k = 0; k < num_candidates; ++k) {
    const BoundaryFace bf = bnd[k];
    const bool keep = mark[bf.outer >> 2] == Mark::kOutside;
    bnd[num_boundary] = bf;
    num_boundary += keep;
  }
  cavity.resize(num_cavity);
  boundary.resize(num_boundary);
  w.stats.conflict_tests += tests;
  clearMarks();
  if constexpr (kShared) {
    if (boundary.size() > cavity.size() && !takeSlots(w, boundary.size() - cavity.size())) return false;
  }

  // The new tetrahedra: boundary face k with v is tetrahedron k, put in cavity slot k while there is
  // one, then in slots off the free list's top. Each face through v (v and a boundary edge) is shared
  // by the two new tetrahedra on the two boundary triangles of that edge: they find each other through
  // the edge, below. The slots are all taken first (the sequential free list may grow the arrays), so
  // that the writes go through raw pointers and counts in locals: with a slot taken per iteration, the
  // call made the compiler reload every vector's data and size (~500 instructions per point).
  const std::size_t nb = num_boundary, nc = num_cavity;
  index_t* const mk = atLeast(w.made, nb);
  const std::size_t reused = std::min(nb, nc);
  std::copy(cav, cav + reused, mk);
  if (nb > nc) {
    // A parallel pass's thread takes its own slots (takeSlots() above made sure it holds enough).
    std::vector<index_t>& free_list = kShared ? w.free : free_;
    if constexpr (!kShared) ensureFreeSlots(nb - nc);
    const index_t* top = free_list.data() + free_list.size();
    for (std::size_t k = nc; k < nb; ++k) mk[k] = *--top;
    free_list.resize(free_list.size() - (nb - nc));
  }
  if (track_births_)
    for (std::size_t k = 0; k < nb; ++k) birth_[mk[k]] = static_cast<std::uint32_t>(num_inserted_ + 1);
  writeNewTetrahedra<kShared>(w);
  w.stats.created_tets += boundary.size();
  for (std::size_t k = boundary.size(); k < cavity.size(); ++k) {
    store<kShared>(tet_v_[4 * std::size_t(cavity[k])], kDead);
    if constexpr (kShared)
      w.free.push_back(cavity[k]);
    else
      free_.push_back(cavity[k]);
  }
  w.last_tet = mk[nb - 1];
  w.last_vertex = v;
  store<true>(vertex_tet_[v], mk[nb - 1]);
  if constexpr (kShared)
    ++w.stats.parallel_inserted;
  else
    ++num_inserted_;
  return true;
}

namespace {
// Read once, at load time: even a function-local static's guard is a test on every insertion.
const bool kCpuHasX86_64V3 = detail::cpuHasX86_64V3();
}  // namespace

// The two compiled versions of the insertion (see DW_TARGET_V3): insertCore, locateInline, walkTo and
// writeNewTetrahedra are always inlined, so each wrapper holds a whole insertion built for its target.
template <class Owner>
bool Triangulation3D::insertCoreBaseline(index_t v, Worker& w, const Owner& own) {
  return insertCore(v, w, own);
}

template <class Owner>
DW_TARGET_V3 bool Triangulation3D::insertCoreV3(index_t v, Worker& w, const Owner& own) {
  return insertCore(v, w, own);
}

template <class Owner>
bool Triangulation3D::insertOnThisCpu(index_t v, Worker& w, const Owner& own) {
  return kCpuHasX86_64V3 ? insertCoreV3(v, w, own) : insertCoreBaseline(v, w, own);
}

void Triangulation3D::insert(index_t v) {
  if (!built()) throw Error("dw::Triangulation3D::insert: build() first");
  if (v >= num_points_) throw Error("dw::Triangulation3D::insert: vertex id out of range");
  seq_.last_tet = last_tet_;
  seq_.stats = Stats{};
  insertOnThisCpu(v, seq_, Everything{});
  last_tet_ = seq_.last_tet;
  stats_.add(seq_.stats);
}

template <bool kShared>
void Triangulation3D::writeNewTetrahedra(Worker& w) {
  // Each new tetrahedron is written whole where its face is read, in the loop that enters the face's
  // edges (as a loop of its own, one more pass over the boundary: 0.3 % of a build's instructions).
  // The boundary is a closed triangulated surface: each of its edges (x, y) lies in exactly two
  // boundary triangles, which pass it in opposite directions when both are read outward-oriented. The
  // new tetrahedron on one triangle enters its face through v under the directed edge x -> y in a hash
  // table, and finds its neighbour under y -> x: two passes, so that no branch asks whether the twin
  // came first (a coin flip). The table is nearly always ~2 % full (kLinkMinEntries), so a probe
  // nearly always ends at once. An entry is read once, by its twin, which then leaves a tombstone:
  // free for later insertions' entries, but passed over by this one's probes (an empty slot would end
  // them). (Session 13's hash linked in one pass and branched on whether the twin had come first.)
  //
  // Raw pointers in locals: through the vectors, every store (atomic ones above all) made the
  // compiler reload their data pointers and sizes in each iteration.
  const std::size_t nb = w.boundary.size();
  const BoundaryFace* boundary = w.boundary.data();
  const index_t* made = w.made.data();
  std::uint32_t* tet_n = tet_n_.data();
  index_t* tet_v = tet_v_.data();
  index_t* vertex_tet = vertex_tet_.data();
  const std::size_t num_edges = 3 * nb;
  if (w.link_keys.size() < kLinkLoad * num_edges) {
    const std::size_t size = std::max(std::size_t(1) << tableBits(kLinkLoad * num_edges), kLinkMinEntries);
    w.link_keys.resize(size, kNoLinkKey);  // free between insertions, so the table may simply grow
    w.link_codes.resize(size);
  }
  std::uint64_t* keys = w.link_keys.data();
  std::uint32_t* codes = w.link_codes.data();
  const unsigned bits = static_cast<unsigned>(__builtin_ctzll(w.link_keys.size()));
  const std::size_t mask = w.link_keys.size() - 1;
  std::uint64_t* edge_key = atLeast(w.edge_keys, num_edges);
  std::uint32_t* edge_code = atLeast(w.edge_codes, num_edges);
  for (std::size_t k = 0; k < nb; ++k) {
    const BoundaryFace& bf = boundary[k];
    const FaceLink* links = kFaceLinks.at[bf.face];
    // In a local: read through the pointer, it was loaded again after each store below (which the
    // compiler must assume may alias it).
    const index_t nt = made[k];
    index_t* const ntv = &tet_v[4 * std::size_t(nt)];
    store<kShared>(ntv[0], bf.v[0]);  // written out: as a loop of atomic stores it stayed a loop
    store<kShared>(ntv[1], bf.v[1]);
    store<kShared>(ntv[2], bf.v[2]);
    store<kShared>(ntv[3], bf.v[3]);
    tet_n[4 * std::size_t(nt) + bf.face] = bf.outer;
    tet_n[bf.outer] = 4 * nt + bf.face;
#pragma GCC unroll 3
    for (unsigned i = 0; i < 3; ++i) {
      // Face j of the new tetrahedron passes through v and the boundary edge from its position x to
      // its position y, read outward.
      const index_t x = bf.v[links[i].x], y = bf.v[links[i].y];
      const std::uint64_t key = std::uint64_t(x) << 32 | y;
      std::size_t h = hashKey(key, bits);
      while (keys[h] < kLinkTombstone) h = (h + 1) & mask;  // taken by this insertion's entry
      const std::uint32_t code = 4 * nt + links[i].j;
      keys[h] = key;
      codes[h] = code;
      edge_key[3 * k + i] = key;
      edge_code[3 * k + i] = code;
      // Every vertex of a destroyed tetrahedron is on the boundary, so giving each boundary vertex (the
      // tail of some boundary edge) one of the new tetrahedra keeps vertex_tet_ exact (vertex removal
      // aside). The infinite vertex is everybody's and has no entry.
      if (x != kInfinite) store<kShared>(vertex_tet[x], nt);
    }
  }
  for (std::size_t e = 0; e < num_edges; ++e) {
    const std::uint64_t twin = edge_key[e] << 32 | edge_key[e] >> 32;  // y -> x
    std::size_t h = hashKey(twin, bits);
    for (std::size_t probes = 0; keys[h] != twin; h = (h + 1) & mask)
      if (++probes > mask) throw Error("dw::Triangulation3D: the cavity's boundary is not closed");
    tet_n[edge_code[e]] = codes[h];
    keys[h] = kLinkTombstone;
  }
}

void Triangulation3D::insertParallel(const index_t* ids, std::size_t m, unsigned num_threads) {
  if (!built()) throw Error("dw::Triangulation3D::insertParallel: build() first");
  if (track_births_) throw Error("dw::Triangulation3D::insertParallel: not with trackBirths(true)");
  for (std::size_t i = 0; i < m; ++i)
    if (ids[i] >= num_points_) throw Error("dw::Triangulation3D::insertParallel: vertex id out of range");
  insertBatch(std::vector<index_t>(ids, ids + m), num_threads);
}

void Triangulation3D::insertBatch(std::vector<index_t> pending, unsigned num_threads) {
  const std::size_t m = pending.size();
  detail::sortAdaptive(pending);
  // Small batches use fewer threads (min_points_per_thread_, see the header); two threads already
  // share a batch of half that many points. When a pass stalls (under a quarter of the points it tried
  // went in), the rest goes in on this thread: what is left then is held up by cavities that cross
  // cells whatever the cut (halving the threads instead inserted 1-3 % per pass at 16 threads, at four
  // times the sequential cost per point).
  const std::size_t min_per_thread = std::max<std::size_t>(1, min_points_per_thread_);
  constexpr unsigned kMaxPasses = 12;
  const std::size_t by_size = std::max<std::size_t>(m / min_per_thread, m >= min_per_thread / 2 ? 2 : 1);
  constexpr unsigned kMaxCells = 256;  // a pass's cell ids are bytes
  unsigned threads = static_cast<unsigned>(std::min<std::size_t>({num_threads, by_size, kMaxCells}));
  bool passes_ran = false;
  for (unsigned pass = 0; pass < kMaxPasses && threads > 1; ++pass) {
    if (pending.size() < threads * min_per_thread / 4)
      threads = static_cast<unsigned>(pending.size() * 4 / min_per_thread);
    if (threads < 2) break;
    const std::size_t before = pending.size(), handed_before = stats_.handed_on;
    runParallelPass(pending, threads, pass);
    passes_ran = true;
    const std::size_t handed = static_cast<std::size_t>(stats_.handed_on - handed_before);
    // The pass threads' heaps (glibc keeps one per thread) hold their freed lists and scratch. Given
    // back after every pass, not once per batch: the dragon's last batch takes 9 passes at 16 threads,
    // and what they kept raised its peak by 3-4 B/pt.
    releaseFreeHeap();
    // Stalled: under a quarter of the points tried went in (those handed on were not tried).
    if ((pending.size() - handed) * 4 > (before - handed) * 3) break;
  }
  // The passes' growth estimate is generous: the untaken tail of their last fresh range, prefaulted,
  // held 0.13 slots per point at 2-8 threads. Its pages go back to the system (later growth maps them
  // again); within a batch, the next pass reuses them as they are.
  detail::releaseUnused(tet_v_);
  detail::releaseUnused(tet_n_);
  detail::releaseUnused(mark_);
  detail::sortAdaptive(pending);
  const auto rest_start = std::chrono::steady_clock::now();
  for (index_t v : pending) insert(v);
  if (passes_ran)
    stats_.rest_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - rest_start).count();
}

void Triangulation3D::runParallelPass(std::vector<index_t>& pending, unsigned threads, unsigned pass) {
  const auto start = std::chrono::steady_clock::now();
  CellSplit split;
  {
    // The cuts come from an evenly strided sample (ids follow a space-filling curve, so it covers the
    // pending points' extent): the medians of the whole batch, found on one thread, took 0.09 s of a
    // 1M-point build on 16 threads; cells off balance by a fraction of a percent cost far less.
    // The sample's points are copied first: a later pass's points lie scattered over the cloud, and
    // the split, reading them where they lie, took 3-4 ms of such a pass on 16 device threads.
    const std::size_t stride = std::max<std::size_t>(1, pending.size() / kSplitSample);
    std::vector<Vec3f> sample((pending.size() + stride - 1) / stride);
    parallelFor(sample.size(), workerCount(sample.size(), threads, 4096),
                [&](std::size_t b, std::size_t e, unsigned) {
                  for (std::size_t j = b; j < e; ++j) sample[j] = points_[pending[j * stride]];
                });
    split.build(sample.data(), sample.size(), threads, pass, threads);
  }
  // Every point's cell, found once: ownership is tested ~40 times per insertion, each a descent of
  // the split tree (4 levels of projections at 16 threads; the device's 16-thread builds of 4M points
  // then took 15 % more thread time). Not for a pass that inserts few points into many (a sliding
  // window's update), which would pay for a byte per point to test a handful.
  std::vector<std::uint8_t> cell_of(pending.size() * 8 >= num_points_ ? num_points_ : 0);
  parallelFor(cell_of.size(), threads, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t v = b; v < e; ++v) cell_of[v] = static_cast<std::uint8_t>(split.cellOf(points_[v]));
  });
  std::vector<Cell> own(threads);
  std::vector<Worker> workers(threads);
  for (unsigned i = 0; i < threads; ++i)
    own[i] = {&split, points_, cell_of.empty() ? nullptr : cell_of.data(), num_points_, i};
  // The to-do lists, sized exactly (no list holds twice its points) and in id order per thread: ids
  // follow a space-filling curve, so consecutive walks are short. Slices of the pending list are
  // counted per cell, then copied to their offsets, both on all threads (one thread took 0.14 s of a
  // 4M-point build on 16).
  {
    const Cell& cells = own[0];  // any thread's view gives every point's cell
    detail::parallelBucket(
        pending.size(), workerCount(pending.size(), threads, 1 << 14), threads,
        [&](std::size_t k) { return cells.cellOf(pending[k]); },
        [&](const std::vector<std::size_t>& sizes) {
          for (unsigned i = 0; i < threads; ++i) workers[i].deferred.resize(sizes[i]);
        },
        [&](std::size_t k, unsigned i, std::size_t rank) { workers[i].deferred[rank] = pending[k]; });
  }
  const std::size_t points_in_pass = pending.size();
  detail::freeScratch(pending);  // held again by the to-do lists; refilled after the pass

  // Slots: the recycled ones first (sorted, so that a chunk is one part of the arrays and two threads
  // rarely write one cache line), then fresh ones for the rest of the growth (about 6.7 per point).
  // Counting the recycled ones keeps repeated passes from inflating the arrays.
  const std::size_t used = tet_v_.size() / 4;
  const std::size_t growth = 7 * points_in_pass + 2 * kSlotChunk * threads;
  const std::size_t fresh = (growth > free_.size() ? growth - free_.size() : 0) + kSlotChunk * threads;
  if (4 * (used + fresh) > tet_v_.capacity()) reserveSlots(used + fresh + (used + fresh) / 8);
  // The fresh range is only reserved here: a thread writes (and so maps) a chunk when it takes it
  // (takeSlots). Writing the range here, on one thread, took 0.13 s of a 4M-point build on 16 threads,
  // and faulting it in beforehand made the estimate's unused part resident (about 0.3 slots per point).
  sizeSlotsUnwritten(used + fresh);
  pool_.swap(free_);
  free_.clear();
  std::sort(pool_.begin(), pool_.end());
  pool_next_ = 0;
  fresh_begin_ = used;
  fresh_end_ = used + fresh;

  // Each thread starts from an owned tetrahedron holding one of its points, found by walks that only
  // read (this phase ends before any thread writes); its list is rotated to begin at that point.
  // Points at the start of a list lie near a cell's boundary, so the tries are spread over the list.
  parallelFor(threads, threads, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t i = b; i < e; ++i) {
      Worker& w = workers[i];
      w.rng = 0x9E3779B9u ^ static_cast<std::uint32_t>(i) * 0x85EBCA6Bu;
      w.last_tet = kNoTet;
      std::vector<index_t>& todo = w.deferred;
      constexpr std::size_t kTries = 16;
      index_t t = last_tet_;
      for (std::size_t k = 0; k < kTries && k < todo.size(); ++k) {
        const std::size_t j = (todo.size() / 2 + k * todo.size() / kTries) % todo.size();
        double p[3];
        point(todo[j], p);
        t = walkTo<false>(p, t, w, Everything{}, std::uint64_t(1) << 20);
        if (t == kNoTet) break;
        if (ownsTet(t, own[i])) {
          w.last_tet = t;
          std::rotate(todo.begin(), todo.begin() + j, todo.end());
          break;
        }
      }
    }
  });

  stats_.parallel_setup_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // The cells hold the same number of points, but the threads do not insert at the same speed (on the
  // 16-core device, one pass's threads were busy 99-184 ms for nearly equal work, and which ones were
  // slow changed from run to run). Once half of the threads that insert are through their lists, the
  // others stop, if they are half through theirs, and hand what they have not tried on to the next
  // pass, whose cells split it among all threads. A point handed on is only inserted later, so the
  // triangulation is the same. (The half-through condition keeps cells that ties in the coordinates
  // left uneven from handing on most of their points, pass after pass.)
  auto inserts = [](const Worker& w) { return w.last_tet != kNoTet && !w.deferred.empty(); };
  unsigned inserting = 0;
  for (const Worker& w : workers) inserting += inserts(w);
  const unsigned hand_on_after = (inserting + 1) / 2;
  std::atomic<unsigned> finished{0};
  // A worker that fails (a duplicate point) stops; the others finish, and the slots and counts of all
  // are merged before the error is passed on, so the triangulation stays valid and consistent.
  std::vector<std::exception_ptr> errors(threads);
  parallelFor(threads, threads, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t i = b; i < e; ++i) {
      Worker& w = workers[i];
      if (!inserts(w)) continue;
      std::vector<index_t> todo;
      todo.swap(w.deferred);
      const auto busy_start = std::chrono::steady_clock::now();
      std::size_t k = 0;
      try {
        for (; k < todo.size(); ++k) {
          if (k % 32 == 0 && 2 * k >= todo.size() &&
              finished.load(std::memory_order_relaxed) >= hand_on_after)
            break;
          if (!insertOnThisCpu(todo[k], w, own[i])) {
            w.deferred.push_back(todo[k]);
            ++w.stats.deferred;
          }
        }
        w.deferred.insert(w.deferred.end(), todo.begin() + k, todo.end());
        w.stats.handed_on += todo.size() - k;
      } catch (...) {
        errors[i] = std::current_exception();
      }
      finished.fetch_add(1, std::memory_order_relaxed);
      w.stats.parallel_busy_sum =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - busy_start).count();
      detail::freeScratch(todo);  // freed plainly, its pages stayed in this thread's heap
    }
  });

  pending.clear();
  double busy_max = 0.0;
  for (auto& w : workers) {
    busy_max = std::max(busy_max, w.stats.parallel_busy_sum);
    pending.insert(pending.end(), w.deferred.begin(), w.deferred.end());
    detail::freeScratch(w.deferred);
    for (index_t t : w.free)
      if (t >= fresh_begin_) clearSlot(t);  // taken from the fresh range but not used (takeSlots)
    free_.insert(free_.end(), w.free.begin(), w.free.end());
    num_inserted_ += w.stats.parallel_inserted;
    stats_.add(w.stats);
    if (w.stats.parallel_inserted > 0) last_tet_ = w.last_tet;
  }
  // What nobody took of the recycled slots goes back to the free list; the fresh range is cut where
  // the last chunk handed out ends (insertParallel gives the pages beyond back once the batch is in).
  const std::size_t recycled = pool_.size(), total = recycled + (fresh_end_ - fresh_begin_);
  const std::size_t taken = std::min(pool_next_, total);
  for (std::size_t k = taken; k < recycled; ++k) free_.push_back(pool_[k]);
  resizeSlots(fresh_begin_ + (taken > recycled ? taken - recycled : 0));
  std::vector<index_t>().swap(pool_);
  detail::freeScratch(cell_of);
  pool_next_ = fresh_begin_ = fresh_end_ = 0;
  ++stats_.parallel_passes;
  stats_.parallel_busy_max += busy_max;
  stats_.parallel_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

// Every edge (a, b), a < b, lies in ~5 finite tetrahedra. Rather than walking each vertex's star
// (random access into the tetrahedra: measured 5 s for 1M points), the tetrahedra are streamed:
//  1. cut [first, last) into ranges of a with the same number of vertices, so that each range's edge
//     occurrences (3 per tetrahedron, see below, spread over the vertices) fit a bounded buffer;
//  2. (listByRange) list, per range, the vertex quadruples, sorted, of the tetrahedra that have an
//     edge owned there (a tetrahedron has three possible smaller endpoints; with Morton ids they are
//     nearly always in one range, and such whole quadruples come first in each list);
//  3. (edgesOfRanges) per range, in parallel: count the occurrences per a, bucket the b's by a, drop
//     repeats, and write the range's chunk.
// A tetrahedron gives only those of its edges at which it is an ascent of the edge's ring. The
// tetrahedra around an edge (a, b) form a closed ring, each written positively as (a, b, x, y) with x
// and y consecutive other vertices (consistent orientation: two neighbours in the ring induce opposite
// orientations on their shared face, so every one of them reads the ring in the same direction, x
// before y). A closed ring of distinct ids rises somewhere (x < y), kInfinite counting as the largest
// id, so every edge is given at least once, and about half as often as by all six edges (~2.5 times
// instead of ~5). The test is local: with the quadruple sorted, which of its edges rise is the parity
// of the sort: an even one gives (s0, s1), (s0, s3), (s1, s2) and (s2, s3), an odd one (s0, s2) and
// (s1, s3). The hull's edges lie in infinite tetrahedra too, which are listed for their finite edges.
// The lists hold the quadruples themselves, sorted once, not tetrahedron ids: through ids, stage 3
// fetched every tetrahedron from wherever its slot lay (slots follow the order of the cavities that
// freed them, not the vertex ids) and sorted its vertices, twice per range (100k points on 2
// threads: 327 M instructions for the extraction then, 279 M now). Copies cost 16 bytes a
// tetrahedron instead of 4, so the tetrahedra's pages go back as they are listed (below).
// No thread writes what another writes: each worker fills its own part of the lists' array (a global
// count per vertex needed locked adds).
struct Triangulation3D::RangeLists {
  std::size_t first = 0, last = 0;
  unsigned width_bits = 0;  // ranges are 2^width_bits ids wide (a shift, not a 64-bit division)
  std::size_t num_ranges = 0;
  unsigned workers = 0;
  // The lists, worker by worker, each worker's range by range, in one array of quadruples: list (w, r)
  // is quadruples [at[i], at[i + 1]) for i = w * num_ranges + r. A quadruple q is the sorted ids,
  // s0 < s1 < s2 < s3, of a tetrahedron whose sort was even, and (s0, s2, s1, s3) of one whose sort
  // was odd: both give (q0, q1) and (q2, q3), an even one (q1 < q2) also (q0, q3) and (q1, q2).
  SlotArray<index_t> quads;
  std::vector<std::size_t> at;
  // List i's quadruples [at[i], whole[i]) are finite and have s0, s1 and s2 in its range (all their
  // pairs are its occurrences); those from whole[i] on straddle ranges or hold kInfinite, and are
  // checked pair by pair.
  std::vector<std::size_t> whole;
  std::size_t rangeOf(index_t v) const { return static_cast<std::size_t>((v - first) >> width_bits); }
  std::size_t rangeStart(std::size_t r) const { return std::min(last, first + (r << width_bits)); }
  std::size_t list(unsigned w, std::size_t r) const { return std::size_t(w) * num_ranges + r; }
};

Triangulation3D::EdgeChunks Triangulation3D::edgeChunks(unsigned num_threads) const {
  return edgesOfRanges(listByRange(tet_v_, num_points_, num_threads, 0, num_points_), num_threads);
}

std::vector<std::pair<index_t, index_t>> Triangulation3D::edgesFrom(std::size_t first,
                                                                     std::size_t last) const {
  return joinChunks(edgesOfRanges(listByRange(tet_v_, num_points_, 1, first, last), 1));
}

std::vector<std::pair<index_t, index_t>> Triangulation3D::joinChunks(EdgeChunks&& chunks) {
  if (chunks.size() == 1) return std::move(chunks[0]);
  // Several chunks come only from extractions without an edge bound (edgesFrom, edgeChunks), whose
  // callers join them on one thread: appended chunk by chunk, each freed once copied, so the peak
  // holds the list and one chunk.
  std::size_t total = 0;
  for (const auto& c : chunks) total += c.size();
  std::vector<std::pair<index_t, index_t>> out;
  out.reserve(total);
  for (auto& c : chunks) {
    out.insert(out.end(), c.begin(), c.end());
    detail::freeScratch(c);
  }
  return out;
}

std::vector<index_t> Triangulation3D::hullVertices() const {
  std::vector<index_t> out;
  const std::size_t nt = tet_v_.size() / 4;
  for (std::size_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v_[4 * t];
    if (tv[0] == kDead) continue;
    if (tv[0] != kInfinite && tv[1] != kInfinite && tv[2] != kInfinite && tv[3] != kInfinite) continue;
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] != kInfinite) out.push_back(tv[k]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Triangulation3D::EdgeChunks Triangulation3D::releaseIntoEdgeChunks(unsigned num_threads) {
  // Only the vertex quadruples are needed from here on: free the rest before the edges are made,
  // pages first. A plain free left them resident whenever malloc had placed the arrays in its heap
  // rather than in a mapping of their own (after an earlier build had raised glibc's mmap threshold,
  // for arrays below its 32 MiB cap: a second 200k-point build on 2 threads peaked at 285 bytes per
  // point instead of 228, the extraction's buffers landing on fresh pages beside them).
  // Euler's relation for the triangulated ball: edges = V + T + H / 2 - 1 for T finite tetrahedra and
  // H hull triangles (one per infinite tetrahedron), so V + T + H, what is counted here, bounds them.
  const std::size_t edge_bound = num_inserted_ + numLiveTetrahedra();
  // The adjacency's storage, mapped already, becomes the lists' (listByRange's donor).
  SlotArray<index_t> adjacency;
  adjacency.swap(tet_n_);
  detail::freeScratch(mark_);
  detail::freeScratch(free_);
  detail::freeScratch(birth_);
  seq_ = Worker{};
  SlotArray<index_t> tets;
  tets.swap(tet_v_);
  num_inserted_ = 0;
  RangeLists lists = listByRange(tets, num_points_, num_threads, 0, num_points_, &tets, &adjacency);
  detail::freeScratch(adjacency);
  detail::freeScratch(tets);
  return edgesOfRanges(std::move(lists), num_threads, edge_bound);
}

Triangulation3D::RangeLists Triangulation3D::listByRange(const SlotArray<index_t>& tet_v_, std::size_t n,
                                                           unsigned num_threads, std::size_t first,
                                                           std::size_t last, SlotArray<index_t>* give_back,
                                                           SlotArray<index_t>* donor) {
  if (num_threads == 0) num_threads = 1;
  if (give_back != nullptr && give_back != &tet_v_)
    throw Error("dw::Triangulation3D::listByRange: give_back must be the listed array");
  RangeLists out;
  last = std::min(last, n);
  if (tet_v_.empty() || first >= last) return out;
  const std::size_t nt = tet_v_.size() / 4;
  out.first = first;
  out.last = last;

  // 1. Ranges: `budget` occurrences each, estimated as 3 per tetrahedron slot spread over all points
  // (a range holding more only makes its buffer bigger). At least one range per thread. Each thread
  // holds one range's buffer, so the budget shrinks with the thread count (a floor of 2^18 gave the
  // dragon's 16 threads 38 bytes per point of buffers, and the extraction a peak above the insertion's;
  // 4 occurrences per point per thread still put the dragon's 4-16 thread extraction 6-10 B/pt above
  // it, so 2 now, with no change in time measured on 1-2 threads). At most 2^19 (a range's bucket in 2 MiB,
  // nearer the core's caches): on one thread, 1M uniform points took 0.385-0.393 s to extract with
  // ranges of 2M occurrences and 0.323-0.335 s with 0.3M-0.5M; the dragon (437k) 0.161-0.165 s either way.
  const std::size_t span = last - first;
  const std::size_t budget = std::min<std::size_t>(
      std::size_t(1) << 19, std::max<std::size_t>(std::size_t(1) << 15, 2 * span / num_threads));
  const std::size_t per_vertex = std::max<std::size_t>(1, 3 * nt / std::max<std::size_t>(n, 1));
  const std::size_t wanted =
      std::min(span, std::max<std::size_t>(num_threads, (span * per_vertex + budget - 1) / budget));
  while ((std::size_t(1) << out.width_bits) * wanted < span) ++out.width_bits;
  out.num_ranges = ((span - 1) >> out.width_bits) + 1;
  out.workers = workerCount(nt, num_threads, 1 << 16);
  const std::size_t num_ranges = out.num_ranges;

  // 2. Worker w takes the w-th slice of the tetrahedra: per range, it counts the tetrahedra with an
  // edge owned there, then copies their quadruples into its part of the lists, each list sized
  // exactly. Dead slots (one id kDead, which sorts below kInfinite) are skipped.
  // Copying the quadruples would hold the tetrahedra twice (the dragon on 16 device threads peaked at
  // 268 bytes per point, the insertion at 247): with `give_back`, the fill gives back the pages of what
  // it has listed in steps of 1 MiB, whose ends lie on 1 MiB boundaries of the array's addresses, so
  // that consecutive steps give back whole pages, none twice.
  constexpr std::size_t kStepBytes = std::size_t(1) << 20;
  const std::uintptr_t base = reinterpret_cast<std::uintptr_t>(tet_v_.data());
  auto stepEnd = [&](std::size_t t) {  // the first tetrahedron at or after a boundary beyond t
    const std::uintptr_t next = ((base + 16 * t) / kStepBytes + 1) * kStepBytes;
    return static_cast<std::size_t>((next - base) / 16);  // base is 16-aligned
  };
  auto forEachEntry = [&](std::size_t from, std::size_t to, auto&& emit) {
    for (std::size_t t = from; t < to; ++t) {
      const index_t* tv = &tet_v_[4 * t];
      index_t s[4] = {tv[0], tv[1], tv[2], tv[3]};
      // A network of branch-free swaps: which id is smaller is a coin flip to the branch predictor
      // (GCC 12 compiles std::min and std::max here into branches). `odd` is the sort's parity.
      index_t odd = 0;
      auto order = [&](int i, int j) {
        const index_t swap = index_t(s[j] < s[i]);
        const index_t d = (s[i] ^ s[j]) & (0u - swap);
        s[i] ^= d;
        s[j] ^= d;
        odd ^= swap;
      };
      order(0, 1);
      order(2, 3);
      order(0, 2);
      order(1, 3);
      order(1, 2);
      if (s[3] == kDead || s[2] >= kDead) continue;
      // The ranges of the three possible owners s0 <= s1 <= s2; with Morton ids nearly always one.
      const index_t d = (s[1] ^ s[2]) & (0u - odd);  // odd: stored as (s0, s2, s1, s3), no branch
      const index_t q[4] = {s[0], s[1] ^ d, s[2] ^ d, s[3]};
      if (s[0] >= first && s[2] < last && out.rangeOf(s[0]) == out.rangeOf(s[2]) && s[3] != kInfinite) {
        emit(out.rangeOf(s[0]), q, std::true_type{});
        continue;
      }
      std::size_t previous = num_ranges;
      for (unsigned j = 0; j < 3; ++j) {
        if (s[j] < first || s[j] >= last) continue;
        const std::size_t r = out.rangeOf(s[j]);
        if (r != previous) emit(r, q, std::false_type{});
        previous = r;
      }
    }
  };
  std::vector<std::size_t>& at = out.at;
  at.assign(std::size_t(out.workers) * num_ranges + 1, 0);
  parallelFor(nt, out.workers, [&](std::size_t tb, std::size_t te, unsigned w) {
    std::size_t* count = &at[out.list(w, 0) + 1];
    forEachEntry(tb, te, [&](std::size_t r, const index_t*, auto) { ++count[r]; });
  });
  for (std::size_t i = 1; i < at.size(); ++i) at[i] += at[i - 1];
  // The lists' array: the donor's storage when it is big enough (the adjacency, freed next anyway,
  // whose pages are mapped already; on 1M points the lists are ~104 MB, 26k pages to map afresh), its
  // pages beyond the lists given back; otherwise the donor is freed first and the array is new.
  const std::size_t words = 4 * at.back();
  if (donor != nullptr && donor->capacity() >= words) {
    out.quads.swap(*donor);
    out.quads.resize(words);  // no writes: the allocator leaves growth unwritten, shrinking keeps it
    detail::releaseUnused(out.quads);
  } else {
    if (donor != nullptr) detail::freeScratch(*donor);
    out.quads.resize(words);
  }
  // The fill runs over the same slices as the count (parallelFor's blocks depend on nt and the worker
  // count only). Each list fills from its front with whole quadruples and from its back with
  // straddling ones; where they meet is `whole`.
  out.whole.assign(at.size() - 1, 0);
  parallelFor(nt, out.workers, [&](std::size_t tb, std::size_t te, unsigned w) {
    std::vector<std::size_t> front(at.begin() + out.list(w, 0), at.begin() + out.list(w, 0) + num_ranges);
    std::vector<std::size_t> back(at.begin() + out.list(w, 0) + 1,
                                  at.begin() + out.list(w, 0) + 1 + num_ranges);
    index_t* quads = out.quads.data();
    for (std::size_t b = tb; b < te;) {
      const std::size_t e = std::min(te, stepEnd(b));
      forEachEntry(b, e, [&](std::size_t r, const index_t* s, auto whole) {
        index_t* q = quads + 4 * (decltype(whole)::value ? front[r]++ : --back[r]);
        q[0] = s[0];
        q[1] = s[1];
        q[2] = s[2];
        q[3] = s[3];
      });
      if (give_back != nullptr) detail::releaseSlice(give_back->data() + 4 * b, 16 * (e - b), 0, 1);
      b = e;
    }
    std::copy(front.begin(), front.end(), out.whole.begin() + out.list(w, 0));
  });
  return out;
}

Triangulation3D::EdgeChunks Triangulation3D::edgesOfRanges(RangeLists&& in, unsigned num_threads,
                                                             std::size_t edge_bound) {
  if (num_threads == 0) num_threads = 1;
  EdgeChunks chunks;
  const std::size_t num_ranges = in.num_ranges;
  if (num_ranges == 0) return chunks;
  // 3. The edges of each range. The ranges are claimed in order from one counter by the workers;
  // each range's list pages go back once they are bucketed, so the lists shrink as the edges grow.
  // Given a bound on the edge count, every range's edges go straight into one list, so that
  // joinChunks() hands it over as it is:
  //  - on one thread, appended range by range to the list reserved to the bound (the chunks had been
  //    faulted in, then copied into a list faulted in again: 1M points, 62 MB of edges; the bench's
  //    page faults fell from 252k to 222k);
  //  - on several, the list is mapped on all workers and sized to the bound first, and a range's edges
  //    are written at the end of the range before it, published through `end_of` as soon as each range
  //    knows its count (before it writes). The range before was claimed earlier by a worker that is
  //    running it, so the wait is short and cannot deadlock, even when the loop runs on fewer threads.
  //    Per-range chunks then joined took 20 ms of a two-thread 1M-point build (session 20).
  // Without a bound, each range goes into a chunk of its own sized exactly (a growing vector per
  // thread held up to twice its edges while reallocating: 2 threads peaked 20 % above the insertion).
  const unsigned parts = static_cast<unsigned>(std::min<std::size_t>(num_threads, num_ranges));
  const bool one_list = edge_bound > 0;
  chunks.assign(one_list ? 1 : num_ranges, {});
  std::vector<std::pair<index_t, index_t>>& list = chunks[0];
  if (one_list) list.reserve(edge_bound);
  constexpr std::size_t kNotYet = ~std::size_t(0), kFailed = kNotYet - 1;
  std::unique_ptr<std::atomic<std::size_t>[]> end_of;
  if (one_list && parts > 1) {
    const std::size_t bytes = edge_bound * sizeof(list[0]), slices = detail::pageSlices(bytes, 4 * parts);
    parallelFor(slices, parts, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t k = b; k < e; ++k) detail::prefaultSlice(list.data(), bytes, k, slices);
    });
    list.resize(edge_bound);
    end_of.reset(new std::atomic<std::size_t>[num_ranges]);
    for (std::size_t r = 0; r < num_ranges; ++r) end_of[r].store(kNotYet, std::memory_order_relaxed);
  }
  // Where range r's edges begin in the one list: the end of range r - 1, once published.
  auto startOf = [&](std::size_t r) {
    if (r == 0) return std::size_t(0);
    std::size_t at = end_of[r - 1].load(std::memory_order_acquire);
    for (unsigned spins = 0; at == kNotYet; at = end_of[r - 1].load(std::memory_order_acquire))
      if (++spins > 64) std::this_thread::yield();
    return at;
  };
  std::atomic<std::size_t> next_range{0};
  auto work = [&]() {
    std::vector<std::uint32_t> bucket_offset, fill;
    std::vector<index_t> bucket;
    // Repeats of b under one a are dropped through a small open-addressing set of entries
    // (a << 32) | b, in which an entry of another a reads as empty: its size follows a's occurrences,
    // not the point count, so threads need no per-point stamp array (4 bytes per point per thread).
    std::vector<std::uint64_t> seen;
    for (std::size_t r = next_range++; r < num_ranges; r = next_range++) {
      // A range that fails publishes kFailed, so that the ranges after it stop instead of waiting.
      struct PublishFailure {
        std::atomic<std::size_t>* slot;
        ~PublishFailure() {
          if (slot) slot->store(kFailed, std::memory_order_release);
        }
      } on_failure{end_of ? &end_of[r] : nullptr};
      const std::size_t lo = in.rangeStart(r), hi = in.rangeStart(r + 1);
      // Occurrences per a, then the bucket of each a. Each quadruple says which of its pairs it gives
      // and each pair's smaller endpoint (see RangeLists), and the only tests left are whether s0, s1,
      // s2 lie in the range. The listing made them: it put the finite quadruples they all lie in
      // (nearly all, with Morton ids) first in each list, and only the rest is tested pair by pair.
      // fn(a - lo, b, gives): whether an even quadruple's two more pairs are given is a coin flip, so
      // they are passed with the flag rather than branched on.
      auto forEachOccurrence = [&](auto&& fn) {
        for (unsigned w = 0; w < in.workers; ++w) {
          const std::size_t i = in.list(w, r);
          for (std::size_t k = in.at[i]; k < in.whole[i]; ++k) {
            const index_t* q = in.quads.data() + 4 * k;
            const bool even = q[1] < q[2];
            fn(q[0] - lo, q[1], true);
            fn(q[2] - lo, q[3], true);
            fn(q[0] - lo, q[3], even);
            fn(q[1] - lo, q[2], even);
          }
          for (std::size_t k = in.whole[i]; k < in.at[i + 1]; ++k) {
            const index_t* q = in.quads.data() + 4 * k;
            const bool even = q[1] < q[2], finite = q[3] != kInfinite;
            auto here = [&](index_t a) { return a >= lo && a < hi; };
            if (here(q[0])) {
              fn(q[0] - lo, q[1], true);
              if (even && finite) fn(q[0] - lo, q[3], true);
            }
            if (finite && here(q[2])) fn(q[2] - lo, q[3], true);
            if (even && here(q[1])) fn(q[1] - lo, q[2], true);
          }
        }
      };
      bucket_offset.assign(hi - lo + 1, 0);
      forEachOccurrence([&](std::size_t i, index_t, bool gives) { bucket_offset[i + 1] += gives; });
      for (std::size_t i = 0; i < hi - lo; ++i) bucket_offset[i + 1] += bucket_offset[i];
      bucket.resize(bucket_offset.back() + 1);  // the last entry takes the writes of pairs not given
      fill.assign(bucket_offset.begin(), bucket_offset.end() - 1);
      const std::size_t spare = bucket_offset.back();
      forEachOccurrence([&](std::size_t i, index_t b, bool gives) {
        // The select as a mask: written as `gives ? ... : ...`, GCC branched (a coin flip).
        const std::size_t at = fill[i];
        bucket[spare ^ ((at ^ spare) & (0 - std::size_t(gives)))] = b;
        fill[i] = static_cast<std::uint32_t>(at + gives);
      });
      for (unsigned w = 0; w < in.workers; ++w) {  // the range's lists are done with: pages back
        const std::size_t i = in.list(w, r);
        detail::releaseSlice(in.quads.data() + 4 * in.at[i], 16 * (in.at[i + 1] - in.at[i]), 0, 1);
      }
      // Distinct b's moved to the front of the bucket, a by a; fill[a - lo] becomes the end of a's.
      std::size_t distinct = 0;
      for (std::size_t a = lo; a < hi; ++a) {
        const std::uint32_t begin = bucket_offset[a - lo], end = bucket_offset[a - lo + 1];
        const unsigned bits = tableBits(2 * std::size_t(end - begin));
        if (seen.size() < (std::size_t(1) << bits))
          seen.resize(std::size_t(1) << bits, std::uint64_t(kNoTet) << 32);
        const std::size_t mask = (std::size_t(1) << bits) - 1;
        // Branch-free but for collisions: whether b repeats is a coin flip (each edge comes ~5 times),
        // so the entry is always (re)written and the output advances by the flag.
        for (std::uint32_t k = begin; k < end; ++k) {
          const index_t b = bucket[k];
          const std::uint64_t key = std::uint64_t(a) << 32 | b;
          std::size_t h = hashKey(b, bits);
          // x = entry ^ key is 0 for a repeat, below 2^32 but not 0 for a collision (another b of
          // this a: probe on), and at least 2^32 for an empty entry. One compare, rarely true: the
          // boolean form compiled to a jump on "same a", a coin flip.
          std::uint64_t x = seen[h] ^ key;
          while (x - 1 < 0xFFFFFFFFull) {
            h = (h + 1) & mask;
            x = seen[h] ^ key;
          }
          seen[h] = key;
          bucket[distinct] = b;
          distinct += x != 0;
        }
        fill[a - lo] = static_cast<std::uint32_t>(distinct);
      }
      if (one_list && !end_of) {
        std::size_t k = 0;
        for (std::size_t a = lo; a < hi; ++a)
          for (; k < fill[a - lo]; ++k) list.emplace_back(static_cast<index_t>(a), bucket[k]);
        continue;
      }
      std::pair<index_t, index_t>* out;
      if (end_of) {
        const std::size_t start = startOf(r);
        if (start == kFailed) return;  // an earlier range failed: its error is passed on
        if (start + distinct > edge_bound)
          throw Error("dw::Triangulation3D: more edges than Euler's bound (a corrupted triangulation)");
        end_of[r].store(start + distinct, std::memory_order_release);
        on_failure.slot = nullptr;
        out = list.data() + start;
      } else {
        chunks[r].resize(distinct);
        out = chunks[r].data();
      }
      std::size_t k = 0;
      for (std::size_t a = lo; a < hi; ++a)
        for (; k < fill[a - lo]; ++k) out[k] = {static_cast<index_t>(a), bucket[k]};
    }
  };
  parallelFor(parts, parts, [&](std::size_t, std::size_t, unsigned) { work(); });
  if (end_of) {
    list.resize(end_of[num_ranges - 1].load(std::memory_order_relaxed));
    detail::releaseUnused(list);
  }
  return chunks;
}

void Triangulation3D::validate() const {
  const std::size_t nt = tet_v_.size() / 4;
  auto fail = [](index_t t, const std::string& what) {
    throw Error("dw::Triangulation3D::validate: tetrahedron " + std::to_string(t) + ": " + what);
  };
  std::vector<char> present(num_points_, 0);
  std::size_t live = 0;
  for (index_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    if (tv[0] == kDead) continue;
    ++live;
    unsigned inf = 4, count_inf = 0;
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == kInfinite) {
        inf = k;
        ++count_inf;
      } else if (tv[k] >= num_points_) {
        fail(t, "vertex id out of range");
      } else {
        present[tv[k]] = 1;
      }
    }
    if (count_inf > 1) fail(t, "more than one infinite vertex");
    for (unsigned f = 0; f < 4; ++f) {
      const std::uint32_t nc = tet_n_[4 * std::size_t(t) + f];
      const index_t n = nc >> 2;
      if (n >= nt || tet_v_[4 * std::size_t(n)] == kDead) fail(t, "neighbour is not a live tetrahedron");
      if (tet_n_[nc] != 4 * t + f) fail(t, "adjacency is not symmetric");
      std::array<index_t, 3> a{}, b{};
      unsigned ia = 0, ib = 0;
      for (unsigned k = 0; k < 4; ++k) {
        if (k != f) a[ia++] = tv[k];
        if (k != (nc & 3u)) b[ib++] = tet_v_[4 * std::size_t(n) + k];
      }
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      if (a != b) fail(t, "neighbours do not share the face");
      const index_t opposite = tet_v_[nc];
      if (opposite == kInfinite) continue;
      // Local Delaunay (finite t) or local convexity of the hull (infinite t), same perturbation.
      double po[3];
      point(opposite, po);
      if (inConflict(t, opposite, predicates::BroadcastPoint(po)))
        fail(t, "face " + std::to_string(f) + " is not locally Delaunay");
    }
    double q[4][3];
    if (inf == 4) {
      for (unsigned k = 0; k < 4; ++k) point(tv[k], q[k]);
      if (predicates::orient3d(q[0], q[1], q[2], q[3]) <= 0.0) fail(t, "not positively oriented");
    } else {
      const std::uint32_t nc = tet_n_[4 * std::size_t(t) + inf];
      const index_t inner = tet_v_[nc];
      if (inner == kInfinite) fail(t, "hull facet backed by an infinite tetrahedron");
      for (unsigned k = 0; k < 4; ++k) point(k == inf ? inner : tv[k], q[k]);
      if (predicates::orient3d(q[0], q[1], q[2], q[3]) >= 0.0) fail(t, "hull facet faces inwards");
    }
  }
  std::size_t missing = 0;
  for (char c : present) missing += c == 0;
  if (num_points_ - missing != num_inserted_)
    throw Error("dw::Triangulation3D::validate: " + std::to_string(num_points_ - missing) +
                " vertices in tetrahedra, " + std::to_string(num_inserted_) + " inserted");
  if (live != numLiveTetrahedra()) throw Error("dw::Triangulation3D::validate: free list out of sync");
}

std::size_t Triangulation3D::memoryBytes() const {
  // Every scratch list of the sequential worker too.
  return (tet_v_.capacity() + tet_n_.capacity() + birth_.capacity() + vertex_tet_.capacity() +
          seq_.made.capacity() + seq_.link_codes.capacity() + seq_.edge_codes.capacity() +
          seq_.cavity.capacity() + seq_.queued.capacity() + free_.capacity()) *
             sizeof(std::uint32_t) +
         (seq_.link_keys.capacity() + seq_.edge_keys.capacity()) * sizeof(std::uint64_t) + mark_.capacity() +
         seq_.cavity_entry.capacity() + seq_.boundary.capacity() * sizeof(BoundaryFace);
}

}  // namespace builder3d
}  // namespace dw
