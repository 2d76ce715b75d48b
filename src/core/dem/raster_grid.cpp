/// \file raster_grid.cpp
/// \brief Grids from bounds.
#include "pcl_delaunay_walk/core/dem/raster_grid.h"

#include <cmath>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace dem {

namespace {
constexpr double kMaxCellsPerSide = 2147483647.0;

std::size_t cellsAcross(double from, double to, double cell, const char* axis) {
  const double n = std::ceil((to - from) / cell);
  if (!(n <= kMaxCellsPerSide))
    throw Error(std::string("raster grid: ") + axis + " extent " + std::to_string(to - from) + " / cell " +
                std::to_string(cell) + " needs more than 2^31 cells");
  return n < 1 ? 1 : std::size_t(n);
}
}  // namespace

RasterGrid gridFromBounds(double xmin, double ymin, double xmax, double ymax, double cell) {
  if (!std::isfinite(xmin) || !std::isfinite(ymin) || !std::isfinite(xmax) || !std::isfinite(ymax))
    throw Error("raster grid: the bounds must be finite");
  if (!(cell > 0) || !std::isfinite(cell))
    throw Error("raster grid: the cell size must be a positive number");
  if (xmax < xmin || ymax < ymin)
    throw Error("raster grid: empty bounds (xmin " + std::to_string(xmin) + " > xmax " +
                std::to_string(xmax) + " or ymin " + std::to_string(ymin) + " > ymax " +
                std::to_string(ymax) + ")");
  RasterGrid g;
  g.west = xmin;
  g.north = ymax;
  g.cell = cell;
  g.cols = cellsAcross(xmin, xmax, cell, "x");
  g.rows = cellsAcross(ymin, ymax, cell, "y");
  return g;
}

RasterGrid alignedGridCovering(double xmin, double ymin, double xmax, double ymax, double cell) {
  if (!(cell > 0) || !std::isfinite(cell))
    throw Error("raster grid: the cell size must be a positive number");
  const double west = std::floor(xmin / cell) * cell, north = std::ceil(ymax / cell) * cell;
  // floor/ceil of the quotient can land one cell inside the box after rounding: step out if so.
  return gridFromBounds(west > xmin ? west - cell : west, ymin, xmax, north < ymax ? north + cell : north,
                        cell);
}

}  // namespace dem
}  // namespace dw
