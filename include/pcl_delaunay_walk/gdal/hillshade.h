/// \file hillshade.h
/// \brief A hillshade preview of a DEM, computed by GDAL's DEMProcessing (what `gdaldem hillshade`
/// computes: sun azimuth 315 degrees, altitude 45 degrees, edges computed) and written as an 8-bit PNG
/// (0 where the DEM has no data), under a temporary name and renamed when complete.
#pragma once

#include <string>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"

namespace dw {
namespace gdal {

/// `values`: grid.size() cells, row by row, `nodata` where undefined. `z_factor` scales heights to the
/// horizontal units. Throws dw::gdal::RasterError, leaving an existing `path` untouched, on failure.
void writeHillshadePng(const std::string& path, const dem::RasterGrid& grid, const double* values,
                       double nodata, double z_factor = 1.0);

}  // namespace gdal
}  // namespace dw
