/// \file envi_writer.cpp
/// \brief Raw band + ENVI header (see envi_writer.h).
#include "pcl_delaunay_walk/core/dem/envi_writer.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace dem {

namespace {

bool littleEndian() {
  const std::uint16_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

/// %.17g: every double written reads back as the same double.
std::string exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::string enviHeaderPath(const std::string& data_path) {
  const std::size_t slash = data_path.find_last_of('/');
  const std::size_t dot = data_path.find_last_of('.');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash + 1);
  return (has_ext ? data_path.substr(0, dot) : data_path) + ".hdr";
}

std::string enviHeaderText(const RasterGrid& g, const EnviOptions& o) {
  // ENVI's map info names the image coordinate (1, 1), the upper-left corner of the first cell.
  std::string h = "ENVI\n";
  h += "description = {pcl_delaunay_walk TIN-linear DEM}\n";
  h += "samples = " + std::to_string(g.cols) + "\n";
  h += "lines = " + std::to_string(g.rows) + "\n";
  h += "bands = 1\nheader offset = 0\nfile type = ENVI Standard\n";
  h += std::string("data type = ") + (o.float64 ? "5" : "4") + "\n";
  h += "interleave = bsq\nbyte order = 0\n";
  h += "map info = {Arbitrary, 1, 1, " + exact(g.west) + ", " + exact(g.north) + ", " + exact(g.cell) + ", " +
       exact(g.cell) + "}\n";
  if (!o.srs_wkt.empty()) h += "coordinate system string = {" + o.srs_wkt + "}\n";
  h += "data ignore value = " + exact(o.nodata) + "\n";
  h += "band names = {" + o.band_name + "}\n";
  return h;
}

EnviWriter::EnviWriter(const std::string& path, const RasterGrid& grid, const EnviOptions& options)
    : grid_(grid), options_(options) {
  if (grid.cols == 0 || grid.rows == 0 || !(grid.cell > 0))
    throw Error(path + ": an ENVI raster needs a grid of at least one cell");
  if (!littleEndian()) throw Error(path + ": the ENVI writer writes byte order 0 and needs a little-endian host");
  if (enviHeaderPath(path) == path) throw Error(path + ": the data file cannot have the extension .hdr");
  data_.open(path);
  header_.open(enviHeaderPath(path));
}

void EnviWriter::writeRows(std::size_t row_begin, std::size_t rows, const double* values) {
  if (row_begin != next_ || row_begin + rows > grid_.rows)
    throw Error(data_.target() + ": rows [" + std::to_string(row_begin) + ", " + std::to_string(row_begin + rows) +
                ") written out of order (next row " + std::to_string(next_) + " of " +
                std::to_string(grid_.rows) + ")");
  const std::size_t n = rows * grid_.cols;
  if (options_.float64) {
    data_.write(values, n * sizeof(double));
  } else {
    std::vector<float> f(n);
    for (std::size_t i = 0; i < n; ++i) f[i] = float(values[i]);  // round to nearest, as GDAL's Float32
    data_.write(f.data(), n * sizeof(float));
  }
  next_ += rows;
}

void EnviWriter::commit() {
  if (next_ != grid_.rows)
    throw Error(data_.target() + ": " + std::to_string(next_) + " of " + std::to_string(grid_.rows) +
                " rows written; the raster is incomplete");
  const std::string text = enviHeaderText(grid_, options_);
  header_.write(text.data(), text.size());
  data_.commit();
  header_.commit();
}

}  // namespace dem
}  // namespace dw
