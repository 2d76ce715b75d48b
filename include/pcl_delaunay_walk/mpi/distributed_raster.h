/// \file distributed_raster.h
/// \brief TIN-linear rasterisation of the distributed TIN (distributed_tin.h) in row bands, one per rank:
/// every emitted triangle travels, with its vertices, to the ranks whose rows it may touch, and each
/// rank runs dw::dem::rasterizeTinRows on its band. The bands together are bit for bit the raster
/// dw::dem::rasterizeTin makes of the single-process TIN on the same grid (docs/mpi.md, "The DEM"):
/// the triangles are the same gid triples with the same coordinates and values; each is stored with
/// its smallest gid first, which is the rotation the rasteriser interpolates from; and a cell centre's
/// owning triangle is unique and does not depend on triangle order or on the split into row windows
/// (tin_raster.h). GDAL-free; the tools write the bands as tiles (apps/dem_mosaic.h).
#pragma once

#include <mpi.h>

#include <cstddef>
#include <vector>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/mpi/distributed_tin.h"

namespace dw {
namespace mpi {

/// Collective: the box [lo, hi] (frame units) of all ranks' triangle vertices, which are all the
/// distinct input points; false when no rank has a triangle (collinear input).
bool globalFrameBox(MPI_Comm comm, const RankTin& tin, double lo[2], double hi[2]);

/// Rank `rank`'s band of a grid of `rows` rows: [rows * rank / size, rows * (rank + 1) / size), empty
/// for some ranks when the grid has fewer rows than there are ranks.
void rowBand(std::size_t rows, int rank, int size, std::size_t& begin, std::size_t& end);

struct RasterBand {
  std::size_t row_begin = 0, row_end = 0;  ///< this rank's rows (rowBand)
  std::vector<double> values;              ///< (row_end - row_begin) * grid.cols cells, row by row
  dem::TinRasterStats stats;               ///< summed over all ranks
  std::size_t triangles = 0;  ///< triangles this rank rasterised (some also in a neighbour's band)
};

/// Collective: this rank's band of `grid` (in the triangulation frame, like tin.coords), the value of
/// each vertex being tin.coords.z (world z, or what DistributedTinOptions::value put there). Triangles
/// with an edge longer than options.max_edge are dropped before they travel and counted once.
RasterBand rasterizeBands(MPI_Comm comm, const RankTin& tin, const dem::RasterGrid& grid,
                          const dem::TinRasterOptions& options);

}  // namespace mpi
}  // namespace dw
