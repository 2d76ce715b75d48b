/// \file owned_cells.h
/// \brief TIN-linear rasterisation of a subset of the triangles that also records which cells they own
/// (internal; the streaming DEM's raster, docs/dem.md "Beyond memory"). Same ownership rule, rotation
/// and arithmetic as rasterizeTinRows, so a cell gets bit for bit the value the whole-grid call gives.
#pragma once

#include <cstddef>

#include "pcl_delaunay_walk/core/dem/tin_raster.h"

namespace dw {
namespace dem {

/// For every cell of rows [row_begin, row_end) whose centre one of the triangles owns: sets
/// owned[(r - row_begin) * grid.cols + c] = 1 and writes the value into out[...] (the same index),
/// unless the triangle has an edge longer than max_edge (> 0), which leaves out[...] as it was.
/// Cells no given triangle owns are not touched. The triangles must be of one triangulation (each cell
/// has one owner): blocks of them run on `threads` threads (0: all cores) without locks.
TinRasterStats rasterizeOwnedCells(const double* x, const double* y, const double* value, std::size_t n,
                                   const index_t* triangles, std::size_t num_indices, const RasterGrid& grid,
                                   std::size_t row_begin, std::size_t row_end, double* out,
                                   unsigned char* owned, double max_edge, unsigned threads = 1);

}  // namespace dem
}  // namespace dw
