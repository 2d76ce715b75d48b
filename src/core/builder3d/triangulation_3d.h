/// \file triangulation_3d.h
/// \brief Incremental 3D Delaunay triangulation (Bowyer-Watson) over a TetraMesh, made for one
/// purpose: producing the walk graph's edges (docs/architecture.md).
///
/// The pieces, as in CGAL (TDS / traits / triangulation) and geogram (Delaunay3d, ParallelDelaunay3d):
/// - tetra_mesh.h: the mesh (flat arrays of vertex ids and neighbour codes, slots, free list);
/// - triangulation_3d.cpp: insertion, read as locate -> find the cavity -> stellate it;
/// - triangulation_build.cpp: build(): the first tetrahedron, then the vertices batch by batch;
/// - parallel_insertion.cpp: insertParallel's passes over k-d cells of space, with hand-on;
/// - edge_extraction.cpp: the Delaunay edges, each listed once (the ring-ascent argument there);
/// - vertex_removal.cpp: remove().
/// The convex hull is closed by an infinite vertex (kInfinite): each hull facet is the finite face of
/// one infinite tetrahedron. Unlike a bounding super-tetrahedron this changes no Delaunay edge near
/// the hull, so every hull edge of the real points is present and no artificial edge exists.
/// - Geometry comes only from dw::predicates (orient3d, insphere with simulation of simplicity keyed
///   on the vertex ids), so exactly cospherical or coplanar input gives a valid triangulation of a
///   consistently perturbed point set and never a hang.
/// - Finite tetrahedra are positively oriented: orient3d(v0, v1, v2, v3) > 0. An infinite one is
///   oriented so that replacing kInfinite by a point beyond its hull facet gives orient3d > 0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "core/builder3d/tetra_mesh.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace predicates {
struct BroadcastPoint;
}
namespace builder3d {

class Triangulation3D {
 public:
  static constexpr index_t kInfinite = TetraMesh::kInfinite;  ///< the vertex at infinity
  static constexpr index_t kDead = TetraMesh::kDead;          ///< first vertex slot of a recycled tetrahedron
  /// Keeps tet * 4 + face in 32 bits (about 6.7 tetrahedra per vertex on volumetric input).
  static constexpr std::size_t kMaxVertices = 150000000;

  /// Points are read through `points` (not copied). The array must stay alive and unchanged for
  /// every vertex already inserted; it may grow (call setPoints again) before inserting new ones.
  void setPoints(const Vec3f* points, std::size_t n);

  /// Triangulates the vertices `order[0..n)` (distinct points) inserted in that order. The first
  /// tetrahedron is made of the first four non-coplanar ones. Throws dw::Error if all are coplanar.
  /// `progress` (optional) receives the fraction inserted.
  void build(const index_t* order, std::size_t n, const std::function<void(double)>& progress = {});

  /// build(), with the positions order[batch_begin[r] .. batch_begin[r + 1]) (the last batch runs to n)
  /// inserted batch by batch through insertParallel() on `num_threads` threads; positions before the
  /// first batch go in one by one. For BRIO rounds: each round is spread over the whole cloud.
  void build(const index_t* order, std::size_t n, const std::function<void(double)>& progress,
             const std::vector<std::size_t>& batch_begin, unsigned num_threads);
  /// The same, taking the order over: it is freed once the last batch is copied out, before that
  /// batch (the biggest BRIO round, half the points) goes in, where the builder's memory peaks.
  void build(std::vector<index_t>&& order, const std::function<void(double)>& progress,
             const std::vector<std::size_t>& batch_begin, unsigned num_threads);

  /// Inserts one more vertex (a point distinct from every vertex present) into a built triangulation.
  void insert(index_t v);

  /// Inserts the vertices ids[0..m) (distinct, not yet present) on `num_threads` threads by
  /// partitioned insertion: each pass splits the pending points into k-d cells of space, one per
  /// thread; a thread owns the tetrahedra whose four vertices lie in its cell and inserts a point only
  /// when the walk and the whole cavity (plus the faces around it) stay inside what it owns, otherwise
  /// it defers the point. The next pass cuts along other directions (not the axes), so the sheets of
  /// deferred points along the old cuts lie across the new cells. What is left when a pass stalls, and every
  /// point in batches too small to share, is inserted on the calling thread. The perturbed Delaunay
  /// triangulation is unique, so the result does not depend on the thread count. Walks are short when
  /// ids follow a space-filling curve (buildDelaunayGraph hands points over in Morton order);
  /// otherwise the result is the same, only slower. Not with trackBirths(true).
  void insertParallel(const index_t* ids, std::size_t m, unsigned num_threads);

