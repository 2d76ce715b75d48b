/// \file bowyer_watson.h
/// \brief The sequential 2D Bowyer-Watson kernel (internal): spatially sorted insertion, visibility walk
/// point location from the last created triangle, cavity by depth-first conflict search, fan
/// re-triangulation. Works in a caller-given slot range of a shared TriangleArena.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "triangle_store.h"

namespace dw {
namespace tin {
namespace detail {

class BowyerWatson {
 public:
  /// Slots [base, base + capacity) of `arena` belong to this kernel. n distinct-or-duplicate points
  /// need at most 2n + 2 slots.
  BowyerWatson(const PointSet& points, TriangleArena arena, index_t base, index_t capacity);

  /// Inserts the points order[0..m) (positions) in that order. Duplicates (equal x and y) are not
  /// inserted; they are reported in duplicates() as (position, representative position). If all
  /// distinct points are collinear, no triangle is made and collinearVertices() lists them.
  void run(const index_t* order, std::size_t m);

  bool hasTriangles() const { return has_triangles_; }
  /// Slots used: [base, base + used()).
  index_t used() const { return next_ - base_; }
  /// Any ghost triangle (valid after run() when hasTriangles()).
  index_t anyGhost() const;
  /// Distinct vertices inserted (including the collinear set of a degenerate run).
  std::size_t numVertices() const { return num_vertices_; }
  const std::vector<std::pair<index_t, index_t>>& duplicates() const { return dups_; }
  const std::vector<index_t>& collinearVertices() const { return collinear_; }

 private:
  void makeFirstTriangle(index_t a, index_t b, index_t c);
  void insert(index_t p);
  /// Returns a triangle in conflict with p, or kGhost | (vertex) marker via *dup when p duplicates a vertex.
  index_t locate(index_t p, index_t* dup);
  index_t alloc();

  PointSet ps_;
  index_t* tv_;
  index_t* tn_;
  index_t base_, cap_, next_;
  index_t last_ = kDead;
  bool has_triangles_ = false;
  std::size_t num_vertices_ = 0;
  std::vector<std::pair<index_t, index_t>> dups_;
  std::vector<index_t> collinear_;
  // Scratch reused by every insertion (no allocation in steady state).
  std::vector<index_t> stack_, cavity_;
  struct BoundaryEdge {
    index_t u, v, outside;
  };
  std::vector<BoundaryEdge> boundary_;
  std::vector<std::pair<index_t, index_t>> by_u_;
};

/// Insertion order for Bowyer-Watson: biased randomised rounds (BRIO), Hilbert order within a round
/// (dw::hilbertKey, space_filling_curve.h).
/// Positions index interleaved xy. Stable for equal points (same round, same key), so copies of a point
/// stay in input order and the first copy inserted is the one with the smallest rank.
void brioHilbertSort(const double* xy, std::vector<index_t>& positions);

}  // namespace detail
}  // namespace tin
}  // namespace dw
