/// \file distributed_tin.h
/// \brief MPI driver of the distributed 2D Delaunay TIN: every rank reads its own range of the records of
/// a LAS file or of a pre-split set of LAS files (las_input_set.h), points are redistributed into equal-count
/// strips along the long axis (sampled splitters, MPI_Alltoallv), each rank triangulates its strip and emits
/// what is provably final, and the rest is merged up a log-depth tree of rank pairs (strip_group.h). The
/// union of all ranks' emitted triangles is exactly the single-process dw::tin::triangulate result on the
/// same input (docs/mpi.md).
#pragma once

#include <mpi.h>

#include <functional>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/mpi/las_input_set.h"
#include "pcl_delaunay_walk/mpi/strip_group.h"

namespace dw {
namespace mpi {

struct DistributedTinOptions {
  /// LAS files (uncompressed): one file or a pre-split set, taken as one sequence of records in this
  /// order; every rank reads only its own range of that sequence.
  std::vector<std::string> inputs;
  int classification = -1;        ///< keep only this class; -1: all (global indices count kept points)
  unsigned num_threads = 1;       ///< threads per rank for the local triangulations
  std::uint64_t max_records = 0;  ///< use only the first max_records records (0: all); for weak scaling
  /// What each point carries as its z (never used by the triangulation, which sees x and y only): the
  /// world z, or the LAS intensity (for a raster of intensities; the pieces then hold it as z).
  bool intensity_as_z = false;
  /// Progress lines (called on rank 0 only).
  std::function<void(const std::string&)> progress;
  /// Testing hook: fail or die on one rank at one stage ("read", "leaf", "merge", "write"): "fail:STAGE:RANK"
  /// or "kill:STAGE:RANK" (the apps' --inject); empty: none.
  std::string inject_fault;
};

struct RankTimings {
  double read_s = 0, exchange_s = 0, leaf_s = 0, merge_s = 0, write_s = 0;
};

/// What one rank holds after the run.
struct RankTin {
  int rank = 0, size = 1;
  Frame frame;
  std::uint64_t total_points = 0;  ///< kept records over all ranks (global indices 0 .. total - 1)
  std::size_t strip_points = 0;    ///< points this rank triangulated at its leaf
  Emitted emitted;                 ///< triangles this rank emitted (leaf and the merges it hosted)
  StripPoints coords;  ///< frame x, y and world z of every vertex this rank's triangles use (by gid)
  RankTimings timings;
  /// Testing hook forwarded from the options.
};

/// Runs the whole distributed triangulation on `comm` (collective). Throws dw::Error on bad input or an
/// internal failure on this rank; callers should then MPI_Abort, as the other ranks may be waiting.
RankTin triangulateDistributed(MPI_Comm comm, const DistributedTinOptions& options);

/// Writes this rank's piece: a binary PLY with world x, y, z (double) and the global index (uint) per
/// vertex and its emitted triangles (collective only through the caller). Returns the vertex count.
std::uint64_t writePiece(const std::string& path, const RankTin& tin);

/// Collective: every rank writes `prefix.rank<r>.ply`; after all succeeded, rank 0 writes
/// `prefix.manifest.json` (last, atomically by rename), the only file that claims completeness.
void writePiecesAndManifest(MPI_Comm comm, const std::string& prefix, const RankTin& tin,
                            const DistributedTinOptions& options);

/// Collective: rank 0 gathers every triangle and vertex and writes one PLY (vertices: the points some
/// triangle uses, in global-index order). Rank 0 needs memory for the whole mesh.
void writeGathered(MPI_Comm comm, const std::string& path, const RankTin& tin,
                   const DistributedTinOptions& options);

/// Collective: rank 0 gathers all triangles (gid triples); other ranks get an empty vector.
std::vector<index_t> gatherTriangles(MPI_Comm comm, const RankTin& tin);

}  // namespace mpi
}  // namespace dw