  /// insertParallel() runs at most one thread per `n` points of a batch (default 8192), but two from
  /// n / 2 points. Below several thousand points per thread the cells are thin next to the cavities
  /// and many attempts are deferred: with 2048, a 64k-point LiDAR frame on 16 device threads cost
  /// 1.7-2x the CPU time of 8192 for the same wall time (the scan-to-scan case builds a graph per
  /// frame); 1M points took the same time within the noise. Two threads on half as many points lose
  /// little (same frame, here: 4 % more CPU, 8 % less wall time; 1M points 2.5 % faster on two
  /// threads). Tests lower it to exercise the parallel passes on small inputs.
  void setMinPointsPerThread(std::size_t n) { min_points_per_thread_ = n; }

  /// Whether build() has produced a tetrahedralisation.
  bool built() const { return !mesh_.empty(); }

  std::size_t numVertices() const { return num_inserted_; }
  std::size_t numLiveTetrahedra() const { return mesh_.numLive(); }

  using EdgeChunks = std::vector<std::vector<std::pair<index_t, index_t>>>;

  /// Every Delaunay edge between finite vertices, u < v, each once, in chunks by consecutive ranges of
  /// u (ascending; each chunk sized exactly), made on `num_threads` threads, so the caller can
  /// concatenate them after freeing the triangulation.
  EdgeChunks edgeChunks(unsigned num_threads) const;

  /// edgeChunks(), but frees the adjacency first and the tetrahedra once they are listed: the peak
  /// memory then holds the vertex quadruples and their lists, then the lists and the edges, never the
  /// whole structure plus the edges. The edges come as one chunk (each range written straight to its
  /// place in it, on any number of threads), so joinChunks() hands it over without a copy. Leaves the
  /// triangulation empty (built() is false).
  EdgeChunks releaseIntoEdgeChunks(unsigned num_threads);

  /// The chunks' edges in one list, in order: a single chunk (releaseIntoEdgeChunks' on any thread
  /// count) is handed over as it is; several are appended one by one, each chunk's pages going back to
  /// the system once copied, so the resident peak is one copy of the edges plus one chunk.
  static std::vector<std::pair<index_t, index_t>> joinChunks(EdgeChunks&& chunks);

  /// The edges (a, b), a < b, of the triangulation whose smaller endpoint a is in [first, last), each
  /// once: what one block of the parallel builder owns.
  std::vector<std::pair<index_t, index_t>> edgesFrom(std::size_t first, std::size_t last) const;

  /// Vertices of the convex hull's triangulated boundary (those of the infinite tetrahedra), sorted.
  std::vector<index_t> hullVertices() const { return mesh_.hullVertices(); }

  /// Raw access for the parallel builder's certification: slot count (live or recycled) and the four
  /// vertices of a slot (first entry kDead for a recycled one, kInfinite marks the infinite vertex).
  std::size_t tetSlots() const { return mesh_.slots(); }

  /// Records, per tetrahedron slot, the insertion count at which it was (re)created, so that a caller
  /// can revisit only what changed since a moment (costs 4 bytes per tetrahedron). Call before build().
  void trackBirths(bool on) { mesh_.track_births = on; }
  /// Insertions so far (the clock of birth()).
  std::uint32_t clock() const { return static_cast<std::uint32_t>(num_inserted_); }
  /// Birth of slot t (only with trackBirths(true)).
  std::uint32_t birth(std::size_t t) const { return mesh_.birth[t]; }
  const index_t* tetVertices(std::size_t t) const { return mesh_.vertices(t); }
  /// The mesh itself (read-only).
  const TetraMesh& mesh() const { return mesh_; }

