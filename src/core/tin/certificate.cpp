/// \file certificate.cpp
/// \brief Delaunay certificate of a triangle list (see certificate.h).
#include "pcl_delaunay_walk/core/tin/certificate.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"

namespace dw {
namespace tin {

namespace {

/// Directed edge a->b (key a << 32 | b) of triangle tri, with the triangle's vertex opposite it.
struct DEdge {
  std::uint64_t key;
  index_t opp;
  index_t tri;
};

/// Every triangle's vertices in range, in the exact predicates' range and counter-clockwise; counts the
/// vertices used. Returns the failure, or "" when all hold.
std::string checkTriangles(const double* x, const double* y, std::size_t n, const index_t* tris,
                           std::size_t expected_vertices, Certificate& c) {
  const std::size_t nt = c.triangles;
  std::vector<unsigned char> used(n, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    const index_t a = tris[3 * t], b = tris[3 * t + 1], d = tris[3 * t + 2];
    if (a >= n || b >= n || d >= n) return "vertex index out of range in triangle " + std::to_string(t);
    for (const index_t v : {a, b, d})
      if (!(pred::inExactRange(x[v]) && pred::inExactRange(y[v])))
        return "vertex " + std::to_string(v) + " is non-finite or outside the exact predicates' range";
    if (pred::orient2d(x[a], y[a], x[b], y[b], x[d], y[d]) <= 0)
      return "triangle " + std::to_string(t) + " is not counter-clockwise";
    used[a] = used[b] = used[d] = 1;
  }
  for (std::size_t i = 0; i < n; ++i) c.vertices += used[i];
  if (expected_vertices && c.vertices != expected_vertices)
    return "mesh uses " + std::to_string(c.vertices) + " vertices, expected " +
           std::to_string(expected_vertices);
  return {};
}

/// No directed edge in two triangles, every interior edge locally Delaunay (exact, perturbed); the
/// edges without a reverse (the hull) go into hull_next, which must map each vertex once.
std::string checkEdges(const double* x, const double* y, const index_t* tris, Certificate& c,
                       std::unordered_map<index_t, index_t>& hull_next) {
  const std::size_t nt = c.triangles;
  // Sorted for reverse look-up.
  std::vector<DEdge> edges;
  edges.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t)
    for (int i = 0; i < 3; ++i) {
      const index_t a = tris[3 * t + (i + 1) % 3], b = tris[3 * t + (i + 2) % 3];
      edges.push_back({(std::uint64_t(a) << 32) | b, tris[3 * t + i], index_t(t)});
    }
  std::sort(edges.begin(), edges.end(), [](const DEdge& l, const DEdge& r) { return l.key < r.key; });
  for (std::size_t i = 1; i < edges.size(); ++i)
    if (edges[i].key == edges[i - 1].key) return "a directed edge belongs to two triangles (overlap)";
  for (const DEdge& e : edges) {
    const index_t a = index_t(e.key >> 32), b = index_t(e.key & 0xFFFFFFFFu);
    const std::uint64_t rev = (std::uint64_t(b) << 32) | a;
    const auto it = std::lower_bound(edges.begin(), edges.end(), rev,
                                     [](const DEdge& l, std::uint64_t k) { return l.key < k; });
    if (it == edges.end() || it->key != rev) {
      if (!hull_next.emplace(a, b).second)
        return "hull is not a simple cycle (vertex " + std::to_string(a) + ")";
      continue;
    }
    if (a > b) continue;  // each interior edge once
    ++c.interior_edges;
    const double pa[2] = {x[a], y[a]}, pb[2] = {x[b], y[b]}, po[2] = {x[e.opp], y[e.opp]};
    const double pq[2] = {x[it->opp], y[it->opp]};
    // Triangle (a, b, opp) is counter-clockwise; the opposite apex must be outside its circle.
    if (pred::incirclePerturbed(pa, a, pb, b, po, e.opp, pq, it->opp) >= 0)
      return "edge (" + std::to_string(a) + ", " + std::to_string(b) + ") is not locally Delaunay";
  }
  return {};
}

/// The boundary must be one convex counter-clockwise cycle that winds exactly once, and the mesh a
/// triangulated disc (Euler).
std::string checkHull(const double* x, const double* y, const std::unordered_map<index_t, index_t>& hull_next,
                      const Certificate& c) {
  const index_t start = hull_next.begin()->first;
  index_t prev = start, cur = hull_next.at(start);
  std::size_t steps = 1;
  double turning = 0.0;
  while (true) {
    const auto it = hull_next.find(cur);
    if (it == hull_next.end()) return "hull chain is open";
    const index_t nxt = it->second;
    if (pred::orient2d(x[prev], y[prev], x[cur], y[cur], x[nxt], y[nxt]) < 0)
      return "hull is not convex at vertex " + std::to_string(cur);
    const double a1 = std::atan2(y[cur] - y[prev], x[cur] - x[prev]);
    const double a2 = std::atan2(y[nxt] - y[cur], x[nxt] - x[cur]);
    double d = a2 - a1;
    while (d <= -M_PI) d += 2 * M_PI;
    while (d > M_PI) d -= 2 * M_PI;
    turning += d;
    prev = cur;
    cur = nxt;
    if (prev == start) break;
    if (++steps > hull_next.size()) return "hull chain does not close";
  }
  if (steps != hull_next.size()) return "boundary has more than one cycle";
  if (std::fabs(turning - 2 * M_PI) > 1e-3) return "hull winds more than once";
  if (c.triangles != 2 * c.vertices - 2 - c.hull_edges) return "Euler count: not a triangulated disc";
  return {};
}

}  // namespace

Certificate certifyDelaunay(const double* x, const double* y, std::size_t n, const index_t* tris,
                            std::size_t num_indices, std::size_t expected_vertices) {
  Certificate c;
  auto fail = [&](const std::string& m) {
    c.ok = false;
    c.message = m;
    return c;
  };
  if (num_indices % 3 != 0) return fail("triangle array length is not a multiple of 3");
  c.triangles = num_indices / 3;
  std::string failure = checkTriangles(x, y, n, tris, expected_vertices, c);
  if (!failure.empty()) return fail(failure);
  std::unordered_map<index_t, index_t> hull_next;
  failure = checkEdges(x, y, tris, c, hull_next);
  if (!failure.empty()) return fail(failure);
  c.hull_edges = hull_next.size();
  if (c.triangles > 0) {
    failure = checkHull(x, y, hull_next, c);
    if (!failure.empty()) return fail(failure);
  } else if (!hull_next.empty()) {
    return fail("inconsistent empty mesh");
  }
  c.ok = true;
  c.message = "ok";
  return c;
}

}  // namespace tin
}  // namespace dw
