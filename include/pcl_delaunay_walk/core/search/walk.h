/// \file walk.h
/// \brief The Delaunay walk (seed Algorithm 1): exact nearest neighbour by greedy descent on the graph.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/search/edge_scan.h"

namespace dw {

struct WalkResult {
  index_t vertex = kInvalidIndex;  ///< nearest vertex (kInvalidIndex only for an empty graph)
  float dist2 = 0.f;               ///< squared distance from the query to it
  std::uint32_t steps = 0;         ///< moves made (0: the start was already the nearest)
};

/// Squared distance in double from float coordinates: exact to 1 ulp of double, so it separates any two
/// vertices whose float positions differ in distance from q (float squared distances can tie there).
inline double squaredDistanceD(const Vec3f& a, const Vec3f& b) {
  const double dx = double(a.x) - b.x, dy = double(a.y) - b.y, dz = double(a.z) - b.z;
  return dx * dx + dy * dy + dz * dz;
}

/// Walks from `start` towards query `q` (in the graph's local frame).
///
/// At vertex i with u = q - x_i, c = u.e_ij for each edge; if some c > m_ij, move to the j of largest c, else
/// x_i is the exact nearest neighbour (docs/architecture.md, "Why the searches are exact"). The float test is
/// exact except within its rounding error (< 1e-6 (|u| + m), from u, the rounded unit vector and m): edges
/// that close to their threshold are re-decided by comparing distances in double, which also catches queries
/// far from the data, where float squared distances of different vertices round to the same value. A move is
/// taken only if it strictly lowers the double distance, so the walk always terminates. Before scanning, a
/// query inside the vertex's safe ball (DelaunayGraph::safe_radius2) ends the walk at once: near convergence
/// most ICP queries lie next to their previous nearest vertex.
///
/// `on_move(j)` is called each time the walk moves to vertex j, before j's neighbourhood is scanned: a
/// caller that reads its own record of the answer vertex afterwards can start loading it there, so the
/// load overlaps the rest of the walk (CallerMetricSearch does).
template <class OnMove>
inline WalkResult walk(const DelaunayGraph& g, const Vec3f& q, index_t start, OnMove&& on_move) {
  WalkResult r;
  if (g.points.empty()) return r;
  index_t i = start < g.points.size() ? start : 0;
  Vec3f u = q - g.points[i];
  double d2 = squaredDistanceD(q, g.points[i]);
  const float* const safe = g.safe_radius2.empty() ? nullptr : g.safe_radius2.data();
  for (;;) {
    if (safe && d2 <= safe[i]) break;
    const EdgeRecord* const first = g.edges.data() + g.offsets[i];
    const EdgeRecord* const end = g.edges.data() + g.offsets[i + 1];
    // An edge within rounding of its threshold (c ~ m <= |u|, error < 1e-6 (|u| + m)) is undecided.
    const float dist = std::sqrt(float(d2));
    const float tolerance = 2e-6f * dist + 1e-30f;
    // c - m > 0  <=>  q is closer to x_j; the largest c moves furthest along the descent. Edges with
    // m > stop_m have c - m <= |u| (1 + 1e-6) - m < -tolerance: no move, and not undecided either.
    const float stop_m = dist * 1.0001f + 2.f * tolerance;
    const EdgeScan scan = scanEdges(first, end, u, stop_m);
    const index_t best = scan.best;
    const float max_margin = scan.max_margin;  // how near the closest edge came to a move
    bool uncertain = max_margin > -tolerance;
    index_t next = kInvalidIndex;
    double next_d2 = d2;
    if (best != kInvalidIndex) {
      const double db = squaredDistanceD(q, g.points[best]);
      if (db < d2)
        next = best, next_d2 = db;
      else
        uncertain = true;  // float and double disagree: a rounding tie, settle it in double
    }
    if (next == kInvalidIndex && uncertain) {
      for (const EdgeRecord* e = first; e != end; ++e) {
        const double dj = squaredDistanceD(q, g.points[e->j]);
        if (dj < next_d2) next = e->j, next_d2 = dj;
      }
    }
    if (next == kInvalidIndex) break;
    on_move(next);
    i = next;
    u = q - g.points[i];
    d2 = next_d2;
    ++r.steps;
  }
  r.vertex = i;
  r.dist2 = static_cast<float>(d2);
  return r;
}

inline WalkResult walk(const DelaunayGraph& g, const Vec3f& q, index_t start) {
  return walk(g, q, start, [](index_t) {});
}

}  // namespace dw
