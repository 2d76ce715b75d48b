/// \file neighbour_search.h
/// \brief The core search engine over a DelaunayGraph: start location + walk for NN, best-first expansion
/// from the NN for exact kNN and radius search (docs/architecture.md, "Why the searches are exact").
/// Thread-safe for concurrent queries; results are input indices (duplicates expanded), sorted by distance.
#pragma once

#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/search/kd_ann.h"
#include "pcl_delaunay_walk/core/search/start_strategy.h"
#include "pcl_delaunay_walk/core/search/walk.h"

namespace dw {

/// One vertex of a kNN answer: every input collapsed onto it lies at squared distance dist2.
struct VertexNeighbour {
  index_t vertex;
  index_t inputs;  ///< how many inputs share the vertex
  float dist2;
};

class NeighbourSearch {
 public:
  using Ptr = std::shared_ptr<NeighbourSearch>;
  using ConstPtr = std::shared_ptr<const NeighbourSearch>;

  /// Takes shared ownership of the graph and builds the start locators (Zero vertex, KD-ANN tree).
  explicit NeighbourSearch(DelaunayGraph::ConstPtr graph);

  const DelaunayGraph& graph() const { return *graph_; }
  const DelaunayGraph::ConstPtr& graphPtr() const { return graph_; }

  /// Start vertex for q under strategy s; `hint` is a vertex (kInvalidIndex for none). Out-of-range
  /// hints are treated as none.
  index_t startVertex(const Vec3f& q, StartStrategy s, index_t hint = kInvalidIndex) const;

  /// Exact nearest vertex of q.
  WalkResult nearest(const Vec3f& q, StartStrategy s = StartStrategy::KdAnn,
                     index_t hint = kInvalidIndex) const {
    return walk(*graph_, q, startVertex(q, s, hint));
  }

  /// Exact k nearest input points of q (min(k, #finite inputs) results), ascending distance.
  /// `nn` is q's nearest vertex (from nearest()). Returns the number found.
  std::size_t knn(const Vec3f& q, std::size_t k, const WalkResult& nn, std::vector<index_t>& indices,
                  std::vector<float>& dist2) const;

  /// The same answer as knn() by vertex: the fewest nearest vertices that hold k inputs (all vertices
  /// if fewer), ascending (distance, vertex). Returns the inputs they hold (>= k unless all are in).
  /// For callers that read per-vertex data next to the graph's own order.
  std::size_t knnVertices(const Vec3f& q, std::size_t k, const WalkResult& nn,
                          std::vector<VertexNeighbour>& out) const;

  /// radius() (no limit) by vertex: every vertex within squared distance radius2, ascending (distance,
  /// vertex). Returns the inputs they hold.
  std::size_t radiusVertices(const Vec3f& q, float radius2, const WalkResult& nn,
                             std::vector<VertexNeighbour>& out) const;

  /// Every input point with squared distance <= radius2, ascending, at most max_nn (0: no limit).
  std::size_t radius(const Vec3f& q, float radius2, const WalkResult& nn, std::vector<index_t>& indices,
                     std::vector<float>& dist2, std::size_t max_nn = 0) const;

  index_t zeroVertex() const { return zero_vertex_; }

  /// Hints the cache to fetch what a walk starting at vertex v reads first (its position and the
  /// head of its edge records). Query loops call it a few queries ahead: with ICP's source order the
  /// start vertex is a cache miss on nearly every query (measured ~30% of walk time on the dragon).
  void prefetchStart(index_t v) const {
    const DelaunayGraph& g = *graph_;
    if (v >= g.points.size()) return;
    __builtin_prefetch(&g.points[v]);
    if (!g.safe_radius2.empty()) __builtin_prefetch(&g.safe_radius2[v]);
    const EdgeRecord* e = g.edges.data() + g.offsets[v];
    __builtin_prefetch(e);
    __builtin_prefetch(reinterpret_cast<const char*>(e) + 64);
    __builtin_prefetch(reinterpret_cast<const char*>(e) + 128);
  }

 private:
  DelaunayGraph::ConstPtr graph_;
  KdAnnLocator kd_ann_;
  index_t zero_vertex_ = kInvalidIndex;
};

}  // namespace dw
