#include "pcl_delaunay_walk/core/search/neighbour_search.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

bool before(const SearchCandidate& a, const SearchCandidate& b) {
  return a.d2 < b.d2 || (a.d2 == b.d2 && a.v < b.v);
}

/// How far along v's neighbourhood (shortest edge first) a neighbour can still lie within squared
/// distance bound_d2 of q, for v at distance dv: |q - x_j| >= |x_j - x_v| - dv = 2 m_vj - dv, so once
/// 2 m_vj - dv exceeds sqrt(bound_d2), neither that neighbour nor any after it (longer edges) can.
/// The stored m carries a few float ulps of rounding; 1e-5 relative covers it and the float rounding
/// of the returned half-length many times over.
float edgeReach(double bound_d2, double dv) {
  return static_cast<float>((std::sqrt(bound_d2) + dv) * (1.0 / (2.0 * (1.0 - 1e-5))));
}

/// Starts loading a vertex's edge records, which an expansion reads soon after the vertex is listed.
/// The records (36 MB on a 125k-point KITTI frame) do not stay in L2, and the chain record -> mark ->
/// position gives the core little to overlap: this was 20 % of a self-kNN query (k = 16, KITTI).
/// A neighbourhood of ~15 edges spans 5 lines; the first four are fetched.
inline void prefetchRecords(const EdgeRecord* first) {
  const char* r = reinterpret_cast<const char*>(first);
  __builtin_prefetch(r);
  __builtin_prefetch(r + 64);
  __builtin_prefetch(r + 128);
  __builtin_prefetch(r + 192);
}

/// The vertices nearest q as a bounded best-first list (s.list, ascending (d2, v)): the shortest
/// prefix of the order that holds k inputs, every vertex no farther than stop_above (inclusive).
///
/// Exact (docs/architecture.md, "Why the searches are exact"): every vertex that is not the nearest
/// has a strictly nearer Delaunay neighbour, so each of the k nearest is a neighbour of a nearer one,
/// and it is enough to expand (measure the neighbours of) the vertices that end in the list. A vertex
/// leaves the list, or is refused, only when k inputs lie before it in (d2, v) order, and then it is
/// not among the k nearest; the list's last distance only falls, so neither the refusal nor the edge
/// cut of edgeReach() (a neighbour beyond that distance) is ever undone. The list is expanded nearest
/// unexpanded first, which tightens its bound soonest: what a frontier heap does, without the heap.
void nearestVertices(const DelaunayGraph& g, const Vec3f& q, index_t start, std::size_t k, double stop_above,
                     SearchScratch& s) {
  const std::size_t n = g.points.size();
  s.begin(n);
  // The list never holds more than k + 1 entries (one insert, then the trim), nor more than n.
  s.list.resize(std::min(k, n) + 1);
  SearchCandidate* const list = s.list.data();
  std::uint32_t* const stamp = s.stamp.data();
  const std::uint32_t epoch = s.epoch;
  const Vec3f* const pts = g.points.data();
  const EdgeRecord* const edges = g.edges.data();
  const index_t* const offsets = g.offsets.data();
  const index_t* const inputs = g.originals_offsets.data();
  std::size_t size = 0;
  stamp[start] = epoch;
  const double d0 = squaredDistanceD(q, pts[start]);
  if (d0 <= stop_above) list[size++] = {d0, start, inputs[start + 1] - inputs[start]};
  std::size_t total = size ? list[0].inputs() : 0;  // inputs held by the list
  // A new vertex is taken if it comes before (bound_d2, bound_v) in (d2, v) order: the last entry
  // once the list holds k inputs, stop_above (inclusive) before.
  double bound_d2 = stop_above;
  index_t bound_v = kInvalidIndex;
  if (total >= k) bound_d2 = list[0].d2, bound_v = list[0].v;
  std::size_t open = 0;  // every entry before `open` is expanded
  while (open < size) {
    if (list[open].expanded()) {
      ++open;
      continue;
    }
    list[open].count |= SearchCandidate::kExpanded;
    const index_t v = list[open].v;
    const double dv = std::sqrt(list[open].d2);
    ++open;
    float reach = edgeReach(bound_d2, dv);
    const EdgeRecord* const end = edges + offsets[v + 1];
    for (const EdgeRecord* e = edges + offsets[v]; e != end && !(e->m > reach); ++e) {
      const index_t j = e->j;
      if (stamp[j] == epoch) continue;
      stamp[j] = epoch;
      const double d2 = squaredDistanceD(q, pts[j]);
      if (!(d2 < bound_d2 || (d2 == bound_d2 && j < bound_v))) continue;
      // Insert in order, then drop the tail that k inputs before it make unnecessary.
      const index_t count = inputs[j + 1] - inputs[j];
      prefetchRecords(edges + offsets[j]);
      std::size_t p = size++;
      for (; p > 0 && (d2 < list[p - 1].d2 || (d2 == list[p - 1].d2 && j < list[p - 1].v)); --p)
        list[p] = list[p - 1];
      list[p] = {d2, j, count};
      total += count;
      while (total - list[size - 1].inputs() >= k) total -= list[--size].inputs();
      open = std::min(open, p);
      if (total >= k) {
        bound_d2 = list[size - 1].d2, bound_v = list[size - 1].v;
        reach = edgeReach(bound_d2, dv);
      }
    }
  }
  s.list.resize(size);
}

