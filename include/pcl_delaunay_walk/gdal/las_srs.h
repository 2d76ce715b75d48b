/// \file las_srs.h
/// \brief A LAS file's coordinate reference system as GDAL/OGR understands it: the OGC WKT record when
/// there is one, else the GeoTIFF keys, read by GDAL's own GeoTIFF driver (libgeotiff).
#pragma once

#include <string>

#include "pcl_delaunay_walk/core/las/las_crs.h"

namespace dw {
namespace gdal {

/// The CRS as WKT (as OGR exports it), or empty when `crs` has no record. `source`, if given, is set to
/// "wkt", "geokeys" or "none". Throws dw::gdal::RasterError when a record is present but OGR cannot
/// make a spatial reference of it.
std::string srsWktFromLas(const las::LasCrs& crs, std::string* source = nullptr);

/// The same from the GeoTIFF keys alone (ignoring any WKT record); empty when there are none.
std::string srsWktFromGeoKeys(const las::LasCrs& crs);

}  // namespace gdal
}  // namespace dw
