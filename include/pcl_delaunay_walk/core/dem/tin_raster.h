/// \file tin_raster.h
/// \brief TIN-linear rasterisation: the value of every cell centre interpolated linearly inside the
/// triangle of the TIN that contains it (the DEM of las2dem, PDAL's writers.gdal on a Delaunay mesh,
/// gdal_grid -a linear). Cells outside the convex hull, and cells under a triangle with an (x, y) edge
/// longer than `max_edge` (blast2dem's "kill"), stay `nodata`. PCL-free and GDAL-free.
///
/// Which triangle a centre belongs to is decided exactly: p is inside triangle (a, b, c) (counter-
/// clockwise) when it is strictly left of every edge, or on an edge u -> v that the fixed infinitesimal
/// shift p + (e, e^2) puts on the inside (v.y < u.y, or v.y == u.y and v.x > u.x), all signs by the
/// exact orient2d. A shifted point lies in exactly one triangle of a triangulation whose union
/// contains it, so each centre on a shared edge or vertex is owned by one triangle: the cells are
/// written by one triangle each (the parallel loop needs no locks) and the raster does not depend on
/// the triangles' order, the thread count, or how the rows are split into windows.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace dem {

struct TinRasterOptions {
  /// Triangles with an (x, y) edge longer than this (in the grid's units) leave their cells nodata;
  /// 0: no limit.
  double max_edge = 0;
  double nodata = -9999;
  unsigned num_threads = 0;  ///< 0: hardware concurrency; the raster does not depend on it
  /// Optional: fraction of the triangles done, from the calling thread only.
  std::function<void(double fraction)> progress;
};

struct TinRasterStats {
  std::size_t cells_set = 0;         ///< cells given a value
  std::size_t triangles_killed = 0;  ///< triangles skipped for an edge longer than max_edge
};

/// The points (x[i], y[i]) with values value[i], i < n, in the grid's units; `triangles` holds
/// counter-clockwise index triples (dw::tin::TinResult::triangles). Writes rows [row_begin, row_end)
/// of the grid into out[(r - row_begin) * grid.cols + c], which must have room for them; cells no
/// triangle owns are set to options.nodata. Throws dw::Error on an index >= n or a bad row range.
TinRasterStats rasterizeTinRows(const double* x, const double* y, const double* value, std::size_t n,
                                const index_t* triangles, std::size_t num_indices, const RasterGrid& grid,
                                std::size_t row_begin, std::size_t row_end, double* out,
                                const TinRasterOptions& options = {});

/// The whole grid, row by row (grid.rows * grid.cols values).
std::vector<double> rasterizeTin(const double* x, const double* y, const double* value, std::size_t n,
                                 const std::vector<index_t>& triangles, const RasterGrid& grid,
                                 const TinRasterOptions& options = {}, TinRasterStats* stats = nullptr);

}  // namespace dem
}  // namespace dw
