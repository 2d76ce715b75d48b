// Incremental Bowyer-Watson over the TetraMesh: an insertion reads locate -> find the cavity ->
// stellate it (geogram's locate, find_conflict_zone, stellate_cavity). See triangulation_3d.h.
#include "core/builder3d/triangulation_3d.h"

#include <algorithm>
#include <cmath>
#include <string>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/builder3d/parallel_insertion.h"
#include "core/geometry/predicates_3d_simd.h"
#include "core/util/multiversioning.h"
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"

// The insertion (insertCore with the walk and the linking inlined) is compiled twice, for baseline
// x86-64 and for x86-64-v3, and each call takes the version the CPU can run (multiversioning.h).

namespace dw {
namespace builder3d {
namespace {

// Scratch of at least n entries, grown (never shrunk) to the largest need seen.
template <class T>
inline T* atLeast(SlotArray<T>& v, std::size_t n) {
  if (v.size() < n) v.resize(std::max(n, 2 * v.size()));
  return v.data();
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

namespace {

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

}  // namespace

template <class Owner>
bool Triangulation3D::ownsTet(index_t t, const Owner& own) const {
  if constexpr (!Owner::kShared) {
    return true;
  } else {
    for (unsigned k = 0; k < 4; ++k)
      if (!own.ownsVertex(load<true>(mesh_.tet_v[4 * std::size_t(t) + k]))) return false;
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
  if (t >= mesh_.tet_v.size() / 4 || mesh_.tet_v[4 * std::size_t(t)] == kDead) t = last_tet_;
  if (t >= mesh_.tet_v.size() / 4 || mesh_.tet_v[4 * std::size_t(t)] == kDead) {
    // After a parallel pass the remembered tetrahedron may be gone: any live one will do.
    t = 0;
    while (t + 1 < mesh_.tet_v.size() / 4 && mesh_.tet_v[4 * std::size_t(t)] == kDead) ++t;
  }
  // The visibility walk terminates in a Delaunay triangulation; the guard only protects against a
  // corrupted structure and falls back to a scan that cannot loop.
  const std::uint64_t guard = 64 + 4 * static_cast<std::uint64_t>(mesh_.tet_v.size() / 4);
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
    const index_t* tv = &mesh_.tet_v[4 * std::size_t(t)];
    unsigned infinite = 4;
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] == kInfinite) infinite = k;
    if (infinite != 4) {
      if (steps > 0) return t;  // beyond the hull: the cavity starts here
      // A start on the hull: go to the finite side first (and test the way back like any face: the
      // point may lie beyond this very facet).
      const std::uint32_t nc = mesh_.tet_n[4 * std::size_t(t) + infinite];
      if (!own.ownsVertex(mesh_.tet_v[nc])) return kNoTet;
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
    const std::uint32_t nc = mesh_.tet_n[4 * std::size_t(t) + f];
    // The neighbour shares three owned vertices with t: it is owned when the fourth one is (and owned
    // by nobody else either way, so nobody writes it: a plain read).
    if (!own.ownsVertex(mesh_.tet_v[nc])) return kNoTet;
    t = nc >> 2;
  }
  return kNoTet;
}

index_t Triangulation3D::locateByScan(index_t v) const {
  const std::size_t nt = mesh_.tet_v.size() / 4;
  double p[3];
  point(v, p);
  const predicates::BroadcastPoint query(p);
  for (index_t t = 0; t < nt; ++t)
    if (mesh_.tet_v[4 * std::size_t(t)] != kDead && inConflict(t, v, query)) return t;
  throw Error("dw::Triangulation3D: no tetrahedron conflicts with vertex " + std::to_string(v) +
              " (duplicate point or corrupted triangulation)");
}

// Both conflict tests are inlined into the cavity search, which runs ~43 per inserted point: the
// finite case first, since the infinite tetrahedra are a sliver of the mesh; the simulated-simplicity
// tie and the hull's test stay out of line.
[[gnu::always_inline]] inline bool Triangulation3D::finiteInConflict(
    index_t t, index_t v, const predicates::BroadcastPoint& e) const {
  const index_t* tv = &mesh_.tet_v[4 * std::size_t(t)];
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
  if (__builtin_expect(!hasInfiniteVertex(&mesh_.tet_v[4 * std::size_t(t)]), 1))
    return finiteInConflict(t, v, p);
  return infiniteInConflict(t, v, p);
}

bool Triangulation3D::infiniteInConflict(index_t t, index_t v,
                                         const predicates::BroadcastPoint& query) const {
  const double* p = query.p;
  const index_t* tv = &mesh_.tet_v[4 * std::size_t(t)];
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
  return finiteInConflict(mesh_.tet_n[4 * std::size_t(t) + k] >> 2, v, query);
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
      mesh_.mark[t] = Mark::kUnknown;
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
    if (s >= mesh_.tet_v.size() / 4 || !ownsTet(s, own)) return false;
    const index_t* sv = &mesh_.tet_v[4 * std::size_t(s)];
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
index_t Triangulation3D::locateConflict(index_t v, const double* p, Worker& w, const Owner& own) {
  constexpr bool kShared = Owner::kShared;
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
    if (t == kNoTet || !ownsTet(t, own)) return kNoTet;
  } else {
    t = locateInline<true>(v, walkStart(v, p, w, own));
  }
  return t;
}

void Triangulation3D::checkNotDuplicate(index_t v, index_t t) const {
  // A walk that stops in a finite tetrahedron has v strictly inside its circumsphere: decided so, or
  // v lies in its closed hull and repeats none of its vertices. Checked instead of trusted: a wrong
  // root corrupts the mesh.
  const index_t* tv = &mesh_.tet_v[4 * std::size_t(t)];
  const Vec3f& pv = points_[v];
  for (unsigned k = 0; k < 4; ++k) {
    if (tv[k] == kInfinite) continue;
    const Vec3f& q = points_[tv[k]];
    if (q.x == pv.x && q.y == pv.y && q.z == pv.z)
      throw Error("dw::Triangulation3D::insert: vertex " + std::to_string(v) + " duplicates vertex " +
                  std::to_string(tv[k]));
  }
}

namespace {

// Grows the cavity search's four lists to at least `needed` entries, each sized to its capacity (their
// element types are trivial and their allocator leaves resized storage unwritten); returns the entries
// every list can take. Out of line: inlined with the check, the whole ran per cavity tetrahedron (29
// instructions a call; the split saves 1.2 % of a 50k-point build's instructions).
template <class W>
[[gnu::noinline]] std::size_t growSearchLists(W& w, std::size_t needed) {
  auto grow = [](auto& list, std::size_t n) {
    if (list.size() < n) list.resize(std::max(list.capacity(), 2 * n + 60));
    if (list.size() < list.capacity()) list.resize(list.capacity());
  };
  grow(w.cavity, needed);
  grow(w.cavity_entry, needed);
  grow(w.boundary, needed);
  grow(w.queued, needed);
  return std::min({w.cavity.size(), w.cavity_entry.size(), w.boundary.size(), w.queued.size()});
}

// The boundary: the candidates bnd[0..num_candidates) whose neighbour ended outside the cavity,
// compacted in place (branch-free: each face advances the output by a flag). Returns their count.
template <class Face, class M>
[[gnu::always_inline]] inline std::size_t compactBoundary(Face* bnd, std::size_t num_candidates,
                                                          const M* mark) {
  std::size_t num_boundary = 0;
  for (std::size_t k = 0; k < num_candidates; ++k) {
    const Face bf = bnd[k];
    const bool keep = mark[bf.outer >> 2] == M::kOutside;
    bnd[num_boundary] = bf;
    num_boundary += keep;
  }
  return num_boundary;
}

}  // namespace

// The cavity: every tetrahedron whose (perturbed) circumsphere contains v; connected, found by a
// breadth-first search run level by level. Each level first visits the faces of the cavity
// tetrahedra found by the last one, queueing every neighbour not seen before (marked queued) and
// listing every face whose neighbour is not in the cavity as a candidate boundary face; then it
// tests the queued neighbours, one after another. Whether a neighbour was seen before is a coin flip
// (~19 of ~63 visits per point): tested at each visit, that branch was mispredicted ~22
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
template <class Owner>
bool Triangulation3D::findCavity(index_t v, const double* p, index_t t, Worker& w, const Owner& own) {
  const predicates::BroadcastPoint query(p);
  auto& cavity = w.cavity;
  auto& boundary = w.boundary;
  // The arrays through raw pointers in locals (none is resized during the search): through the
  // members, every push and mark store made the compiler reload their data pointers.
  const index_t* const tet_v = mesh_.tet_v.data();
  const std::uint32_t* const tet_n = mesh_.tet_n.data();
  Mark* const mark = mesh_.mark.data();
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
  // The check is inline, the growth out of line (growSearchLists). GNU attributes, which bind to the
  // call operator: written [[gnu::...]] there they name the type, which Clang ignores, and GCC called
  // the check out of line in the parallel pass's version (1.2 % of a 200k-point build's instructions
  // on two threads).
  auto makeRoom = [&](std::size_t extra) __attribute__((always_inline)) {
    if (std::max({num_cavity, num_candidates, num_queued}) + extra <= room) return;
    room = growSearchLists(w, std::max({num_cavity, num_candidates, num_queued}) + extra);
    cav = cavity.data();
    ent = entry.data();
    bnd = boundary.data();
    que = queued.data();
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
  cavity.resize(num_cavity);
  boundary.resize(compactBoundary(bnd, num_candidates, mark));
  w.stats.conflict_tests += tests;
  clearMarks();
  return true;
}

template <bool kShared>
bool Triangulation3D::stellateCavity(index_t v, Worker& w) {
  auto& cavity = w.cavity;
  auto& boundary = w.boundary;
  if constexpr (kShared) {
    if (boundary.size() > cavity.size() && !takeSlots(w, boundary.size() - cavity.size())) return false;
  }
  // The new tetrahedra: boundary face k with v is tetrahedron k, put in cavity slot k while there is
  // one, then in slots off the free list's top. Each face through v (v and a boundary edge) is shared
  // by the two new tetrahedra on the two boundary triangles of that edge: they find each other through
  // the edge, below. The slots are all taken first (the sequential free list may grow the arrays), so
  // that the writes go through raw pointers and counts in locals: with a slot taken per iteration, the
  // call made the compiler reload every vector's data and size (~500 instructions per point).
  const std::size_t nb = boundary.size(), nc = cavity.size();
  index_t* const mk = atLeast(w.made, nb);
  const std::size_t reused = std::min(nb, nc);
  std::copy(cavity.data(), cavity.data() + reused, mk);
  if (nb > nc) {
    // A parallel pass's thread takes its own slots (takeSlots() above made sure it holds enough).
    std::vector<index_t>& free_list = kShared ? w.free : mesh_.free;
    if constexpr (!kShared) ensureFreeSlots(nb - nc);
    const index_t* top = free_list.data() + free_list.size();
    for (std::size_t k = nc; k < nb; ++k) mk[k] = *--top;
    free_list.resize(free_list.size() - (nb - nc));
  }
  if (mesh_.track_births)
    for (std::size_t k = 0; k < nb; ++k) mesh_.birth[mk[k]] = static_cast<std::uint32_t>(num_inserted_ + 1);
  writeNewTetrahedra<kShared>(w);
  w.stats.created_tets += boundary.size();
  for (std::size_t k = boundary.size(); k < cavity.size(); ++k) {
    store<kShared>(mesh_.tet_v[4 * std::size_t(cavity[k])], kDead);
    if constexpr (kShared)
      w.free.push_back(cavity[k]);
    else
      mesh_.free.push_back(cavity[k]);
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

template <class Owner>
bool Triangulation3D::insertCore(index_t v, Worker& w, const Owner& own) {
  double p[3];
  point(v, p);
  const index_t t = locateConflict(v, p, w, own);
  if (Owner::kShared && t == kNoTet) return false;
  checkNotDuplicate(v, t);
  if (!findCavity(v, p, t, w, own)) return false;
  return stellateCavity<Owner::kShared>(v, w);
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

index_t Triangulation3D::walkAnywhere(const double* p, index_t start, Worker& w, std::uint64_t guard) const {
  return walkTo<false>(p, start, w, Everything{}, guard);
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
  // them). A one-pass linking would branch on whether the twin had come first.
  //
  // Raw pointers in locals: through the vectors, every store (atomic ones above all) made the
  // compiler reload their data pointers and sizes in each iteration.
  const std::size_t nb = w.boundary.size();
  const BoundaryFace* boundary = w.boundary.data();
  const index_t* made = w.made.data();
  std::uint32_t* tet_n = mesh_.tet_n.data();
  index_t* tet_v = mesh_.tet_v.data();
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

void Triangulation3D::validate() const {
  // The structure first: the geometric checks below follow neighbour codes it has found sound.
  mesh_.validate(num_points_, num_inserted_);
  const std::size_t nt = mesh_.slots();
  auto fail = [](index_t t, const std::string& what) {
    throw Error("dw::Triangulation3D::validate: tetrahedron " + std::to_string(t) + ": " + what);
  };
  for (index_t t = 0; t < nt; ++t) {
    const index_t* tv = mesh_.vertices(t);
    if (tv[0] == kDead) continue;
    unsigned inf = 4;
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] == kInfinite) inf = k;
    for (unsigned f = 0; f < 4; ++f) {
      const index_t opposite = mesh_.tet_v[mesh_.tet_n[4 * std::size_t(t) + f]];
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
      const std::uint32_t nc = mesh_.tet_n[4 * std::size_t(t) + inf];
      const index_t inner = mesh_.tet_v[nc];
      if (inner == kInfinite) fail(t, "hull facet backed by an infinite tetrahedron");
      for (unsigned k = 0; k < 4; ++k) point(k == inf ? inner : tv[k], q[k]);
      if (predicates::orient3d(q[0], q[1], q[2], q[3]) >= 0.0) fail(t, "hull facet faces inwards");
    }
  }
}

std::size_t Triangulation3D::memoryBytes() const {
  // The mesh and every scratch list of the sequential worker.
  return mesh_.memoryBytes() +
         (vertex_tet_.capacity() + seq_.made.capacity() + seq_.link_codes.capacity() +
          seq_.edge_codes.capacity() + seq_.cavity.capacity() + seq_.queued.capacity()) *
             sizeof(std::uint32_t) +
         (seq_.link_keys.capacity() + seq_.edge_keys.capacity()) * sizeof(std::uint64_t) +
         seq_.cavity_entry.capacity() + seq_.boundary.capacity() * sizeof(BoundaryFace);
}

// The parallel pass (parallel_insertion.cpp) inserts through this translation unit's compiled
// versions, with the walk and the stages inlined into them as for the sequential insertion.
template bool Triangulation3D::insertOnThisCpu<Triangulation3D::Cell>(index_t, Worker&, const Cell&);
template bool Triangulation3D::ownsTet<Triangulation3D::Cell>(index_t, const Cell&) const;

}  // namespace builder3d
}  // namespace dw