/// Every vertex within squared distance r2 of q (inclusive) into s.list, in the order found, from q's
/// nearest vertex `start`: each vertex inside the ball has a strictly nearer Delaunay neighbour, which
/// is inside too, so expanding only the vertices inside finds them all. Each list entry is expanded in
/// turn, so the list is its own queue.
void verticesWithin(const DelaunayGraph& g, const Vec3f& q, index_t start, double r2, SearchScratch& s) {
  s.begin(g.points.size());
  auto& list = s.list;
  std::uint32_t* const stamp = s.stamp.data();
  const std::uint32_t epoch = s.epoch;
  const Vec3f* const pts = g.points.data();
  const EdgeRecord* const edges = g.edges.data();
  const index_t* const offsets = g.offsets.data();
  const index_t* const inputs = g.originals_offsets.data();
  stamp[start] = epoch;
  const double d0 = squaredDistanceD(q, pts[start]);
  if (!(d0 <= r2)) return;
  list.push_back({d0, start, inputs[start + 1] - inputs[start]});
  for (std::size_t i = 0; i < list.size(); ++i) {
    const index_t v = list[i].v;
    const float reach = edgeReach(r2, std::sqrt(list[i].d2));
    const EdgeRecord* const end = edges + offsets[v + 1];
    for (const EdgeRecord* e = edges + offsets[v]; e != end && !(e->m > reach); ++e) {
      const index_t j = e->j;
      if (stamp[j] == epoch) continue;
      stamp[j] = epoch;
      const double d2 = squaredDistanceD(q, pts[j]);
      if (d2 <= r2) {
        list.push_back({d2, j, inputs[j + 1] - inputs[j]});
        prefetchRecords(edges + offsets[j]);
      }
    }
  }
  std::sort(list.begin(), list.end(), before);
}

/// Appends the inputs of the listed vertices in list order, at most `limit`: a vertex stands for all
/// its collapsed duplicates, each one result at the same distance.
template <typename List>
void emit(const DelaunayGraph& g, const List& list, std::size_t limit, std::vector<index_t>& indices,
          std::vector<float>& dist2) {
  std::size_t n = 0;
  for (const SearchCandidate& c : list) n += c.inputs();
  n = std::min(n, limit);
  indices.resize(n);
  dist2.resize(n);
  std::size_t i = 0;
  for (auto c = list.begin(); i < n; ++c)
    for (index_t o = g.originals_offsets[c->v]; o < g.originals_offsets[c->v + 1] && i < n; ++o, ++i)
      indices[i] = g.originals[o], dist2[i] = static_cast<float>(c->d2);
}

bool validStart(const DelaunayGraph& g, const WalkResult& nn) {
  return nn.vertex != kInvalidIndex && nn.vertex < g.points.size();
}

}  // namespace

std::size_t NeighbourSearch::knn(const Vec3f& q, std::size_t k, const WalkResult& nn,
                                 std::vector<index_t>& indices, std::vector<float>& dist2) const {
  indices.clear();
  dist2.clear();
  const DelaunayGraph& g = *graph_;
  if (k == 0 || !validStart(g, nn)) return 0;
  SearchScratch& s = SearchScratch::threadLocal();
  nearestVertices(g, q, nn.vertex, k, std::numeric_limits<double>::infinity(), s);
  emit(g, s.list, k, indices, dist2);
  return indices.size();
}

std::size_t NeighbourSearch::knnVertices(const Vec3f& q, std::size_t k, const WalkResult& nn,
                                         std::vector<VertexNeighbour>& out) const {
  out.clear();
  const DelaunayGraph& g = *graph_;
  if (k == 0 || !validStart(g, nn)) return 0;
  SearchScratch& s = SearchScratch::threadLocal();
  nearestVertices(g, q, nn.vertex, k, std::numeric_limits<double>::infinity(), s);
  std::size_t inputs = 0;
  for (const SearchCandidate& c : s.list) {
    out.push_back({c.v, c.inputs(), static_cast<float>(c.d2)});
    inputs += c.inputs();
  }
  return inputs;
}

std::size_t NeighbourSearch::radiusVertices(const Vec3f& q, float radius2, const WalkResult& nn,
                                            std::vector<VertexNeighbour>& out) const {
  out.clear();
  const DelaunayGraph& g = *graph_;
  if (!(radius2 >= 0.f) || !validStart(g, nn)) return 0;
  SearchScratch& s = SearchScratch::threadLocal();
  verticesWithin(g, q, nn.vertex, radius2, s);
  std::size_t inputs = 0;
  for (const SearchCandidate& c : s.list) {
    out.push_back({c.v, c.inputs(), static_cast<float>(c.d2)});
    inputs += c.inputs();
  }
  return inputs;
}

std::size_t NeighbourSearch::radius(const Vec3f& q, float radius2, const WalkResult& nn,
                                    std::vector<index_t>& indices, std::vector<float>& dist2,
                                    std::size_t max_nn) const {
  indices.clear();
  dist2.clear();
  const DelaunayGraph& g = *graph_;
  if (!(radius2 >= 0.f) || !validStart(g, nn)) return 0;
  SearchScratch& s = SearchScratch::threadLocal();
  // With a limit the nearest max_nn inside are wanted: the bounded list stops expanding at them.
  if (max_nn == 0)
    verticesWithin(g, q, nn.vertex, radius2, s);
  else
    nearestVertices(g, q, nn.vertex, max_nn, radius2, s);
  emit(g, s.list, max_nn == 0 ? std::numeric_limits<std::size_t>::max() : max_nn, indices, dist2);
  return indices.size();
}

}  // namespace dw
