/// \file geotiff_writer.cpp
/// \brief GeoTIFF and COG writing through GDAL's GTiff and COG drivers.
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"

#include <cpl_string.h>
#include <gdal.h>

#include <algorithm>
#include <thread>

#include "gdal/gdal_session.h"
#include "gdal/temporary_output.h"

namespace dw {
namespace gdal {

using detail::GdalSession;
using detail::TemporaryOutput;

namespace {

/// GDAL's list of "KEY=VALUE" strings, freed on scope exit.
class StringList {
 public:
  ~StringList() { CSLDestroy(list_); }
  void set(const char* key, const std::string& value) { list_ = CSLSetNameValue(list_, key, value.c_str()); }
  char** get() const { return list_; }

 private:
  char** list_ = nullptr;
};

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  return s;
}

std::string threadsValue(unsigned n) {
  return std::to_string(n ? n : std::max(1u, std::thread::hardware_concurrency()));
}

GDALDriverH driver(const char* name, const std::string& path) {
  GDALDriverH d = GDALGetDriverByName(name);
  if (!d) throw RasterError(path + ": this GDAL has no " + std::string(name) + " driver");
  return d;
}

}  // namespace

struct GeoTiffWriter::Impl {
  dem::RasterGrid grid;
  GeoTiffOptions options;
  TemporaryOutput out;        // the file renamed into place
  TemporaryOutput tiled;      // COG only: the tiled GeoTIFF the COG is copied from
  GDALDatasetH ds = nullptr;  // open on tiled (COG) or out (GeoTIFF)
  bool finished = false;      // out holds the complete raster
  Impl(const std::string& path, const dem::RasterGrid& g, const GeoTiffOptions& o)
      : grid(g), options(o), out(path), tiled(path) {}
  const std::string& writtenPath() const { return options.cog ? tiled.path() : out.path(); }
  void close() {
    if (ds) GDALClose(ds);
    ds = nullptr;
  }
};

GeoTiffWriter::GeoTiffWriter(const std::string& path, const dem::RasterGrid& grid,
                             const GeoTiffOptions& options)
    : impl_(std::make_unique<Impl>(path, grid, options)) {
  if (grid.cols == 0 || grid.rows == 0 || !(grid.cell > 0))
    throw RasterError(path + ": cannot write an empty raster grid");
  if (grid.cols > 2147483647u || grid.rows > 2147483647u)
    throw RasterError(path + ": a raster of " + std::to_string(grid.cols) + " x " +
                      std::to_string(grid.rows) + " cells exceeds GDAL's 2^31 - 1 cells a side");
  const std::string compress = upper(options.compress);
  if (compress != "DEFLATE" && compress != "LZW" && compress != "ZSTD" && compress != "NONE")
    throw RasterError(path + ": unknown compression '" + options.compress + "' (DEFLATE, LZW, ZSTD or NONE)");
  GdalSession session;
  StringList co;
  co.set("TILED", "YES");
  co.set("BLOCKXSIZE", std::to_string(options.block ? options.block : 256));
  co.set("BLOCKYSIZE", std::to_string(options.block ? options.block : 256));
  co.set("BIGTIFF", "IF_SAFER");
  co.set("NUM_THREADS", threadsValue(options.num_threads));
  if (options.cog) {
    co.set("COMPRESS", "LZW");  // the intermediate: quick to write, read once by the COG copy
  } else {
    co.set("COMPRESS", compress);
    if (compress != "NONE")
      co.set("PREDICTOR", "3");  // floating-point predictor: neighbours' bits differ little
  }
  const GDALDataType type = options.float64 ? GDT_Float64 : GDT_Float32;
  Impl& m = *impl_;
  m.ds = GDALCreate(driver("GTiff", path), m.writtenPath().c_str(), int(grid.cols), int(grid.rows), 1, type,
                    co.get());
  if (!m.ds)
    throw RasterError(path + ": GDAL cannot create " + m.writtenPath() + ": " + GdalSession::lastError());
  double gt[6] = {grid.west, grid.cell, 0, grid.north, 0, -grid.cell};
  if (GDALSetGeoTransform(m.ds, gt) != CE_None ||
      GDALSetRasterNoDataValue(GDALGetRasterBand(m.ds, 1), options.nodata) != CE_None ||
      (!options.srs_wkt.empty() && GDALSetProjection(m.ds, options.srs_wkt.c_str()) != CE_None)) {
    m.close();
    throw RasterError(path + ": GDAL cannot set the georeferencing: " + GdalSession::lastError());
  }
}

GeoTiffWriter::~GeoTiffWriter() {
  GdalSession session;
  impl_->close();  // the TemporaryOutputs then remove the files
}

const std::string& GeoTiffWriter::temporaryPath() const {
  return impl_->writtenPath();
}

void GeoTiffWriter::writeRows(std::size_t row_begin, std::size_t num_rows, const double* values) {
  Impl& m = *impl_;
  if (!m.ds) throw RasterError(m.out.target() + ": the raster is already closed");
  if (row_begin > m.grid.rows || num_rows > m.grid.rows - row_begin)
    throw RasterError(m.out.target() + ": rows beyond the grid's " + std::to_string(m.grid.rows));
  if (num_rows == 0) return;
  GdalSession session;
  const CPLErr e =
      GDALRasterIO(GDALGetRasterBand(m.ds, 1), GF_Write, 0, int(row_begin), int(m.grid.cols), int(num_rows),
                   const_cast<double*>(values), int(m.grid.cols), int(num_rows), GDT_Float64, 0, 0);
  if (e != CE_None)
    throw RasterError(m.out.target() + ": GDAL cannot write rows: " + GdalSession::lastError());
}

void GeoTiffWriter::finish() {
  Impl& m = *impl_;
  if (!m.ds) throw RasterError(m.out.target() + ": the raster is already closed");
  GdalSession session;
  GDALFlushCache(m.ds);  // returns nothing in GDAL 3.6: failures show in the error state
  m.close();
  if (GdalSession::failed()) {
    m.out.discard();
    m.tiled.discard();
    throw RasterError(m.out.target() + ": GDAL cannot finish " + m.writtenPath() + ": " +
                      GdalSession::lastError());
  }
  if (m.options.cog) {
    GDALDatasetH src = GDALOpen(m.tiled.path().c_str(), GA_ReadOnly);
    if (!src) throw RasterError(m.out.target() + ": GDAL cannot reopen " + m.tiled.path());
    StringList co;
    const std::string compress = upper(m.options.compress);
    co.set("COMPRESS", compress);
    if (compress != "NONE") co.set("PREDICTOR", "YES");
    co.set("BLOCKSIZE", std::to_string(m.options.block ? m.options.block : 512));
    co.set("BIGTIFF", "IF_SAFER");
    co.set("NUM_THREADS", threadsValue(m.options.num_threads));
    GDALDatasetH cog = GDALCreateCopy(driver("COG", m.out.target()), m.out.path().c_str(), src, FALSE,
                                      co.get(), nullptr, nullptr);
    const bool ok = cog && !GdalSession::failed();
    if (cog) GDALClose(cog);
    GDALClose(src);
    if (!ok || GdalSession::failed()) {
      m.out.discard();
      m.tiled.discard();
      throw RasterError(m.out.target() + ": GDAL cannot write the COG " + m.out.path() + ": " +
                        GdalSession::lastError());
    }
    m.tiled.discard();
  }
  m.finished = true;
}

void GeoTiffWriter::commit() {
  Impl& m = *impl_;
  if (!m.finished) finish();
  m.finished = false;  // a second commit finds the raster closed
  try {
    m.out.commit();
  } catch (const Error& e) {
    throw RasterError(e.what());
  }
}

void writeGeoTiff(const std::string& path, const dem::RasterGrid& grid, const double* values,
                  const GeoTiffOptions& options) {
  GeoTiffWriter w(path, grid, options);
  w.writeRows(0, grid.rows, values);
  w.commit();
}

}  // namespace gdal
}  // namespace dw
