/// \file raster_grid.h
/// \brief The north-up grid of square cells a DEM is sampled on, and its conventions (docs/dem.md,
/// "Conventions"): row 0 is the northern row, column 0 the western column; cell (r, c) covers
/// [west + c s, west + (c + 1) s] x [north - (r + 1) s, north - r s] and takes the value at its centre.
/// This is the GeoTIFF geotransform (west, s, 0, north, 0, -s) and gdal_grid's convention for
/// `-txe west east -tye north south -outsize cols rows`.
#pragma once

#include <cstddef>

namespace dw {
namespace dem {

struct RasterGrid {
  double west = 0, north = 0;  ///< the outer edges of the first column and the first row
  double cell = 1;             ///< cell size (> 0), in the units of west and north
  std::size_t cols = 0, rows = 0;

  double east() const { return west + double(cols) * cell; }
  double south() const { return north - double(rows) * cell; }
  /// Cell centres. Every user of the grid computes them with these two functions, so a cell is sampled
  /// at bit-for-bit the same point by the in-memory and the streamed rasters.
  double centreX(std::size_t c) const { return west + (double(c) + 0.5) * cell; }
  double centreY(std::size_t r) const { return north - (double(r) + 0.5) * cell; }
  std::size_t size() const { return cols * rows; }
};

/// The grid of `cell`-sized cells covering [xmin, xmax] x [ymin, ymax] with its west and north edges
/// at xmin and ymax: cols = ceil((xmax - xmin) / cell), at least 1 (rows likewise). Throws dw::Error
/// when a value is not finite, cell <= 0, the box is empty or the grid exceeds 2^31 cells a side.
RasterGrid gridFromBounds(double xmin, double ymin, double xmax, double ymax, double cell);

/// The same, with the edges moved out to multiples of `cell` (so that tiles of one survey line up):
/// west = floor(xmin / cell) cell, north = ceil(ymax / cell) cell.
RasterGrid alignedGridCovering(double xmin, double ymin, double xmax, double ymax, double cell);

}  // namespace dem
}  // namespace dw
