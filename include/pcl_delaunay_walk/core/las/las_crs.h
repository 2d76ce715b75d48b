/// \file las_crs.h
/// \brief The coordinate reference system records of a LAS/LAZ file, as stored: the OGC WKT record
/// (LASF_Projection 2112, a VLR or, in LAS 1.4, an EVLR) and the GeoTIFF keys (LASF_Projection 34735
/// GeoKeyDirectoryTag, 34736 GeoDoubleParamsTag, 34737 GeoAsciiParamsTag). PCL-free and GDAL-free:
/// turning them into a spatial reference is the GDAL adapter's work (pcl_delaunay_walk/gdal/las_srs.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dw {
namespace las {

struct LasCrs {
  std::string wkt;                      ///< the WKT record's text (trailing NULs removed); empty: none
  std::vector<std::uint16_t> geo_keys;  ///< GeoKeyDirectoryTag as 16-bit values; empty: none
  std::vector<double> geo_doubles;      ///< GeoDoubleParamsTag
  std::string geo_ascii;                ///< GeoAsciiParamsTag (NULs kept: keys index into it)
  bool empty() const { return wkt.empty() && geo_keys.empty(); }
};

/// Reads the CRS records of a LAS or LAZ file (the first of each kind; VLRs before EVLRs). Throws
/// dw::las::LasError naming the file when the header is invalid or a record runs past the file.
LasCrs readLasCrs(const std::string& path);

}  // namespace las
}  // namespace dw
