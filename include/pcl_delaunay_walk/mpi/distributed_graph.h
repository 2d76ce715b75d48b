/// \file distributed_graph.h
/// \brief MPI driver of the 3D Delaunay graph builder: the block-parallel construction of
/// core/builder3d/block_parallel_builder.h with blocks on ranks instead of threads. Every rank reads its
/// own share of the input, the points are sorted along the Morton curve across ranks (so a rank's block
/// is a contiguous range of the single-process vertex ids), and each rank triangulates its block plus a
/// halo that it fetches from the ranks owning the cells its uncertified tetrahedra reach into. The union
/// of the ranks' edges is exactly the graph of dw::buildDelaunayGraph on the same input: same vertices,
/// same ids, same edges, ties included (docs/mpi.md).
#pragma once

#include <mpi.h>

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/mpi/point_input_set.h"

namespace dw {
namespace mpi {

struct DistributedGraphOptions {
  /// Progress lines (called on rank 0 only).
  std::function<void(const std::string&)> progress;
  /// Halo cell size: 2^cell_shift times the edge of cells holding ~4 points of a uniform cloud. Larger
  /// cells mean fewer, fuller cells per ball test (measured faster on both uniform points and the
  /// dragon, whose surface leaves most small cells empty) but a thicker first ring. Only speed depends
  /// on it, never the graph.
  int cell_shift = 1;
  /// Testing hook: fail or die on one rank at one stage ("read", "sort", "block", "grow", "write"):
  /// "fail:STAGE:RANK" or "kill:STAGE:RANK" (the apps' --inject); empty: none.
  std::string inject_fault;
};

struct GraphRankTimings {
  double read_s = 0, sort_s = 0, block_s = 0, hull_s = 0, grow_s = 0, exchange_s = 0;
};

/// What one rank holds after the build: its block of the graph.
struct RankGraph {
  int rank = 0, size = 1;
  std::uint64_t input_points = 0;  ///< points in the input sequence (input indices 0 .. input_points - 1)
  std::uint64_t vertices = 0;      ///< distinct finite points over all ranks
  std::array<double, 3> origin{{0, 0, 0}};
  int dimension = 3;          ///< affine dimension of the vertex set (below 3 only with gathered_fallback)
  index_t first_vertex = 0;   ///< this rank's vertices are first_vertex + [0, points.size())
  std::vector<Vec3f> points;  ///< its vertices, relative to origin
  std::vector<index_t> originals_offsets;  ///< per vertex (local, size points.size() + 1)
  std::vector<index_t> originals;          ///< input indices collapsed onto each vertex, ascending
  EdgeList edges;                          ///< Delaunay edges (a, b), a < b, a one of this rank's vertices
  /// Inputs the block method does not take (fewer than 9 distinct points, coplanar, collinear or nearly
  /// flat sets): rank 0 built the whole graph with dw::buildDelaunayGraph from the gathered input, and
  /// holds it here; the other ranks hold nothing.
  bool gathered_fallback = false;
  DelaunayGraph fallback;
  // Statistics of this rank's block.
  std::size_t halo_points = 0;     ///< points inserted beyond its own vertices
  std::size_t fetched_points = 0;  ///< points received from other ranks
  std::size_t growth_rounds = 0;   ///< local certification passes that inserted points
  std::size_t halo_exchanges = 0;  ///< message rounds that fetched cells from other ranks
  std::size_t hull_points = 0;     ///< global hull vertices (same on every rank)
  std::size_t cells = 0;           ///< grid cells of the halo unit (same on every rank)
  GraphRankTimings timings;
};

/// Collective over `comm`: builds this rank's block of the Delaunay graph of `input`. Throws dw::Error
/// on bad input or an internal failure on this rank; callers should then MPI_Abort (others may wait).
RankGraph buildGraphDistributed(MPI_Comm comm, const PointInputSet& input, const DistributedGraphOptions& o);

/// Collective: rank 0 receives every rank's block and returns the whole DelaunayGraph (the layout of
/// dw::buildDelaunayGraph: CSR edges, input_to_vertex, originals); other ranks return an empty graph.
/// Rank 0 needs memory for the whole graph.
DelaunayGraph gatherGraph(MPI_Comm comm, RankGraph&& part);

/// Writes this rank's block as a piece file (binary; layout in docs/mpi.md) and returns its byte size.
std::uint64_t writeGraphPiece(const std::string& path, const RankGraph& part);

/// Collective: every rank writes `prefix.rank<r>.dwgp`; after all succeeded rank 0 writes
/// `prefix.manifest.json` (last, atomically by rename), the only file that claims completeness.
void writeGraphPiecesAndManifest(MPI_Comm comm, const std::string& prefix, const RankGraph& part,
                                 const std::string& input_name, const DistributedGraphOptions& o);

/// Reads the pieces listed in a manifest and assembles the whole graph (for checks and tools).
DelaunayGraph readGraphPieces(const std::string& manifest);

}  // namespace mpi
}  // namespace dw
