/// \file hillshade.cpp
/// \brief The hillshade preview: the DEM into a GDAL in-memory dataset, GDALDEMProcessing
/// ("hillshade", the algorithm of gdaldem), then GDAL's PNG driver.
#include "pcl_delaunay_walk/gdal/hillshade.h"

#include <cpl_string.h>
#include <gdal.h>
#include <gdal_utils.h>

#include <string>

#include "gdal/gdal_session.h"
#include "gdal/temporary_output.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"

namespace dw {
namespace gdal {

using detail::GdalSession;

namespace {
/// Closes a dataset on scope exit.
struct Dataset {
  GDALDatasetH h = nullptr;
  ~Dataset() {
    if (h) GDALClose(h);
  }
};
}  // namespace

void writeHillshadePng(const std::string& path, const dem::RasterGrid& grid, const double* values,
                       double nodata, double z_factor) {
  if (grid.cols == 0 || grid.rows == 0) throw RasterError(path + ": cannot shade an empty raster");
  GdalSession session;
  GDALDriverH mem = GDALGetDriverByName("MEM"), png = GDALGetDriverByName("PNG");
  if (!mem || !png) throw RasterError(path + ": this GDAL lacks the MEM or PNG driver");
  Dataset dem;
  dem.h = GDALCreate(mem, "", int(grid.cols), int(grid.rows), 1, GDT_Float64, nullptr);
  if (!dem.h) throw RasterError(path + ": GDAL cannot hold the DEM in memory: " + GdalSession::lastError());
  double gt[6] = {grid.west, grid.cell, 0, grid.north, 0, -grid.cell};
  GDALSetGeoTransform(dem.h, gt);
  GDALRasterBandH band = GDALGetRasterBand(dem.h, 1);
  GDALSetRasterNoDataValue(band, nodata);
  if (GDALRasterIO(band, GF_Write, 0, 0, int(grid.cols), int(grid.rows), const_cast<double*>(values),
                   int(grid.cols), int(grid.rows), GDT_Float64, 0, 0) != CE_None)
    throw RasterError(path + ": GDAL cannot hold the DEM in memory: " + GdalSession::lastError());

  const std::string z = std::to_string(z_factor);
  const char* argv[] = {"-of", "MEM", "-compute_edges", "-z", z.c_str(), nullptr};
  GDALDEMProcessingOptions* opt = GDALDEMProcessingOptionsNew(const_cast<char**>(argv), nullptr);
  if (!opt) throw RasterError(path + ": bad hillshade options: " + GdalSession::lastError());
  Dataset shade;
  int usage_error = 0;
  shade.h = GDALDEMProcessing("", dem.h, "hillshade", nullptr, opt, &usage_error);
  GDALDEMProcessingOptionsFree(opt);
  if (!shade.h) throw RasterError(path + ": GDAL's hillshade failed: " + GdalSession::lastError());

  detail::TemporaryOutput out(path);
  Dataset written;
  written.h = GDALCreateCopy(png, out.path().c_str(), shade.h, FALSE, nullptr, nullptr, nullptr);
  if (!written.h || GdalSession::failed())
    throw RasterError(path + ": GDAL cannot write the PNG " + out.path() + ": " + GdalSession::lastError());
  GDALClose(written.h);
  written.h = nullptr;
  if (GdalSession::failed())
    throw RasterError(path + ": GDAL cannot finish the PNG " + out.path() + ": " + GdalSession::lastError());
  try {
    out.commit();
  } catch (const Error& e) {
    throw RasterError(e.what());
  }
}

}  // namespace gdal
}  // namespace dw
