/// \file tetra_mesh.h
/// \brief The tetrahedral mesh of the 3D triangulation: the combinatorial structure alone (CGAL's
/// triangulation data structure, geogram's cell_to_v / cell_to_cell), which computes no geometry.
///
/// - Tetrahedra live in two flat arrays: 4 vertex ids and 4 neighbour codes (tet * 4 + face) per
///   tetrahedron; face i is the face opposite vertex i. Freed tetrahedra (first vertex kDead) are
///   recycled through a free list.
/// - The convex hull is closed by an infinite vertex (kInfinite): each hull facet is the finite face of
///   one infinite tetrahedron.
/// - Slots are grown in batches, by a quarter at a time: the arrays are most of the builder's peak memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/uninitialised_allocator.h"

namespace dw {
namespace builder3d {

/// The mesh's per-tetrahedron arrays: resize(n) leaves new slots unwritten (a parallel pass writes
/// them as its threads take them).
template <class T>
using SlotArray = std::vector<T, UninitialisedAllocator<T>>;

/// A read of a slot that another thread may write: a relaxed atomic when shared (plain moves on x86,
/// but defined behaviour and TSan-clean), a plain read otherwise.
template <bool kShared>
inline std::uint32_t load(const std::uint32_t& x) {
  if constexpr (kShared) return __atomic_load_n(&x, __ATOMIC_RELAXED);
  return x;
}

/// The write that pairs with load().
template <bool kShared>
inline void store(std::uint32_t& x, std::uint32_t value) {
  if constexpr (kShared)
    __atomic_store_n(&x, value, __ATOMIC_RELAXED);
  else
    x = value;
}

/// Bits of an open-addressing table for at least `entries` slots (64 at the least).
inline unsigned tableBits(std::size_t entries) {
  // No loop: asked per insertion and per vertex of the edge extraction, whose sizes vary.
  const unsigned bits = entries <= 1 ? 0u : 64u - static_cast<unsigned>(__builtin_clzll(entries - 1));
  return bits < 6u ? 6u : bits;
}

/// Fibonacci hashing of a 64-bit key into `bits` bits.
inline std::size_t hashKey(std::uint64_t k, unsigned bits) {
  return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> (64 - bits));
}

struct TetraMesh {
  static constexpr index_t kInfinite = 0xFFFFFFFFu;     ///< the vertex at infinity
  static constexpr index_t kDead = 0xFFFFFFFEu;         ///< first vertex slot of a recycled tetrahedron
  static constexpr std::uint32_t kNoTet = 0xFFFFFFFFu;  ///< no tetrahedron (a walk that gave up)

  /// Per tetrahedron, during one insertion or removal. Not a char type, so that its stores do not
  /// force the compiler to reload everything else (char may alias any object).
  enum class Mark : std::uint8_t { kUnknown, kCavity, kOutside, kQueued };

  // Vertices and neighbour codes in separate arrays (measured: interleaving them in one cache line
  // made no difference), so the adjacency can be freed before the edge extraction, which needs only
  // the vertices: that keeps the builder's peak near one copy of the tetrahedra.
  SlotArray<index_t> tet_v;          ///< 4 per tetrahedron
  SlotArray<std::uint32_t> tet_n;    ///< 4 per tetrahedron: neighbour tet * 4 + the shared face's index there
  SlotArray<Mark> mark;              ///< per tetrahedron; kUnknown between insertions
  std::vector<index_t> free;         ///< recycled tetrahedra (the sequential free list)
  std::vector<std::uint32_t> birth;  ///< per tetrahedron, with track_births: the clock at its creation
  bool track_births = false;

  /// Slot count, live or recycled.
  std::size_t slots() const { return tet_v.size() / 4; }
  std::size_t numLive() const { return slots() - free.size(); }
  bool empty() const { return tet_v.empty(); }
  const index_t* vertices(std::size_t t) const { return &tet_v[4 * t]; }
  bool isDead(std::size_t t) const { return tet_v[4 * t] == kDead; }

  /// Drops every tetrahedron (capacity kept).
  void clear();
  /// The three per-slot arrays (vertices, neighbour codes, marks) together; new slots read as recycled.
  void reserveSlots(std::size_t slots);
  /// New slots are cleared (recycled state).
  void resizeSlots(std::size_t slots);
  /// New slots are left for whoever takes them to clear (a parallel pass's fresh range).
  void sizeSlotsUnwritten(std::size_t slots);
  /// Marks slot t recycled through atomic stores (another thread may read it).
  void clearSlot(std::size_t t);
  /// Grows the arrays until the free list holds at least `count` slots; new slots are born at `clock`.
  void ensureFreeSlots(std::size_t count, std::uint32_t clock);
  /// A slot off the free list (grown when empty).
  index_t newTet(std::uint32_t clock) {
    ensureFreeSlots(1, clock);
    const index_t t = free.back();
    free.pop_back();
    return t;
  }

  /// Vertices of the infinite tetrahedra (the hull's triangulated boundary), sorted, each once.
  std::vector<index_t> hullVertices() const;

  /// The structural checks: every live tetrahedron has vertex ids below `num_points` or kInfinite, at
  /// most one infinite vertex, live neighbours with symmetric adjacency sharing the face; exactly
  /// `num_inserted` vertices appear; the free list matches the dead slots. Throws dw::Error naming the
  /// first violation.
  void validate(std::size_t num_points, std::size_t num_inserted) const;

  /// Bytes held by the arrays (capacity).
  std::size_t memoryBytes() const;
};

}  // namespace builder3d
}  // namespace dw