  // ---- Vertex removal (sliding-window maps; vertex_removal.cpp) ----
  /// Removes vertex v: its star is re-triangulated by the Delaunay triangulation of its link under the
  /// same perturbation, so the result equals a fresh build of the remaining vertices (with the same ids).
  /// Throws dw::Error, leaving the structure unchanged, when the triangulation is not built, v is out of
  /// range or not present, or the remaining vertices would not span 3D (fewer than 4, or all coplanar).
  /// numVertices() drops by one; clock() (birth tracking) counts vertices present, so it is not
  /// monotone across removals.
  void remove(index_t v);
  /// Vertices removed since construction.
  std::size_t numRemoved() const { return num_removed_; }
  /// A live tetrahedron holding vertex v (a root of its star): the one kept per vertex when it is
  /// still valid, else the end of a walk to v from `hint` (any tetrahedron slot; an invalid one
  /// starts where the last insertion or removal ended). Throws dw::Error when v is not present.
  index_t tetOf(index_t v, index_t hint = kNoTet);

  /// Checks the whole structure (TetraMesh::validate's adjacency and counts, then the orientation of
  /// every tetrahedron and the local Delaunay property of every face under the same perturbation).
  /// Throws dw::Error naming the first violation. O(tetrahedra); for tests.
  void validate() const;

  /// Bytes held by the arrays (capacity), for memory accounting.
  std::size_t memoryBytes() const;

  /// Statistics of the last build (for benchmarks and docs).
  struct Stats {
    std::uint64_t walk_steps = 0;
    std::uint64_t conflict_tests = 0;
    std::uint64_t created_tets = 0;
    std::uint64_t fallback_locations = 0;  ///< walks that hit the step guard and fell back to a scan
    std::uint64_t deferred = 0;            ///< parallel attempts deferred (foreign tetrahedra reached)
    std::uint64_t parallel_passes = 0;     ///< passes of insertParallel that ran threads
    std::uint64_t parallel_inserted = 0;   ///< vertices inserted by threads (the rest: calling thread)
    std::uint64_t handed_on = 0;           ///< points a pass's slower threads left untried for the next pass
    double parallel_seconds = 0.0;         ///< wall time inside parallel passes (set-up included)
    double parallel_busy_max = 0.0;        ///< per pass, the longest a thread inserted (summed over passes)
    double parallel_busy_sum = 0.0;        ///< thread-seconds spent inserting in parallel passes
    double parallel_setup_seconds = 0.0;   ///< per pass, the wall time before its threads insert (summed)
    double rest_seconds = 0.0;  ///< the calling thread inserting what a batch's parallel passes left
    void add(const Stats& o);
  };
  const Stats& stats() const { return stats_; }

 private:
  using Mark = TetraMesh::Mark;
  static constexpr std::uint32_t kNoTet = TetraMesh::kNoTet;

  struct BoundaryFace {
    index_t v[4];         // the new tetrahedron (cavity tet with its vertex `face` replaced by the new point)
    std::uint32_t outer;  // neighbour code of the tetrahedron outside the cavity
    std::uint32_t face;   // local index of that face in the new tetrahedron
  };

  // One inserting thread's scratch (reused across insertions to keep the hot loop allocation-free),
  // and in a parallel pass its own recycled and fresh tetrahedron slots.
  // Aligned to keep one thread's hot counters and vector headers off another's cache lines.
  struct alignas(128) Worker {
    // The cavity search's lists (findCavity fills them through raw pointers, sized to capacity).
    SlotArray<index_t> cavity;
    SlotArray<std::uint8_t> cavity_entry;  // per cavity tetrahedron, the face it was reached through
    SlotArray<BoundaryFace> boundary;
    SlotArray<std::uint32_t> queued;  // every neighbour the search queued (neighbour codes)
    // The linking's scratch, grown but never shrunk (its counts are the insertion's locals): resized to
    // each insertion's count, the growth's zero fill and its out-of-line call cost ~130 instructions
    // per point.
    SlotArray<index_t> made;              // the new tetrahedra, one per boundary face
    SlotArray<std::uint64_t> link_keys;   // hash table of directed boundary edges (empty between uses)
    SlotArray<std::uint32_t> link_codes;  // per table entry: the face through the new point there
    SlotArray<std::uint64_t> edge_keys;   // per face through the new point: its directed edge
    SlotArray<std::uint32_t> edge_codes;  // per face through the new point: its code
    std::vector<index_t> free;            // parallel pass: slots this thread took from the pool or recycled
    index_t last_tet = 0;
    index_t last_vertex = kInfinite;  // the last vertex this worker inserted (none yet: kInfinite)
    std::uint32_t rng = 0x9E3779B9u;
    std::vector<index_t> deferred;
    Stats stats;
  };
  struct Everything;    // ownership policy of the sequential insertion
  struct CellSplit;     // the threads' cells of one parallel pass (parallel_insertion.h)
  struct Cell;          // ownership policy of one thread in a parallel pass (parallel_insertion.h)
  struct ParallelPass;  // one pass of insertParallel (parallel_insertion.cpp)

