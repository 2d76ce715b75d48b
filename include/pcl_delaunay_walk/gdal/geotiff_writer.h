/// \file geotiff_writer.h
/// \brief Rasters written through GDAL: a tiled, compressed GeoTIFF (or a Cloud-Optimized GeoTIFF)
/// with its geotransform, nodata and spatial reference, written under a temporary name in the target's
/// folder and renamed over the target only when complete, so a failure at any point leaves an existing
/// file untouched. The adapter layer between the GDAL-free core (dw::dem) and GDAL.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace gdal {

/// A raster GDAL could not write (the message names the file and GDAL's reason).
class RasterError : public Error {
 public:
  using Error::Error;
};

struct GeoTiffOptions {
  bool cog = false;      ///< a Cloud-Optimized GeoTIFF (GDAL's COG driver, with overviews)
  bool float64 = false;  ///< Float64 cells; Float32 (the usual DEM type) otherwise
  std::string compress =
      "DEFLATE";       ///< DEFLATE, LZW, ZSTD or NONE; the floating-point predictor with all but NONE
  unsigned block = 0;  ///< tile size; 0: 256 (GeoTIFF) or 512 (COG)
  double nodata = -9999;
  std::string srs_wkt;       ///< spatial reference as WKT (srsWktFromLas); empty: none
  unsigned num_threads = 0;  ///< GDAL's compression threads; 0: all cores
};

/// Writes a raster row band by row band. Rows may come in any order; every row must be written before
/// commit(). Destroying the writer without commit() removes the temporary file.
class GeoTiffWriter {
 public:
  /// Creates the temporary file beside `path`; throws RasterError when GDAL cannot.
  GeoTiffWriter(const std::string& path, const dem::RasterGrid& grid, const GeoTiffOptions& options);
  ~GeoTiffWriter();
  GeoTiffWriter(const GeoTiffWriter&) = delete;
  GeoTiffWriter& operator=(const GeoTiffWriter&) = delete;

  /// Rows [row_begin, row_begin + num_rows), grid.cols values each, row after row.
  void writeRows(std::size_t row_begin, std::size_t num_rows, const double* values);
  /// Flushes and closes the temporary file (for a COG: builds it from the tiled file), leaving `path`
  /// as it was; commit() then only renames. Writers of parts of one raster (the MPI ranks' tiles)
  /// finish all parts before any replaces its target. Throws RasterError when GDAL fails.
  void finish();
  /// finish() unless done, then renames the file over `path`. Throws RasterError, leaving `path` as it
  /// was, when any step fails.
  void commit();
  /// The temporary file being written (for tests).
  const std::string& temporaryPath() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The whole raster at once (grid.size() values, row by row).
void writeGeoTiff(const std::string& path, const dem::RasterGrid& grid, const double* values,
                  const GeoTiffOptions& options);

}  // namespace gdal
}  // namespace dw
