/// \file certificate.cpp
/// \brief Delaunay certificate of a triangle list (see certificate.h).
#include "pcl_delaunay_walk/core/tin/certificate.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"

namespace dw {
namespace tin {

Certificate certifyDelaunay(const double* x, const double* y, std::size_t n, const index_t* tris,
                            std::size_t num_indices, std::size_t expected_vertices) {
  Certificate c;
  auto fail = [&](const std::string& m) {
    c.ok = false;
    c.message = m;
    return c;
  };
  if (num_indices % 3 != 0) return fail("triangle array length is not a multiple of 3");
  const std::size_t nt = num_indices / 3;
  c.triangles = nt;
  std::vector<unsigned char> used(n, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    const index_t a = tris[3 * t], b = tris[3 * t + 1], d = tris[3 * t + 2];
    if (a >= n || b >= n || d >= n) return fail("vertex index out of range in triangle " + std::to_string(t));
    for (const index_t v : {a, b, d})
      if (!(pred::inExactRange(x[v]) && pred::inExactRange(y[v])))
        return fail("vertex " + std::to_string(v) + " is non-finite or outside the exact predicates' range");
    if (pred::orient2d(x[a], y[a], x[b], y[b], x[d], y[d]) <= 0)
      return fail("triangle " + std::to_string(t) + " is not counter-clockwise");
    used[a] = used[b] = used[d] = 1;
  }
  for (std::size_t i = 0; i < n; ++i) c.vertices += used[i];
  if (expected_vertices && c.vertices != expected_vertices)
    return fail("mesh uses " + std::to_string(c.vertices) + " vertices, expected " +
                std::to_string(expected_vertices));

  // Directed edges a->b with the triangle's opposite vertex, sorted for reverse look-up.
  struct DEdge {
    std::uint64_t key;
    index_t opp;
    index_t tri;
  };
  std::vector<DEdge> edges;
  edges.reserve(num_indices);
  for (std::size_t t = 0; t < nt; ++t)
    for (int i = 0; i < 3; ++i) {
      const index_t a = tris[3 * t + (i + 1) % 3], b = tris[3 * t + (i + 2) % 3];
      edges.push_back({(std::uint64_t(a) << 32) | b, tris[3 * t + i], index_t(t)});
    }
  std::sort(edges.begin(), edges.end(), [](const DEdge& l, const DEdge& r) { return l.key < r.key; });
  for (std::size_t i = 1; i < edges.size(); ++i)
    if (edges[i].key == edges[i - 1].key) return fail("a directed edge belongs to two triangles (overlap)");
  std::unordered_map<index_t, index_t> hull_next;
  for (const DEdge& e : edges) {
    const index_t a = index_t(e.key >> 32), b = index_t(e.key & 0xFFFFFFFFu);
    const std::uint64_t rev = (std::uint64_t(b) << 32) | a;
    const auto it = std::lower_bound(edges.begin(), edges.end(), rev,
                                     [](const DEdge& l, std::uint64_t k) { return l.key < k; });
    if (it == edges.end() || it->key != rev) {
      if (!hull_next.emplace(a, b).second)
        return fail("hull is not a simple cycle (vertex " + std::to_string(a) + ")");
      continue;
    }
    if (a > b) continue;  // each interior edge once
    ++c.interior_edges;
    const double pa[2] = {x[a], y[a]}, pb[2] = {x[b], y[b]}, po[2] = {x[e.opp], y[e.opp]};
    const double pq[2] = {x[it->opp], y[it->opp]};
    // Triangle (a, b, opp) is counter-clockwise; the opposite apex must be outside its circle.
    if (pred::incirclePerturbed(pa, a, pb, b, po, e.opp, pq, it->opp) >= 0)
      return fail("edge (" + std::to_string(a) + ", " + std::to_string(b) + ") is not locally Delaunay");
  }
  c.hull_edges = hull_next.size();
  if (nt > 0) {
    // The boundary must be one convex counter-clockwise cycle that winds exactly once.
    const index_t start = hull_next.begin()->first;
    index_t prev = start, cur = hull_next.at(start);
    std::size_t steps = 1;
    double turning = 0.0;
    while (true) {
      const auto it = hull_next.find(cur);
      if (it == hull_next.end()) return fail("hull chain is open");
      const index_t nxt = it->second;
      if (pred::orient2d(x[prev], y[prev], x[cur], y[cur], x[nxt], y[nxt]) < 0)
        return fail("hull is not convex at vertex " + std::to_string(cur));
      const double a1 = std::atan2(y[cur] - y[prev], x[cur] - x[prev]);
      const double a2 = std::atan2(y[nxt] - y[cur], x[nxt] - x[cur]);
      double d = a2 - a1;
      while (d <= -M_PI) d += 2 * M_PI;
      while (d > M_PI) d -= 2 * M_PI;
      turning += d;
      prev = cur;
      cur = nxt;
      if (prev == start) break;
      if (++steps > hull_next.size()) return fail("hull chain does not close");
    }
    if (steps != hull_next.size()) return fail("boundary has more than one cycle");
    if (std::fabs(turning - 2 * M_PI) > 1e-3) return fail("hull winds more than once");
    if (nt != 2 * c.vertices - 2 - c.hull_edges) return fail("Euler count: not a triangulated disc");
  } else if (!hull_next.empty()) {
    return fail("inconsistent empty mesh");
  }
  c.ok = true;
  c.message = "ok";
  return c;
}

}  // namespace tin
}  // namespace dw