  // ---- Insertion (triangulation_3d.cpp) ----
  // The insertion: locate a tetrahedron in conflict, find the cavity, stellate it. Returns false, with
  // nothing changed, when the policy does not own what the insertion would touch (never for
  // Everything). Always inlined into the two compiled versions below, which insertOnThisCpu chooses
  // between; so are its stages.
  template <class Owner>
  [[gnu::always_inline]] inline bool insertCore(index_t v, Worker& w, const Owner& own);
  template <class Owner>
  bool insertCoreBaseline(index_t v, Worker& w, const Owner& own);
  template <class Owner>
  bool insertCoreV3(index_t v, Worker& w, const Owner& own);  // x86-64-v3 where the compiler can
  template <class Owner>
  bool insertOnThisCpu(index_t v, Worker& w, const Owner& own);
  // Stage 1: a tetrahedron in conflict with v (at p), or kNoTet where a sharing owner must defer v.
  template <class Owner>
  [[gnu::always_inline]] inline index_t locateConflict(index_t v, const double* p, Worker& w,
                                                       const Owner& own);
  // Throws dw::Error when v repeats a vertex of t (the tetrahedron the walk stopped in).
  [[gnu::always_inline]] inline void checkNotDuplicate(index_t v, index_t t) const;
  // Stage 2: the cavity of v from tetrahedron t into w.cavity, and its boundary faces into w.boundary.
  // False, with every mark cleared, where a sharing owner does not own a tetrahedron in conflict.
  template <class Owner>
  [[gnu::always_inline]] inline bool findCavity(index_t v, const double* p, index_t t, Worker& w,
                                                const Owner& own);
  // Stage 3: replaces the cavity by the tetrahedra joining v to its boundary faces. False, with
  // nothing changed, when a parallel pass's slot pool is spent.
  template <bool kShared>
  [[gnu::always_inline]] inline bool stellateCavity(index_t v, Worker& w);
  // Writes the new tetrahedra w.made, one on each boundary face: their vertices, their links with the
  // tetrahedra outside, and their links with one another (on the faces through the new vertex).
  template <bool kShared>
  [[gnu::always_inline]] inline void writeNewTetrahedra(Worker& w);
  template <class Owner>
  bool ownsTet(index_t t, const Owner& own) const;
  // Where a walk to v (at p) starts: see the definition.
  template <class Owner>
  index_t walkStart(index_t v, const double* p, const Worker& w, const Owner& own) const;
  // A tetrahedron holding vertex u to start a walk from, or kNoTet (u not inserted, or with a sharing
  // owner, a tetrahedron not owned or left stale).
  template <class Owner>
  index_t startAtVertex(index_t u, const Owner& own) const;
  // vertex_tet_[u] (a relaxed atomic read with a sharing owner), kNoVertexTet for u out of range.
  template <bool kShared>
  index_t vertexTet(index_t u) const;
  // Whether s, read from vertex_tet_[u], will do as such a start.
  template <class Owner>
  bool startHolds(index_t s, index_t u, const Owner& own) const;
  // Visibility walk from tetrahedron `start` to the one holding p (or the first infinite one beyond
  // the hull); kNoTet after `guard` steps or, with a sharing owner, where it would leave what it owns.
  // kStopInConflict (an insertion's walk): it may end sooner, at a finite tetrahedron whose circumsphere
  // holds p strictly.
  template <bool kStopInConflict, class Owner>
  [[gnu::always_inline]] inline index_t walkTo(const double* p, index_t start, Worker& w, const Owner& own,
                                               std::uint64_t guard) const;
  // walkTo<false> over every tetrahedron, out of line (a parallel pass's read-only start search).
  index_t walkAnywhere(const double* p, index_t start, Worker& w, std::uint64_t guard) const;
  // Moves slots from the pass's pool to w.free until it holds `count`; false when the pool is spent.
  bool takeSlots(Worker& w, std::size_t count);
  // build()'s body; `owned`, when given, is `order`'s vector, freed before the last batch.
  void buildBatches(const index_t* order, std::size_t n, const std::function<void(double)>& progress,
                    const std::vector<std::size_t>& batch_begin, unsigned num_threads,
                    std::vector<index_t>* owned);
  // buildBatches' checks of the input and its first tetrahedron; returns the positions in `order` of
  // the first tetrahedron's third and fourth vertices (the first two are order[0] and order[1]).
  std::pair<std::size_t, std::size_t> startBuild(const index_t* order, std::size_t n);
  void initialTetrahedron(index_t a, index_t b, index_t c, index_t d);
  index_t locate(index_t v, index_t start);
  template <bool kStopInConflict>
  [[gnu::always_inline]] inline index_t locateInline(index_t v, index_t start);  // locate's body
  index_t locateByScan(index_t v) const;
  // Conflict of tetrahedron t with vertex v at p (v's coordinates, broadcast once per insertion).
  bool inConflict(index_t t, index_t v, const predicates::BroadcastPoint& p) const;
  bool finiteInConflict(index_t t, index_t v, const predicates::BroadcastPoint& p) const;
  // t has the infinite vertex: is v beyond its hull facet (or on it and in conflict behind it)?
  bool infiniteInConflict(index_t t, index_t v, const predicates::BroadcastPoint& p) const;
  index_t newTet() { return mesh_.newTet(clock()); }
  void ensureFreeSlots(std::size_t count) { mesh_.ensureFreeSlots(count, clock()); }
  void point(index_t v, double out[3]) const {
    const Vec3f& p = points_[v];
    out[0] = p.x;
    out[1] = p.y;
    out[2] = p.z;
  }

