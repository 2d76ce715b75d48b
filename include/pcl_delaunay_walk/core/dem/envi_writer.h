/// \file envi_writer.h
/// \brief A GDAL-free raster output: one band of raw little-endian Float32 (or Float64) cells, row 0
/// first, plus an ENVI header beside it (`dem.raw` -> `dem.hdr`: the extension replaced). GDAL, QGIS
/// and ENVI read the pair as a georeferenced raster (GDAL's ENVI driver: the "map info" corner and
/// cell size give the geotransform (west, cell, 0, north, 0, -cell), "data ignore value" the nodata,
/// "coordinate system string" the CRS). For machines without GDAL (docs/dem.md, "Scale").
///
/// Rows arrive in order, in any batches (the streaming DEM's row sink). Both files are written through
/// dw::SafeOutputFile: until commit() the targets are untouched; the cells are committed first, then
/// the header, so a header always describes complete cells.
#pragma once

#include <cstddef>
#include <string>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace dem {

struct EnviOptions {
  double nodata = -9999;
  bool float64 = false;     ///< Float64 cells (ENVI data type 5) instead of Float32 (4)
  std::string srs_wkt;      ///< the CRS as WKT ("coordinate system string"); empty: none
  std::string band_name = "z";
};

/// The header's path for a data file: its extension replaced by ".hdr" ("dem" -> "dem.hdr").
std::string enviHeaderPath(const std::string& data_path);

/// The header's text (ENVI Standard, BSQ, one band, byte order 0) for `grid` in world units.
std::string enviHeaderText(const RasterGrid& grid, const EnviOptions& options);

class EnviWriter {
 public:
  /// Opens the temporaries for `path` and its header; throws dw::Error on an empty grid or a folder
  /// that refuses a new file.
  EnviWriter(const std::string& path, const RasterGrid& grid, const EnviOptions& options = {});
  /// Rows [row_begin, row_begin + rows), grid.cols values each; row_begin must be the next row.
  void writeRows(std::size_t row_begin, std::size_t rows, const double* values);
  /// Both files complete (every row written, else dw::Error): renamed over their targets.
  void commit();
  std::size_t rowsWritten() const { return next_; }

 private:
  RasterGrid grid_;
  EnviOptions options_;
  SafeOutputFile data_, header_;
  std::size_t next_ = 0;
};

}  // namespace dem
}  // namespace dw
