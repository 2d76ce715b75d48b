/// \file las_srs.cpp
/// \brief LAS CRS records to an OGR spatial reference. GDAL has no public call that takes raw GeoTIFF
/// keys, but its GeoTIFF driver reads them from any TIFF (through libgeotiff), so the keys are put into
/// a one-pixel TIFF in GDAL's in-memory file system and read back from there.
#include "pcl_delaunay_walk/gdal/las_srs.h"

#include <cpl_vsi.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <vector>

#include "gdal/gdal_session.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"

namespace dw {
namespace gdal {

using detail::GdalSession;

namespace {

std::string wktOf(OGRSpatialReferenceH srs) {
  char* text = nullptr;
  if (OSRExportToWkt(srs, &text) != OGRERR_NONE || !text) {
    CPLFree(text);
    throw RasterError("OGR cannot export the LAS file's spatial reference as WKT: " +
                      GdalSession::lastError());
  }
  std::string out(text);
  CPLFree(text);
  return out;
}

/// A little-endian baseline TIFF of one 8-bit pixel whose IFD also holds the three GeoTIFF tags.
class GeoKeyTiff {
 public:
  explicit GeoKeyTiff(const las::LasCrs& crs) {
    std::string ascii = crs.geo_ascii;
    if (!ascii.empty() && ascii.back() != '\0') ascii.push_back('\0');
    struct Entry {
      std::uint16_t tag, type;
      std::uint32_t count;
      std::vector<unsigned char> data;
    };
    std::vector<Entry> e;
    auto shortTag = [&](std::uint16_t tag, std::uint16_t v) { e.push_back({tag, 3, 1, bytes(&v, 2)}); };
    auto longTag = [&](std::uint16_t tag, std::uint32_t v) { e.push_back({tag, 4, 1, bytes(&v, 4)}); };
    shortTag(256, 1);  // ImageWidth
    shortTag(257, 1);  // ImageLength
    shortTag(258, 8);  // BitsPerSample
    shortTag(259, 1);  // Compression: none
    shortTag(262, 1);  // PhotometricInterpretation: black is zero
    longTag(273, 0);   // StripOffsets, patched below
    shortTag(277, 1);  // SamplesPerPixel
    shortTag(278, 1);  // RowsPerStrip
    longTag(279, 1);   // StripByteCounts
    e.push_back(
        {34735, 3, std::uint32_t(crs.geo_keys.size()), bytes(crs.geo_keys.data(), 2 * crs.geo_keys.size())});
    if (!crs.geo_doubles.empty())
      e.push_back({34736, 12, std::uint32_t(crs.geo_doubles.size()),
                   bytes(crs.geo_doubles.data(), 8 * crs.geo_doubles.size())});
    if (!ascii.empty())
      e.push_back({34737, 2, std::uint32_t(ascii.size()), bytes(ascii.data(), ascii.size())});
    const std::uint32_t ifd_size = std::uint32_t(2 + 12 * e.size() + 4);
    std::uint32_t data_at = 8 + ifd_size;
    const std::uint32_t pixel_at = data_at;
    std::memcpy(e[5].data.data(), &pixel_at, 4);
    data_at += 2;  // the pixel, padded to an even offset
    file_ = {'I', 'I', 42, 0, 8, 0, 0, 0};
    append(std::uint16_t(e.size()));
    std::vector<unsigned char> tail = {0, 0};
    for (const Entry& x : e) {
      append(x.tag);
      append(x.type);
      append(x.count);
      if (x.data.size() <= 4) {
        std::vector<unsigned char> v = x.data;
        v.resize(4, 0);
        file_.insert(file_.end(), v.begin(), v.end());
      } else {
        append(data_at + std::uint32_t(tail.size() - 2));
        tail.insert(tail.end(), x.data.begin(), x.data.end());
        if (tail.size() % 2) tail.push_back(0);
      }
    }
    append(std::uint32_t(0));  // no next IFD
    file_.insert(file_.end(), tail.begin(), tail.end());
  }
  const std::vector<unsigned char>& bytesOfFile() const { return file_; }

 private:
  std::vector<unsigned char> file_;
  static std::vector<unsigned char> bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    return std::vector<unsigned char>(c, c + n);
  }
  template <typename T>
  void append(T v) {
    const auto b = bytes(&v, sizeof v);
    file_.insert(file_.end(), b.begin(), b.end());
  }
};

std::atomic<unsigned> vsimem_counter{0};

}  // namespace

std::string srsWktFromGeoKeys(const las::LasCrs& crs) {
  if (crs.geo_keys.size() < 4) return std::string();
  GdalSession session;
  const GeoKeyTiff tiff(crs);
  const std::string name = "/vsimem/dw_geokeys_" + std::to_string(vsimem_counter++) + ".tif";
  VSILFILE* f = VSIFileFromMemBuffer(name.c_str(), const_cast<GByte*>(tiff.bytesOfFile().data()),
                                     vsi_l_offset(tiff.bytesOfFile().size()), FALSE);
  if (!f) throw RasterError("GDAL cannot make an in-memory file for the LAS GeoTIFF keys");
  VSIFCloseL(f);
  GDALDatasetH ds = GDALOpen(name.c_str(), GA_ReadOnly);
  std::string wkt;
  if (ds) {
    OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
    if (srs) wkt = wktOf(srs);
    GDALClose(ds);
  }
  VSIUnlink(name.c_str());
  if (!ds) throw RasterError("GDAL cannot read the LAS GeoTIFF keys: " + GdalSession::lastError());
  if (wkt.empty()) throw RasterError("the LAS GeoTIFF keys describe no coordinate system GDAL knows");
  return wkt;
}

std::string srsWktFromLas(const las::LasCrs& crs, std::string* source) {
  if (source) *source = "none";
  if (!crs.wkt.empty()) {
    GdalSession session;
    OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
    // Import as WKT only (never as a file name or URL, which OSRSetFromUserInput would also accept).
    char* text = const_cast<char*>(crs.wkt.c_str());
    const OGRErr e = OSRImportFromWkt(srs, &text);
    std::string wkt;
    if (e == OGRERR_NONE) wkt = wktOf(srs);
    OSRDestroySpatialReference(srs);
    if (e != OGRERR_NONE)
      throw RasterError("OGR cannot read the LAS file's WKT coordinate system record: " +
                        GdalSession::lastError());
    if (source) *source = "wkt";
    return wkt;
  }
  std::string wkt = srsWktFromGeoKeys(crs);
  if (!wkt.empty() && source) *source = "geokeys";
  return wkt;
}

}  // namespace gdal
}  // namespace dw
