#include "pcl_delaunay_walk/core/delaunay_graph.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace dw {

namespace {
[[noreturn]] void broken(const std::string& what) {
  throw Error("pcl_delaunay_walk: invalid graph: " + what);
}
}  // namespace

void DelaunayGraph::validate() const {
  const std::size_t n = points.size();
  if (dimension < 0 || dimension > 3) broken("dimension out of range");
  for (double o : origin)
    if (!std::isfinite(o)) broken("non-finite origin");
  if (offsets.size() != n + 1 || offsets.front() != 0) broken("offsets size");
  if (offsets.back() != edges.size()) broken("offsets do not end at the edge count");
  for (std::size_t v = 0; v < n; ++v) {
    if (offsets[v] > offsets[v + 1]) broken("offsets not monotonic at vertex " + std::to_string(v));
    if (!std::isfinite(points[v].x) || !std::isfinite(points[v].y) || !std::isfinite(points[v].z))
      broken("non-finite vertex " + std::to_string(v));
  }
  for (const EdgeRecord& e : edges) {
    if (e.j >= n) broken("edge neighbour out of range");
    if (!(e.m >= 0.f) || !std::isfinite(e.ex) || !std::isfinite(e.ey) || !std::isfinite(e.ez))
      broken("non-finite edge record");
  }
  for (std::size_t v = 0; v < n; ++v)
    for (index_t e = offsets[v]; e + 1 < offsets[v + 1]; ++e)
      if (!(edges[e].m <= edges[e + 1].m))  // the walk's early stop relies on this order
        broken("edges of vertex " + std::to_string(v) + " not sorted by length");
  if (!safe_radius2.empty()) {
    if (safe_radius2.size() != n) broken("safe radii size");
    for (std::size_t v = 0; v < n; ++v) {
      float r = INFINITY;
      for (index_t e = offsets[v]; e < offsets[v + 1]; ++e) r = std::min(r, edges[e].m);
      // A radius larger than half the nearest-neighbour distance would stop walks at the wrong vertex.
      if (!(safe_radius2[v] >= 0.f) || (safe_radius2[v] > 0.f && !(double(safe_radius2[v]) < double(r) * r)))
        broken("safe radius too large at vertex " + std::to_string(v));
    }
  }
  if (originals_offsets.size() != n + 1 || originals_offsets.front() != 0 ||
      originals_offsets.back() != originals.size())
    broken("originals offsets");
  const std::size_t num_input = input_to_vertex.size();
  for (std::size_t v = 0; v < n; ++v) {
    if (originals_offsets[v] >= originals_offsets[v + 1]) broken("vertex without an input point");
    for (index_t k = originals_offsets[v]; k < originals_offsets[v + 1]; ++k) {
      const index_t i = originals[k];
      if (i >= num_input || input_to_vertex[i] != v) broken("originals do not match input_to_vertex");
      if (k > originals_offsets[v] && originals[k - 1] >= i) broken("originals not ascending");
    }
  }
  std::size_t mapped = 0;
  for (index_t v : input_to_vertex) {
    if (v == kInvalidIndex) continue;
    if (v >= n) broken("input_to_vertex out of range");
    ++mapped;
  }
  if (mapped != originals.size()) broken("input_to_vertex count differs from originals");
}

std::size_t DelaunayGraph::memoryBytes() const {
  return points.size() * sizeof(Vec3f) + offsets.size() * sizeof(index_t) +
         edges.size() * sizeof(EdgeRecord) + input_to_vertex.size() * sizeof(index_t) +
         originals_offsets.size() * sizeof(index_t) + originals.size() * sizeof(index_t) +
         safe_radius2.size() * sizeof(float);
}

