// dw::incrementalDelaunayEdges: the project's 3D Delaunay graph builder. BRIO order, the
// Bowyer-Watson triangulation, then the edges of the triangulation (extracted on num_threads threads); the
// adjacency is freed before the edges are made so that the peak holds one copy of each.
//
// The block-parallel builder (block_parallel_builder.h) is exact for any number of blocks but is not
// used here yet: measured on the 16-core device machine its halos sometimes grow to most of the cloud
// (slivers on a block's local hull, see docs/builder3d.md), so it was slower than this path on the
// dragon and no faster on 1M uniform points.
#include <algorithm>
#include <cmath>
#include <thread>
#include <utility>

#include "insertion_order.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "triangulation_3d.h"

namespace dw {

// Cross-checked against Qhull (identical edge sets on general-position input) in test/builder3d.
bool haveIncrementalBuilder() {
  return true;
}

EdgeList incrementalDelaunayEdges(const std::vector<Vec3f>& points, const BuildOptions& options) {
  unsigned threads = options.num_threads;
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  for (const Vec3f& p : points)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw Error("dw::incrementalDelaunayEdges: non-finite coordinate in the input");

  // One team of threads for every parallel loop of the job: the order, each parallel pass (about five
  // loops each) and the extraction (parallel_for.h).
  ThreadTeam team(threads);
  ThreadTeam::Scope scope(team);
  builder3d::Triangulation3D::EdgeChunks chunks;
  {
    builder3d::Triangulation3D kernel;
    kernel.setPoints(points.data(), points.size());
    {
      std::function<void(double)> progress;
      if (options.progress) progress = [&](double f) { options.progress("delaunay-3d", f); };
      std::vector<std::size_t> rounds;
      std::vector<index_t> order = builder3d::brioOrder(points, rounds, 0, threads);
      kernel.build(std::move(order), progress, rounds, threads);  // freed before the last round
    }
    chunks = kernel.releaseIntoEdgeChunks(threads);
  }
  return builder3d::Triangulation3D::joinChunks(std::move(chunks));
}

}  // namespace dw
