/// \file block_parallel_builder.h
/// \brief Block-parallel 3D Delaunay edges: the map step of the strip idea (Song, Li, Liu)
/// in 3D, with halos certified instead of a merge (in 3D a flip-based merge can get stuck).
///
/// Blocks are ranges of vertex ids, which are in Morton order, hence spatially compact. Each block
/// triangulates its points plus a halo (the grid cells around its own cells) with its own
/// incremental kernel, using the GLOBAL ids in the symbolic perturbation, so all blocks triangulate
/// the same perturbed point set and agree at seams. A tetrahedron is certified when its circumsphere
/// (with a rounding margin) lies within the cells the block holds completely: every point of that
/// ball is present, so it is a tetrahedron of the global triangulation. Tetrahedra around the block's
/// own vertices that are not certified make the halo grow (the cells under their circumspheres)
/// until all are. Infinite tetrahedra are settled once: the points on the global hull boundary are a
/// subset of the blocks' local hull boundaries, so one small sequential triangulation of those gives
/// the global hull, whose boundary points every block then inserts; a block's hull is then the global
/// one. A block finally reports the edges whose smaller endpoint it owns, so the union is exactly the
/// sequential builder's edge set, for any number of blocks.
#pragma once

#include <functional>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"

namespace dw {
namespace builder3d {

/// Statistics of one parallel build (for benchmarks and docs).
struct BlockBuildStats {
  std::size_t blocks = 0;
  std::size_t halo_points = 0;    ///< points inserted beyond the blocks' own, summed over blocks
  std::size_t hull_points = 0;    ///< points on the global hull boundary
  std::size_t growth_rounds = 0;  ///< largest number of halo growth rounds of a block
};

/// Delaunay edges of distinct points (ids in Morton order for good blocks) built by `num_blocks`
/// blocks on as many threads. num_blocks <= 1 runs the sequential kernel. Throws dw::Error on inputs
/// the kernel rejects (coplanar, duplicates).
EdgeList blockParallelDelaunayEdges(const std::vector<Vec3f>& points, unsigned num_blocks,
                                    BlockBuildStats* stats = nullptr);

}  // namespace builder3d
}  // namespace dw
