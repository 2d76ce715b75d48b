/// \file strip_group.h
/// \brief The exact, MPI-free core of the distributed TIN: a "strip group" is the part of the global
/// Delaunay triangulation that one rank (or a merged run of adjacent ranks) cannot yet emit, reduced to
/// the points and fence edges needed to finish it later. Leaves and tree merges both go through
/// processStrip(); the MPI driver only moves StripGroups between ranks. docs/mpi.md proves why the
/// emitted triangles of all levels are exactly DT(all points), each once.
///
/// Notation. Points carry a global index (gid, the symbolic-perturbation rank) and lie in strips
/// [lo, hi) along one axis u. A triangle is "sure" in a strip when its closed circumdisk lies strictly
/// inside lo < u < hi (checked in floating point with a safe margin, never optimistically): no point
/// outside the strip can then be in its disk, so it is a triangle of the global triangulation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace mpi {

/// Points as structure of arrays, sorted by strictly increasing gid. x, y: the triangulation frame
/// (exact predicates run on them); z travels along for the output only.
struct StripPoints {
  std::vector<index_t> gid;
  std::vector<double> x, y, z;

  std::size_t size() const { return gid.size(); }
  void reserve(std::size_t n);
  void push(index_t g, double px, double py, double pz);
};

/// What a strip still owes: the unsure region's vertices plus every hull vertex ("band" points), and the
/// fences: directed edges (a, b) (gids) with an emitted triangle on their left and the unsure region or
/// the outside of the strip's hull on their right.
struct StripGroup {
  double lo = -std::numeric_limits<double>::infinity();  ///< strip [lo, hi) along `axis`
  double hi = std::numeric_limits<double>::infinity();
  int axis = 0;  ///< 0: u = x, 1: u = y
  StripPoints band;
  std::vector<std::uint64_t> fences;  ///< (a << 32) | b

  /// Serialised form for MPI (plain bytes, same-architecture ranks).
  std::vector<unsigned char> serialize() const;
  static StripGroup deserialize(const unsigned char* bytes, std::size_t size);
};

/// Triangles a strip emitted, as gid triples (counter-clockwise in x, y).
struct Emitted {
  std::vector<index_t> triangles;
  /// (duplicate gid, representative gid) for points that collapsed onto an earlier gid (leaves only).
  std::vector<std::pair<index_t, index_t>> duplicates;
  std::size_t band_points = 0;  ///< points triangulated at this step
};

struct StripOptions {
  unsigned num_threads = 1;  ///< threads of the local dw::tin::triangulate
};

/// Leaf step: triangulates all `points` (every one inside [lo, hi) along `axis`; finite), emits the
/// triangles that are sure in the strip and returns the group that carries the rest. Throws dw::Error
/// on points outside the strip, unsorted gids, or any internal inconsistency.
StripGroup processLeaf(StripPoints&& points, int axis, double lo, double hi, Emitted& out,
                       const StripOptions& options = {});

/// Merge step: `left` and `right` are groups of adjacent strips (left.hi == right.lo). Triangulates the
/// union of their bands, discards (by flooding from the fences) what the already emitted triangles
/// cover, emits what is sure in the merged strip and returns the merged group. With lo = -inf and
/// hi = +inf (the root), everything left is emitted.
StripGroup mergeStrips(StripGroup&& left, StripGroup&& right, Emitted& out, const StripOptions& options = {});

}  // namespace mpi
}  // namespace dw