void assembleEdges(DelaunayGraph& g, std::vector<std::pair<index_t, index_t>> undirected, bool distinct) {
  const std::size_t n = g.points.size();
  // Normalise, then sort/unique: builders may report an edge once per incident simplex. A list known
  // to be distinct skips the sort (3 % of a LiDAR frame's build); the records' order comes from
  // sortNeighbourhoods either way.
  for (auto& e : undirected) {
    if (e.first > e.second) std::swap(e.first, e.second);
    if (e.second >= n) throw Error("pcl_delaunay_walk: builder returned an edge to a missing vertex");
  }
  if (!distinct) {
    std::sort(undirected.begin(), undirected.end());
    undirected.erase(std::unique(undirected.begin(), undirected.end()), undirected.end());
  }
  undirected.erase(std::remove_if(undirected.begin(), undirected.end(),
                                  [](const std::pair<index_t, index_t>& e) { return e.first == e.second; }),
                   undirected.end());
  if (2 * undirected.size() > static_cast<std::size_t>(kInvalidIndex))
    throw Error("pcl_delaunay_walk: graph has more than 2^32 directed edges");

  std::vector<index_t> degree(n + 1, 0);
  for (const auto& e : undirected) {
    ++degree[e.first];
    ++degree[e.second];
  }
  g.offsets.assign(n + 1, 0);
  for (std::size_t v = 0; v < n; ++v) g.offsets[v + 1] = g.offsets[v] + degree[v];
  g.edges.resize(g.offsets[n]);
  std::vector<index_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  auto put = [&](index_t i, index_t j) {
    const Vec3f d = g.points[j] - g.points[i];
    const double len = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
    const double inv = len > 0.0 ? 1.0 / len : 0.0;
    g.edges[fill[i]++] = {float(d.x * inv), float(d.y * inv), float(d.z * inv), float(0.5 * len), j};
  };
  for (const auto& e : undirected) {
    put(e.first, e.second);
    put(e.second, e.first);
  }
  sortNeighbourhoods(g);
  if (distinct) {
    // Sorted by (length, neighbour), a repeat sits next to its twin: one pass checks the promise.
    for (std::size_t v = 0; v < n; ++v)
      for (index_t e = g.offsets[v] + 1; e < g.offsets[v + 1]; ++e)
        if (g.edges[e].j == g.edges[e - 1].j)
          throw Error("pcl_delaunay_walk: builder returned edge (" + std::to_string(v) + ", " +
                      std::to_string(g.edges[e].j) + ") twice");
  }
  computeSafeRadii(g);
}

namespace {
// Shortest edge first (the walk stops reading a neighbourhood at the first edge longer than 2|u|);
// ties by neighbour id, so files are deterministic.
bool shorterEdge(const EdgeRecord& a, const EdgeRecord& b) {
  return a.m < b.m || (a.m == b.m && a.j < b.j);
}
}  // namespace

void sortNeighbourhoods(DelaunayGraph& g) {
  // Runs on loaded data before validate(): leave anything malformed (bad offsets, NaN lengths, which
  // would break std::sort's ordering contract) untouched for validate() to report.
  const std::size_t nv = g.offsets.size() - (g.offsets.empty() ? 0 : 1);
  for (std::size_t v = 0; v < nv; ++v) {
    if (g.offsets[v] > g.offsets[v + 1] || g.offsets[v + 1] > g.edges.size()) return;
    const auto first = g.edges.begin() + g.offsets[v], last = g.edges.begin() + g.offsets[v + 1];
    if (std::is_sorted(first, last, shorterEdge)) continue;
    if (std::any_of(first, last, [](const EdgeRecord& e) { return !std::isfinite(e.m); })) return;
    std::sort(first, last, shorterEdge);
  }
}

void computeSafeRadii(DelaunayGraph& g) {
  const std::size_t n = g.points.size();
  g.safe_radius2.assign(n, 0.f);
  for (std::size_t v = 0; v < n; ++v) {
    float r = INFINITY;
    for (index_t e = g.offsets[v]; e < g.offsets[v + 1]; ++e) r = std::min(r, g.edges[e].m);
    if (!std::isfinite(r)) continue;  // isolated vertex (a one-point graph): no bound, keep 0
    const double r2 = double(r) * double(r) * (1.0 - 1e-5);
    const float f = static_cast<float>(r2);
    // Kept only where float holds it below r^2 (r^2 beyond float's range, from a file's huge edge
    // lengths, would round to inf): the invariant validate() checks.
    if (r2 >= 1e-30 && std::isfinite(f) && double(f) < double(r) * double(r)) g.safe_radius2[v] = f;
  }
}

}  // namespace dw
