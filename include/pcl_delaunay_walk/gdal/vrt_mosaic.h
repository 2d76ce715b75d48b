/// \file vrt_mosaic.h
/// \brief A GDAL VRT (virtual raster, XML) that puts row bands of one raster grid, each a GeoTIFF of
/// the grid's full width, together into the whole grid: the mosaic of the MPI ranks' DEM tiles
/// (docs/dem.md, "Tiles and a VRT mosaic"). Each band is a SimpleSource copied cell for cell into its
/// rows, so reading the mosaic gives exactly the bands' values; the bands must not overlap, and rows no
/// band covers read as nodata.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"

namespace dw {
namespace gdal {

/// One band of rows [row_begin, row_begin + rows) of the grid, stored in the raster `path`, relative
/// to the VRT's folder (so the VRT and its tiles can move together).
struct VrtBand {
  std::string path;
  std::size_t row_begin = 0, rows = 0;
};

/// The XML of the mosaic: size, geotransform (west, cell, 0, north, 0, -cell, digits enough to read
/// back the same doubles), options' CRS (srs_wkt), nodata and cell type (Float32, or Float64). Throws
/// RasterError when a band leaves the grid, is empty, or overlaps another, or the CRS is unreadable.
std::string vrtMosaicXml(const dem::RasterGrid& grid, const std::vector<VrtBand>& bands,
                         const GeoTiffOptions& options);

/// Writes vrtMosaicXml(...) to `path` through a temporary renamed over it when complete
/// (dw::SafeOutputFile): a failure leaves an existing file as it was.
void writeVrtMosaic(const std::string& path, const dem::RasterGrid& grid, const std::vector<VrtBand>& bands,
                    const GeoTiffOptions& options);

}  // namespace gdal
}  // namespace dw
