/// \file delaunay_kernel_3d.h
/// \brief Incremental 3D Delaunay triangulation (Bowyer-Watson) on flat structure-of-arrays storage,
/// made for one purpose: producing the walk graph's edges (DESIGN.md §2, issue 8).
///
/// - Tetrahedra live in two flat arrays: 4 vertex ids and 4 neighbour codes (tet * 4 + face) per
///   tetrahedron; face i is the face opposite vertex i. Freed tetrahedra are recycled.
/// - The convex hull is closed by an infinite vertex (kInfinite): each hull facet is the finite face of
///   one infinite tetrahedron. Unlike a bounding super-tetrahedron this changes no Delaunay edge near
///   the hull, so every hull edge of the real points is present and no artificial edge exists.
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

#include "pcl_delaunay_walk/core/types.h"

namespace dw {
namespace builder3d {

class DelaunayKernel3D {
 public:
  static constexpr index_t kInfinite = 0xFFFFFFFFu;  ///< the vertex at infinity
  static constexpr index_t kDead = 0xFFFFFFFEu;      ///< first vertex slot of a recycled tetrahedron
  /// Keeps tet * 4 + face in 32 bits (about 6.7 tetrahedra per vertex on volumetric input).
  static constexpr std::size_t kMaxVertices = 150000000;

  /// Points are read through `points` (not copied). The array must stay alive and unchanged for
  /// every vertex already inserted; it may grow (call setPoints again) before inserting new ones.
  void setPoints(const Vec3f* points, std::size_t n);

  /// Triangulates the vertices `order[0..n)` (distinct points) inserted in that order. The first
  /// tetrahedron is made of the first four non-coplanar ones. Throws dw::Error if all are coplanar.
  /// `progress` (optional) receives the fraction inserted.
  void build(const index_t* order, std::size_t n, const std::function<void(double)>& progress = {});

  /// Inserts one more vertex (a point distinct from every vertex present) into a built triangulation.
  void insert(index_t v);

  /// Whether build() has produced a tetrahedralisation.
  bool built() const { return !tet_v_.empty(); }

  std::size_t numVertices() const { return num_inserted_; }
  std::size_t numLiveTetrahedra() const { return tet_v_.size() / 4 - free_.size(); }

  using EdgeChunks = std::vector<std::vector<std::pair<index_t, index_t>>>;

  /// Every Delaunay edge between finite vertices, u < v, each once. Split into one chunk per thread
  /// (`num_threads` >= 1; the chunks are made in parallel) so the caller can concatenate them after
  /// freeing the kernel.
  EdgeChunks edgeChunks(unsigned num_threads) const;

  /// edgeChunks(), but frees the adjacency first and the tetrahedra last: the peak memory then holds
  /// the vertex quadruples and the edges, not the whole structure plus the edges. Leaves the kernel
  /// empty (built() is false).
  EdgeChunks releaseIntoEdgeChunks(unsigned num_threads);

  /// The edges (a, b), a < b, of the triangulation whose smaller endpoint a is in [first, last), each
  /// once: what one block of the parallel builder owns.
  std::vector<std::pair<index_t, index_t>> edgesFrom(std::size_t first, std::size_t last) const;

  /// Vertices of the convex hull's triangulated boundary (those of the infinite tetrahedra), sorted.
  std::vector<index_t> hullVertices() const;

  /// Raw access for the parallel builder's certification: slot count (live or recycled) and the four
  /// vertices of a slot (first entry kDead for a recycled one, kInfinite marks the infinite vertex).
  std::size_t tetSlots() const { return tet_v_.size() / 4; }

  /// Records, per tetrahedron slot, the insertion count at which it was (re)created, so that a caller
  /// can revisit only what changed since a moment (costs 4 bytes per tetrahedron). Call before build().
  void trackBirths(bool on) { track_births_ = on; }
  /// Insertions so far (the clock of birth()).
  std::uint32_t clock() const { return static_cast<std::uint32_t>(num_inserted_); }
  /// Birth of slot t (only with trackBirths(true)).
  std::uint32_t birth(std::size_t t) const { return birth_[t]; }
  const index_t* tetVertices(std::size_t t) const { return &tet_v_[4 * t]; }

  /// Checks the whole structure (adjacency symmetry, orientation of every tetrahedron, the local
  /// Delaunay property of every interior face under the same perturbation, the Euler relation).
  /// Throws dw::Error naming the first violation. O(tetrahedra); for tests.
  void validate() const;

  /// Bytes held by the kernel's arrays (capacity), for memory accounting.
  std::size_t memoryBytes() const;

  /// Statistics of the last build (for benchmarks and docs).
  struct Stats {
    std::uint64_t walk_steps = 0;
    std::uint64_t conflict_tests = 0;
    std::uint64_t created_tets = 0;
    std::uint64_t fallback_locations = 0;  ///< walks that hit the step guard and fell back to a scan
  };
  const Stats& stats() const { return stats_; }

 private:
  struct BoundaryFace {
    index_t v[4];         // the new tetrahedron (cavity tet with its vertex `face` replaced by the new point)
    std::uint32_t outer;  // neighbour code of the tetrahedron outside the cavity
    std::uint32_t face;   // local index of that face in the new tetrahedron
  };

  static EdgeChunks extractEdges(const std::vector<index_t>& tet_v, std::size_t num_points,
                                 unsigned num_threads, std::size_t first, std::size_t last);
  void initialTetrahedron(index_t a, index_t b, index_t c, index_t d);
  index_t locate(index_t v, index_t start);
  index_t locateByScan(index_t v) const;
  // Conflict of tetrahedron t with vertex v at p (p = v's coordinates, converted once per insertion).
  bool inConflict(index_t t, index_t v, const double* p) const;
  bool finiteInConflict(index_t t, index_t v, const double* p) const;
  index_t newTet();
  void point(index_t v, double out[3]) const {
    const Vec3f& p = points_[v];
    out[0] = p.x;
    out[1] = p.y;
    out[2] = p.z;
  }

  const Vec3f* points_ = nullptr;
  std::size_t num_points_ = 0;
  std::size_t num_inserted_ = 0;

  // Vertices and neighbour codes in separate arrays (measured: interleaving them in one cache line
  // made no difference), so the adjacency can be freed before the edge extraction, which needs only
  // the vertices: that keeps the builder's peak near one copy of the tetrahedra.
  std::vector<index_t> tet_v_;        // 4 per tetrahedron
  std::vector<std::uint32_t> tet_n_;  // 4 per tetrahedron: neighbour tet * 4 + the shared face's index there
  std::vector<std::uint8_t> mark_;    // per tetrahedron: 0 unknown, 1 in cavity, 2 tested outside
  std::vector<index_t> free_;         // recycled tetrahedra
  std::vector<std::uint32_t> birth_;  // per tetrahedron, with track_births_
  bool track_births_ = false;

  // Per-insertion scratch, kept to avoid allocation in the hot loop.
  std::vector<index_t> cavity_, stack_, outside_;
  std::vector<BoundaryFace> boundary_;
  std::vector<std::uint64_t> link_key_;
  std::vector<std::uint32_t> link_val_;
  std::vector<std::uint32_t> link_gen_;
  std::uint32_t generation_ = 0;

  index_t last_tet_ = 0;
  std::uint32_t rng_ = 0x9E3779B9u;
  Stats stats_;
};

}  // namespace builder3d
}  // namespace dw
