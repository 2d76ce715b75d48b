#include "pcl_delaunay_walk/core/search/neighbour_search.h"

#include <algorithm>
#include <functional>

#include "pcl_delaunay_walk/core/search/search_scratch.h"

namespace dw {

NeighbourSearch::NeighbourSearch(DelaunayGraph::ConstPtr graph) : graph_(std::move(graph)) {
  if (!graph_) throw Error("pcl_delaunay_walk: NeighbourSearch needs a graph");
  const auto& pts = graph_->points;
  if (pts.empty()) return;
  kd_ann_ = KdAnnLocator(pts);
  // Zero start: the vertex nearest the centroid, a fixed and central place to begin.
  double c[3] = {0, 0, 0};
  for (const Vec3f& p : pts) {
    c[0] += p.x;
    c[1] += p.y;
    c[2] += p.z;
  }
  const Vec3f centroid{float(c[0] / pts.size()), float(c[1] / pts.size()), float(c[2] / pts.size())};
  zero_vertex_ = walk(*graph_, centroid, kd_ann_.locate(centroid, pts)).vertex;
}

index_t NeighbourSearch::startVertex(const Vec3f& q, StartStrategy s, index_t hint) const {
  const std::size_t n = graph_->points.size();
  if (n == 0) return kInvalidIndex;
  const bool have_hint = hint < n;
  switch (s) {
    case StartStrategy::Zero: return zero_vertex_;
    case StartStrategy::KdAnn: return kd_ann_.locate(q, graph_->points);
    case StartStrategy::Pnn: return have_hint ? hint : zero_vertex_;
    case StartStrategy::PnnOptimized: return have_hint ? hint : kd_ann_.locate(q, graph_->points);
  }
  return zero_vertex_;
}

namespace {

/// Best-first expansion over the graph from the nearest vertex (docs/architecture.md, "Why the searches are
/// exact"): the i-th nearest vertex is a Delaunay neighbour of one of the first i-1, so popping a min-heap of
/// the frontier yields the vertices in exact distance order. `take` receives (vertex, dist2) and returns
/// false to stop.
template <typename Take>
void expand(const DelaunayGraph& g, const Vec3f& q, const WalkResult& nn, double stop_above, Take take) {
  if (nn.vertex == kInvalidIndex || nn.vertex >= g.points.size()) return;
  SearchScratch& s = SearchScratch::threadLocal();
  s.begin(g.points.size());
  auto& heap = s.heap;
  const auto cmp = std::greater<std::pair<double, index_t>>();
  s.visit(nn.vertex);
  heap.emplace_back(squaredDistanceD(q, g.points[nn.vertex]), nn.vertex);
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), cmp);
    const auto [d2, v] = heap.back();
    heap.pop_back();
    if (d2 > stop_above) return;
    if (!take(v, static_cast<float>(d2))) return;
    for (index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const index_t j = g.edges[k].j;
      if (!s.visit(j)) continue;
      heap.emplace_back(squaredDistanceD(q, g.points[j]), j);
      std::push_heap(heap.begin(), heap.end(), cmp);
    }
  }
}

}  // namespace

std::size_t NeighbourSearch::knn(const Vec3f& q, std::size_t k, const WalkResult& nn,
                                 std::vector<index_t>& indices, std::vector<float>& dist2) const {
  indices.clear();
  dist2.clear();
  if (k == 0) return 0;
  const DelaunayGraph& g = *graph_;
  expand(g, q, nn, std::numeric_limits<float>::infinity(), [&](index_t v, float d2) {
    // A vertex stands for all its collapsed duplicates: each is one result at the same distance.
    for (index_t o = g.originals_offsets[v]; o < g.originals_offsets[v + 1] && indices.size() < k; ++o) {
      indices.push_back(g.originals[o]);
      dist2.push_back(d2);
    }
    return indices.size() < k;
  });
  return indices.size();
}

std::size_t NeighbourSearch::radius(const Vec3f& q, float radius2, const WalkResult& nn,
                                    std::vector<index_t>& indices, std::vector<float>& dist2,
                                    std::size_t max_nn) const {
  indices.clear();
  dist2.clear();
  if (!(radius2 >= 0.f)) return 0;
  const DelaunayGraph& g = *graph_;
  const std::size_t limit = max_nn == 0 ? std::numeric_limits<std::size_t>::max() : max_nn;
  expand(g, q, nn, radius2, [&](index_t v, float d2) {
    for (index_t o = g.originals_offsets[v]; o < g.originals_offsets[v + 1] && indices.size() < limit; ++o) {
      indices.push_back(g.originals[o]);
      dist2.push_back(d2);
    }
    return indices.size() < limit;
  });
  return indices.size();
}

}  // namespace dw
