/// \file test_las_srs.cpp
/// \brief LAS CRS records to OGR spatial references: WKT first, GeoTIFF keys otherwise (through GDAL's
/// GeoTIFF driver), errors for records OGR cannot read, and the real tiles' systems.
#include <cpl_conv.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>

#include <string>

#include "gdal_test_util.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#include "pcl_delaunay_walk/gdal/las_srs.h"

namespace {

/// The EPSG code OGR identifies `wkt` with (after AutoIdentifyEPSG), or "" if none.
std::string epsgOf(const std::string& wkt) {
  OGRSpatialReferenceH s = OSRNewSpatialReference(nullptr);
  char* p = const_cast<char*>(wkt.c_str());
  EXPECT_EQ(OSRImportFromWkt(s, &p), OGRERR_NONE);
  OSRAutoIdentifyEPSG(s);
  const char* code = OSRGetAuthorityCode(s, nullptr);
  std::string out = code ? code : "";
  OSRDestroySpatialReference(s);
  return out;
}

bool sameSrs(const std::string& a, const std::string& b) {
  OGRSpatialReferenceH x = OSRNewSpatialReference(a.c_str()), y = OSRNewSpatialReference(b.c_str());
  const char* opts[] = {"IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES", "CRITERION=EQUIVALENT", nullptr};
  const bool same = OSRIsSameEx(x, y, opts);
  OSRDestroySpatialReference(x);
  OSRDestroySpatialReference(y);
  return same;
}

TEST(LasSrs, GeoKeysOfAUtmZoneGiveItsEpsgCode) {
  dw::las::LasCrs crs;
  // Directory header (version 1, revision 1.0, 3 keys); GTModelType = projected, GTRasterType = area,
  // ProjectedCSType = 32633 (WGS 84 / UTM zone 33N).
  crs.geo_keys = {1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633};
  std::string source;
  const std::string wkt = dw::gdal::srsWktFromLas(crs, &source);
  EXPECT_EQ(source, "geokeys");
  EXPECT_EQ(epsgOf(wkt), "32633");
  EXPECT_NE(wkt.find("UTM zone 33N"), std::string::npos) << wkt;
}

TEST(LasSrs, WktComesFirstAndBadRecordsAreErrors) {
  dw::las::LasCrs crs;
  crs.geo_keys = {1, 1, 0, 1, 3072, 0, 1, 32633};
  OGRSpatialReferenceH s = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(s, 2154);
  char* w = nullptr;
  OSRExportToWkt(s, &w);
  crs.wkt = w;
  CPLFree(w);
  OSRDestroySpatialReference(s);
  std::string source;
  EXPECT_EQ(epsgOf(dw::gdal::srsWktFromLas(crs, &source)), "2154");
  EXPECT_EQ(source, "wkt");
  crs.wkt = "PROJCS[\"broken\", nonsense";
  EXPECT_THROW(dw::gdal::srsWktFromLas(crs), dw::gdal::RasterError);
  EXPECT_EQ(dw::gdal::srsWktFromLas(dw::las::LasCrs(), &source), "");
  EXPECT_EQ(source, "none");
}

TEST(LasSrs, RealTilesWktAndGeoKeysAgree) {
  const std::string hexbin = dw_test::sharedData("airborne/hexbin-crop.las");
  if (!dw_test::exists(hexbin)) GTEST_SKIP() << hexbin << " is absent (the shared real data set)";
  const auto h = dw::las::readLasCrs(hexbin);
  const std::string from_wkt = dw::gdal::srsWktFromLas(h), from_keys = dw::gdal::srsWktFromGeoKeys(h);
  EXPECT_EQ(epsgOf(from_wkt), "32642");
  EXPECT_EQ(epsgOf(from_keys), "32642");
  const auto a = dw::las::readLasCrs(dw_test::sharedData("airborne/autzen_trim.las"));
  const std::string a_wkt = dw::gdal::srsWktFromLas(a), a_keys = dw::gdal::srsWktFromGeoKeys(a);
  EXPECT_NE(a_wkt.find("Lambert_Conformal_Conic"), std::string::npos);
  EXPECT_TRUE(sameSrs(a_wkt, a_keys)) << a_wkt << "\n---\n" << a_keys;
  const auto l = dw::las::readLasCrs(dw_test::sharedData("airborne/las_with_several_extra_byte_bloc.laz"));
  EXPECT_EQ(epsgOf(dw::gdal::srsWktFromLas(l)), "2154");  // RGF93 / Lambert-93
}

}  // namespace
