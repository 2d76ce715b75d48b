/// \file walk_path.h
/// \brief The vertices one Delaunay walk visits, for drawing it: the seed explains the walk with
/// pictures of it, and a user should see the same on their own data.
#pragma once

#include <vector>

#include "pcl_delaunay_walk/core/search/walk.h"

namespace dw_viewer {

/// The walk of dw::walk from `start` towards q (graph-local frame), every visited vertex in order:
/// the start first, q's nearest vertex last. It repeats dw::walk's moves exactly (same gain, same
/// tie rule) so that the drawn path is the one the search took; the test compares the two.
inline std::vector<dw::index_t> walkPath(const dw::DelaunayGraph& g, const dw::Vec3f& q, dw::index_t start) {
  std::vector<dw::index_t> path;
  if (g.points.empty()) return path;
  dw::index_t i = start < g.points.size() ? start : 0;
  path.push_back(i);
  dw::Vec3f u = q - g.points[i];
  float d2 = dw::dot(u, u);
  for (;;) {
    float best_gain = 0.f;
    dw::index_t best = dw::kInvalidIndex;
    for (dw::index_t k = g.offsets[i]; k < g.offsets[i + 1]; ++k) {
      const dw::EdgeRecord& e = g.edges[k];
      const float c = u.x * e.ex + u.y * e.ey + u.z * e.ez;
      if (c > e.m && c > best_gain) {
        best_gain = c;
        best = e.j;
      }
    }
    if (best == dw::kInvalidIndex) break;
    const dw::Vec3f un = q - g.points[best];
    const float d2n = dw::dot(un, un);
    if (!(d2n < d2)) break;
    i = best;
    u = un;
    d2 = d2n;
    path.push_back(i);
  }
  return path;
}

}  // namespace dw_viewer
