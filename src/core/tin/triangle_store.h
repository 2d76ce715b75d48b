/// \file triangle_store.h
/// \brief Flat structure-of-arrays triangle store shared by the strip kernels and the merge (internal).
///
/// Triangle t has vertices tv[3t..3t+2] (counter-clockwise) and, for each vertex slot i, the "corner"
/// tn[3t+i] = 3u+j of the neighbour u across the edge opposite vertex i (j: the slot in u opposite the
/// same edge), so the reverse link is found in O(1). The convex hull is closed by ghost triangles that
/// share the ghost vertex kGhost (CGAL's infinite vertex): every triangle then has three neighbours and
/// points outside the hull are handled by the same conflict test as the rest.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace tin {
namespace detail {

constexpr index_t kGhost = 0x7FFFFFFEu;  ///< the vertex at infinity
constexpr index_t kDead = 0x7FFFFFFFu;   ///< tv[3t] of an unused slot
constexpr index_t kMark = 0x80000000u;   ///< transient flag on tv[3t] (cavity / band membership)

inline index_t next3(index_t i) {
  return i == 2 ? 0 : i + 1;
}
inline index_t prev3(index_t i) {
  return i == 0 ? 2 : i - 1;
}

/// Coordinates (in insertion positions) and the ranks used for tie-breaking (input indices).
struct PointSet {
  const double* xy = nullptr;  ///< interleaved x, y: one cache line holds both coordinates
  const index_t* rank = nullptr;
  double x(index_t i) const { return xy[2 * std::size_t(i)]; }
  double y(index_t i) const { return xy[2 * std::size_t(i) + 1]; }
  const double* at(index_t i) const { return xy + 2 * std::size_t(i); }
};

/// The triangle arena: raw arrays so strips can fill disjoint slot ranges of one allocation in parallel.
struct TriangleArena {
  index_t* tv = nullptr;
  index_t* tn = nullptr;
};

inline bool isGhost(const index_t* tv, index_t t) {
  const index_t* v = tv + 3 * t;
  return (v[0] & ~kMark) == kGhost || v[1] == kGhost || v[2] == kGhost;
}

/// Exact "p is strictly inside the circumcircle" of triangle t; for a ghost (a, b, inf) the circle is
/// the open half-plane left of a->b plus the open segment ab (so points on a hull edge split it).
inline bool inConflict(const PointSet& ps, const index_t* tv, index_t t, index_t p) {
  index_t a = tv[3 * t] & ~kMark, b = tv[3 * t + 1], c = tv[3 * t + 2];
  const double px = ps.x(p), py = ps.y(p);
  if (a == kGhost || b == kGhost || c == kGhost) {
    if (a == kGhost) {
      a = b;
      b = c;
    } else if (b == kGhost) {
      b = a;
      a = c;
    }
    const int o = pred::orient2d(ps.x(a), ps.y(a), ps.x(b), ps.y(b), px, py);
    if (o != 0) return o > 0;
    // Collinear with the hull edge: in conflict exactly when strictly between a and b.
    if (ps.x(a) != ps.x(b)) return (px > ps.x(a)) != (px > ps.x(b)) && px != ps.x(a) && px != ps.x(b);
    return (py > ps.y(a)) != (py > ps.y(b)) && py != ps.y(a) && py != ps.y(b);
  }
  const double pa[2] = {ps.x(a), ps.y(a)}, pb[2] = {ps.x(b), ps.y(b)}, pc[2] = {ps.x(c), ps.y(c)};
  const double pd[2] = {px, py};
  const int s = pred::incircle(pa[0], pa[1], pb[0], pb[1], pc[0], pc[1], px, py);
  if (s != 0) return s > 0;
  return pred::incirclePerturbed(pa, ps.rank[a], pb, ps.rank[b], pc, ps.rank[c], pd, ps.rank[p]) > 0;
}

}  // namespace detail
}  // namespace tin
}  // namespace dw
