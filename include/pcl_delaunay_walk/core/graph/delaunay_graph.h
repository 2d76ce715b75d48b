/// \file delaunay_graph.h
/// \brief The walk graph: Delaunay neighbourhoods of the reference cloud in CSR form
/// (docs/architecture.md, "The walk graph").
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/graph/edge_records.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

/// The Delaunay graph of a reference cloud, laid out for the walk.
///
/// Invariants (checked by validate()):
///  - points[v] is vertex v relative to origin; vertices are the distinct finite input points in a
///    space-filling-curve order, so graph neighbours are mostly near in memory;
///  - the neighbours of v are edges[offsets[v] .. offsets[v+1]), each edge stored in both directions,
///    shortest first (ascending m, ties by ascending j): a walk reads a neighbourhood only up to the
///    first edge that cannot be a move (see edge_scan.h);
///  - input_to_vertex[i] is the vertex of input point i, or kInvalidIndex for a skipped (NaN/Inf) one;
///  - originals[originals_offsets[v] .. originals_offsets[v+1]) are the input indices that collapsed
///    onto vertex v (duplicates), ascending; the first is v's representative;
///  - safe_radius2[v] (empty or one per vertex) is the squared radius of a ball around points[v] that
///    lies inside v's Voronoi cell (see computeSafeRadii()).
/// An edge set that contains every Delaunay edge makes the walk exact; extra edges cost only speed.
struct DelaunayGraph {
  using Ptr = std::shared_ptr<DelaunayGraph>;
  using ConstPtr = std::shared_ptr<const DelaunayGraph>;

  std::array<double, 3> origin{{0.0, 0.0, 0.0}};
  /// Affine dimension of the vertex set: 0 (one point), 1 (collinear), 2 (coplanar) or 3.
  int dimension = 0;
  std::vector<Vec3f> points;
  std::vector<index_t> offsets{0};
  /// All directed edges, vertex by vertex (offsets): owned, or (loadGraph) a view of the mapped file,
  /// which is most of a graph's bytes (20 per directed edge, against 28 per vertex for the rest).
  EdgeRecords edges;
  std::vector<index_t> input_to_vertex;
  std::vector<index_t> originals_offsets{0};
  std::vector<index_t> originals;
  /// Per vertex: a query q with |q - x_v|^2 <= safe_radius2[v] has x_v as its exact nearest neighbour,
  /// so the walk stops there without scanning v's edges (the common case late in ICP). Derived data:
  /// filled by assembleEdges() and on load, never saved. Empty disables the test.
  std::vector<float> safe_radius2;

  std::size_t numVertices() const { return points.size(); }
  std::size_t numDirectedEdges() const { return edges.size(); }
  std::size_t numInputPoints() const { return input_to_vertex.size(); }
  std::size_t degree(index_t v) const { return offsets[v + 1] - offsets[v]; }
  index_t representative(index_t v) const { return originals[originals_offsets[v]]; }
  /// True when the edge records are a view of a mapped graph file (loadGraph) rather than a copy.
  bool isMapped() const { return edges.isView(); }

  /// A caller's point in the graph's local frame (subtract in double, then round once).
  Vec3f toLocal(double x, double y, double z) const {
    return {static_cast<float>(x - origin[0]), static_cast<float>(y - origin[1]),
            static_cast<float>(z - origin[2])};
  }

  /// Throws dw::Error naming the first broken invariant (the same one for any thread count). Cost
  /// O(V + E), on `num_threads` threads (0: hardware concurrency).
  void validate(unsigned num_threads = 1) const;

  /// Bytes held by the arrays (what a saved file holds, roughly).
  std::size_t memoryBytes() const;
};

/// Builds the CSR records from an undirected edge list over `points` (pairs i != j, any order,
/// duplicates allowed). Used by every builder so that the layout is defined in one place.
/// Fills safe_radius2 too. With `distinct` the caller promises that no pair repeats (in either
/// orientation): the list is then not sorted, and a repeat found anyway throws dw::Error. Runs on
/// `num_threads` threads (0: hardware concurrency); the graph is the same for any count.
void assembleEdges(DelaunayGraph& graph, std::vector<std::pair<index_t, index_t>> undirected_edges,
                   bool distinct = false, unsigned num_threads = 1);

/// Puts every neighbourhood in the documented order (shortest edge first), sorting only those that
/// are not: graph files written before this order existed load into the same invariants. O(E) when
/// already sorted. On `num_threads` threads (0: hardware concurrency).
void sortNeighbourhoods(DelaunayGraph& graph, unsigned num_threads = 1);

/// Fills graph.safe_radius2 from the edges. The nearest other vertex of v is always a Delaunay neighbour
/// (the nearest-neighbour graph is a subgraph of the Delaunay graph), at distance 2 r_v with
/// r_v = min_j m_vj; any q with |q - x_v| < r_v is then strictly nearer to x_v than to every x_j, since
/// |q - x_j| >= 2 r_v - |q - x_v| > |q - x_v|. The stored value is r_v^2 shrunk by 1e-5 (relative), far
/// more than the float rounding of m and of the walk's distance; balls too small to hold in float
/// precision (r^2 < 1e-30) are disabled (0). O(E), on `num_threads` threads (0: hardware concurrency).
void computeSafeRadii(DelaunayGraph& graph, unsigned num_threads = 1);

}  // namespace dw