  // ---- Parallel insertion (parallel_insertion.cpp) ----
  // insertParallel() on a batch it takes over (validated by the caller).
  void insertBatch(std::vector<index_t> pending, unsigned num_threads);

  // ---- Vertex removal (vertex_removal.cpp) ----
  // A tetrahedron of v's star; throws dw::Error when v is not present.
  index_t starRoot(index_t v);

  const Vec3f* points_ = nullptr;
  std::size_t num_points_ = 0;
  std::size_t num_inserted_ = 0;
  std::size_t num_removed_ = 0;

  TetraMesh mesh_;
  // The linking's hash table: at least kLinkMinEntries entries and kLinkLoad per directed edge. A
  // typical boundary's ~80 directed edges fill 2 % of it, so a probe nearly always ends at once (2048
  // entries: 1.7 more simulated mispredictions per point; tables of 1024 and 2048 sized per insertion
  // measured slower). Only boundaries of over 2048 directed edges grow it: with 8 entries per edge,
  // 16 threads' tables raised the dragon's peak by 2.5 bytes per point, to 249.4-249.8.
  static constexpr std::size_t kLinkMinEntries = 4096;
  static constexpr std::size_t kLinkLoad = 2;
  // Free entries: never used, or used and read (no edge has these keys: kInfinite -> kInfinite or kDead).
  static constexpr std::uint64_t kNoLinkKey = ~std::uint64_t(0);
  static constexpr std::uint64_t kLinkTombstone = kNoLinkKey - 1;
  // Per vertex: a tetrahedron holding it, kept exact by every insertion (vertex removal may leave it
  // stale, so users check; kNoVertexTet before insertion); parallel walks restart from it.
  static constexpr index_t kNoVertexTet = 0x7FFFFFFFu;  // above every tetrahedron id
  std::vector<index_t> vertex_tet_;

  Worker seq_;  // the calling thread's scratch (insert(), build(), the sequential rest of a batch)
  // Parallel pass: the slot pool (recycled slots pool_, then the fresh range [fresh_begin_,
  // fresh_end_)) handed out in chunks from position pool_next_ (advanced with atomic builtins; a
  // std::atomic member would make the triangulation immovable).
  std::vector<index_t> pool_;
  std::size_t pool_next_ = 0;
  std::size_t fresh_begin_ = 0;
  std::size_t fresh_end_ = 0;

  index_t last_tet_ = 0;
  std::size_t min_points_per_thread_ = 8192;
  Stats stats_;
};

}  // namespace builder3d
}  // namespace dw
