/// \file graph_builder.h
/// \brief Builds a DelaunayGraph from a caller's points: input preparation (NaN skip, duplicate
/// collapse, centring, space-filling-curve order, dimension detection) then a Delaunay edge builder.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/point_view.h"

namespace dw {

enum class BuilderType {
  Auto,         ///< the fastest available exact builder
  Qhull,        ///< Qhull (libqhull_r), the baseline and cross-check
  Incremental,  ///< the project's own incremental Bowyer-Watson 3D kernel (when built)
};

/// Progress callback: a stage name and the fraction done in [0, 1].
using ProgressCallback = std::function<void(const std::string& stage, double fraction)>;

struct BuildOptions {
  BuilderType builder = BuilderType::Auto;
  unsigned num_threads = 0;   ///< 0: hardware concurrency
  ProgressCallback progress;  ///< optional; called from the building thread
};

/// Undirected edge list over prepared vertices.
using EdgeList = std::vector<std::pair<index_t, index_t>>;

/// Builds the walk graph of `points`. NaN/Inf points are skipped (input_to_vertex = kInvalidIndex),
/// duplicates collapse onto one vertex, and any number of points (including 0) or degenerate
/// geometry (coplanar, collinear, cospherical) gives a graph on which walk, kNN and radius search are
/// exact. Throws dw::Error with a clear message when a builder fails.
DelaunayGraph buildDelaunayGraph(const PointView& points, const BuildOptions& options = {});

/// Delaunay edges of distinct points in general dimension `dim` (2 or 3) with Qhull. For dim == 2,
/// `basis` holds two orthonormal in-plane vectors (u then v); points are projected onto them.
/// Throws dw::Error if Qhull is unavailable, fails, or does not return every point as a vertex.
EdgeList qhullDelaunayEdges(const std::vector<Vec3f>& points, int dim, const double basis[6]);

/// Whether this build has the Qhull builder / the incremental builder.
bool haveQhullBuilder();
bool haveIncrementalBuilder();

/// Delaunay edges of distinct points in 3D by the incremental kernel (issue: 3D builder), each edge once.
/// the incremental builder's translation unit; throws dw::Error when that builder is not compiled in.
EdgeList incrementalDelaunayEdges(const std::vector<Vec3f>& points, const BuildOptions& options);

}  // namespace dw
