/// \file walk.h
/// \brief The Delaunay walk (seed Algorithm 1): exact nearest neighbour by greedy descent on the graph.
#pragma once

#include <cstdint>

#include "pcl_delaunay_walk/core/delaunay_graph.h"

namespace dw {

struct WalkResult {
  index_t vertex = kInvalidIndex;  ///< nearest vertex (kInvalidIndex only for an empty graph)
  float dist2 = 0.f;               ///< squared distance from the query to it
  std::uint32_t steps = 0;         ///< moves made (0: the start was already the nearest)
};

/// Walks from `start` towards query `q` (in the graph's local frame).
///
/// At vertex i with u = q - x_i, c = u.e_ij for each edge; if some c > m_ij, move to the j of largest
/// c, else x_i is the exact nearest neighbour (DESIGN.md §3). A move is taken only if it strictly
/// lowers the float distance, so the walk always terminates, even where rounding makes c and m tie.
inline WalkResult walk(const DelaunayGraph& g, const Vec3f& q, index_t start) {
  WalkResult r;
  if (g.points.empty()) return r;
  index_t i = start < g.points.size() ? start : 0;
  Vec3f u = q - g.points[i];
  float d2 = dot(u, u);
  for (;;) {
    const EdgeRecord* e = g.edges.data() + g.offsets[i];
    const EdgeRecord* end = g.edges.data() + g.offsets[i + 1];
    float best_gain = 0.f;
    index_t best = kInvalidIndex;
    for (; e != end; ++e) {
      // c - m > 0  <=>  q is closer to x_j; the largest c moves furthest along the descent.
      const float c = u.x * e->ex + u.y * e->ey + u.z * e->ez;
      if (c > e->m && c > best_gain) {
        best_gain = c;
        best = e->j;
      }
    }
    if (best == kInvalidIndex) break;
    const Vec3f un = q - g.points[best];
    const float d2n = dot(un, un);
    if (!(d2n < d2)) break;  // a rounding tie: i is as near as best
    i = best;
    u = un;
    d2 = d2n;
    ++r.steps;
  }
  r.vertex = i;
  r.dist2 = d2;
  return r;
}

}  // namespace dw
