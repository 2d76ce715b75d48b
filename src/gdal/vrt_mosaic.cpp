/// \file vrt_mosaic.cpp
/// \brief The VRT mosaic of row bands (see vrt_mosaic.h).
#include "pcl_delaunay_walk/gdal/vrt_mosaic.h"

#include <ogr_srs_api.h>

#include <algorithm>
#include <cstdio>

#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace gdal {

namespace {

std::string xmlEscaped(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

/// %.17g: every double prints as digits that read back as the same double.
std::string exact(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

/// The <SRS> element, with the axis mapping GDAL gives a GeoTIFF's CRS (x = easting or longitude), so
/// the mosaic reads back with the same CRS as its tiles.
std::string srsElement(const std::string& wkt) {
  if (wkt.empty()) return std::string();
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  char* text = const_cast<char*>(wkt.c_str());
  if (OSRImportFromWkt(srs, &text) != OGRERR_NONE) {
    OSRDestroySpatialReference(srs);
    throw RasterError("the VRT mosaic: OGR cannot read the coordinate system's WKT");
  }
  OSRSetAxisMappingStrategy(srs, OAMS_TRADITIONAL_GIS_ORDER);
  int count = 0;
  const int* map = OSRGetDataAxisToSRSAxisMapping(srs, &count);
  std::string mapping;
  for (int i = 0; i < count; ++i) mapping += (i ? "," : "") + std::to_string(map[i]);
  OSRDestroySpatialReference(srs);
  return "  <SRS dataAxisToSRSAxisMapping=\"" + mapping + "\">" + xmlEscaped(wkt) + "</SRS>\n";
}

}  // namespace

std::string vrtMosaicXml(const dem::RasterGrid& grid, const std::vector<VrtBand>& bands,
                         const GeoTiffOptions& options) {
  if (grid.cols == 0 || grid.rows == 0 || !(grid.cell > 0) || grid.cols > 2147483647u ||
      grid.rows > 2147483647u)
    throw RasterError("the VRT mosaic: the grid is empty or exceeds 2^31 - 1 cells a side");
  std::vector<VrtBand> sorted = bands;
  std::sort(sorted.begin(), sorted.end(),
            [](const VrtBand& a, const VrtBand& b) { return a.row_begin < b.row_begin; });
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    const VrtBand& b = sorted[i];
    if (b.rows == 0 || b.row_begin > grid.rows || b.rows > grid.rows - b.row_begin || b.path.empty())
      throw RasterError("the VRT mosaic: the band " + b.path + " (rows " + std::to_string(b.row_begin) +
                        " + " + std::to_string(b.rows) + ") is empty or leaves the grid's " +
                        std::to_string(grid.rows) + " rows");
    if (i > 0 && sorted[i - 1].row_begin + sorted[i - 1].rows > b.row_begin)
      throw RasterError("the VRT mosaic: the bands " + sorted[i - 1].path + " and " + b.path + " overlap");
  }
  const std::string type = options.float64 ? "Float64" : "Float32";
  const std::string cols = std::to_string(grid.cols);
  std::string x =
      "<VRTDataset rasterXSize=\"" + cols + "\" rasterYSize=\"" + std::to_string(grid.rows) + "\">\n";
  x += srsElement(options.srs_wkt);
  x += "  <GeoTransform>" + exact(grid.west) + ", " + exact(grid.cell) + ", 0, " + exact(grid.north) +
       ", 0, " + exact(-grid.cell) + "</GeoTransform>\n";
  x += "  <VRTRasterBand dataType=\"" + type + "\" band=\"1\">\n";
  x += "    <NoDataValue>" + exact(options.nodata) + "</NoDataValue>\n";
  for (const VrtBand& b : sorted) {
    const std::string rows = std::to_string(b.rows);
    x += "    <SimpleSource>\n";
    x += "      <SourceFilename relativeToVRT=\"1\">" + xmlEscaped(b.path) + "</SourceFilename>\n";
    x += "      <SourceBand>1</SourceBand>\n";
    x += "      <SourceProperties RasterXSize=\"" + cols + "\" RasterYSize=\"" + rows + "\" DataType=\"" +
         type + "\"/>\n";
    x += "      <SrcRect xOff=\"0\" yOff=\"0\" xSize=\"" + cols + "\" ySize=\"" + rows + "\"/>\n";
    x += "      <DstRect xOff=\"0\" yOff=\"" + std::to_string(b.row_begin) + "\" xSize=\"" + cols +
         "\" ySize=\"" + rows + "\"/>\n";
    x += "    </SimpleSource>\n";
  }
  x += "  </VRTRasterBand>\n</VRTDataset>\n";
  return x;
}

void writeVrtMosaic(const std::string& path, const dem::RasterGrid& grid, const std::vector<VrtBand>& bands,
                    const GeoTiffOptions& options) {
  const std::string xml = vrtMosaicXml(grid, bands, options);
  SafeOutputFile f(path);
  f.write(xml.data(), xml.size());
  f.commit();
}

}  // namespace gdal
}  // namespace dw
