/// \file test_geotiff_writer.cpp
/// \brief GeoTIFF and COG files read back through GDAL with their values, geotransform, nodata, tiling,
/// compression and spatial reference; failed or abandoned writes leave an existing file as it was.
#include <cpl_conv.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>

#include <cmath>
#include <cstring>

#include "gdal_test_util.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#include "pcl_delaunay_walk/gdal/hillshade.h"

namespace {

using dw_test::Raster;

dw::dem::RasterGrid testGrid() {
  return dw::dem::gridFromBounds(393700.5, 3689000, 393700.5 + 0.5 * 611, 3689000 + 0.5 * 300, 0.5);
}

std::vector<double> testValues(const dw::dem::RasterGrid& g, double nodata) {
  std::vector<double> v(g.size());
  for (std::size_t r = 0; r < g.rows; ++r)
    for (std::size_t c = 0; c < g.cols; ++c)
      v[r * g.cols + c] =
          (r + c) % 17 == 0 ? nodata : 3100 + 0.01 * double(r) + std::sin(0.05 * double(c)) * 20;
  return v;
}

std::string utm42n() {
  OGRSpatialReferenceH s = OSRNewSpatialReference(nullptr);
  EXPECT_EQ(OSRImportFromEPSG(s, 32642), OGRERR_NONE);
  char* w = nullptr;
  OSRExportToWkt(s, &w);
  std::string out(w);
  CPLFree(w);
  OSRDestroySpatialReference(s);
  return out;
}

void expectGeoreferenced(const Raster& r, const dw::dem::RasterGrid& g, double nodata) {
  ASSERT_NE(r.ds, nullptr);
  EXPECT_EQ(std::size_t(GDALGetRasterXSize(r.ds)), g.cols);
  EXPECT_EQ(std::size_t(GDALGetRasterYSize(r.ds)), g.rows);
  double gt[6];
  ASSERT_EQ(GDALGetGeoTransform(r.ds, gt), CE_None);
  EXPECT_EQ(gt[0], g.west);
  EXPECT_EQ(gt[1], g.cell);
  EXPECT_EQ(gt[2], 0);
  EXPECT_EQ(gt[3], g.north);
  EXPECT_EQ(gt[4], 0);
  EXPECT_EQ(gt[5], -g.cell);
  int has = 0;
  EXPECT_EQ(GDALGetRasterNoDataValue(GDALGetRasterBand(r.ds, 1), &has), nodata);
  EXPECT_TRUE(has);
  OGRSpatialReferenceH srs = GDALGetSpatialRef(r.ds);
  ASSERT_NE(srs, nullptr);
  EXPECT_STREQ(OSRGetAuthorityCode(srs, nullptr), "32642");
}

TEST(GeoTiffWriter, TiledCompressedFloat64FileReadsBackExactly) {
  const std::string dir = dw_test::scratch("tiff64");
  const auto g = testGrid();
  const auto v = testValues(g, -9999);
  dw::gdal::GeoTiffOptions o;
  o.float64 = true;
  o.srs_wkt = utm42n();
  dw::gdal::writeGeoTiff(dir + "/dem.tif", g, v.data(), o);
  const Raster r(dir + "/dem.tif");
  expectGeoreferenced(r, g, -9999);
  EXPECT_EQ(r.values(), v);
  int bx = 0, by = 0;
  GDALGetBlockSize(GDALGetRasterBand(r.ds, 1), &bx, &by);
  EXPECT_EQ(bx, 256);
  EXPECT_EQ(by, 256);
  EXPECT_STREQ(GDALGetMetadataItem(r.ds, "COMPRESSION", "IMAGE_STRUCTURE"), "DEFLATE");
  EXPECT_STREQ(GDALGetMetadataItem(r.ds, "PREDICTOR", "IMAGE_STRUCTURE"), "3");
  EXPECT_EQ(dw_test::listFolder(dir), std::vector<std::string>{"dem.tif"});
}

TEST(GeoTiffWriter, Float32CogIsACogWithTheValuesRoundedToFloat) {
  const std::string dir = dw_test::scratch("cog");
  const auto g = testGrid();
  const auto v = testValues(g, -9999);
  dw::gdal::GeoTiffOptions o;
  o.cog = true;
  o.compress = "lzw";
  o.srs_wkt = utm42n();
  dw::gdal::writeGeoTiff(dir + "/dem.tif", g, v.data(), o);
  const Raster r(dir + "/dem.tif");
  expectGeoreferenced(r, g, -9999);
  EXPECT_STREQ(GDALGetMetadataItem(r.ds, "LAYOUT", "IMAGE_STRUCTURE"), "COG");
  EXPECT_STREQ(GDALGetMetadataItem(r.ds, "COMPRESSION", "IMAGE_STRUCTURE"), "LZW");
  EXPECT_EQ(GDALGetRasterDataType(GDALGetRasterBand(r.ds, 1)), GDT_Float32);
  const auto back = r.values();
  for (std::size_t i = 0; i < v.size(); ++i) ASSERT_EQ(back[i], double(float(v[i]))) << i;
  EXPECT_EQ(dw_test::listFolder(dir), std::vector<std::string>{"dem.tif"});
}

TEST(GeoTiffWriter, AnAbandonedWriteLeavesTheExistingFileAndNoTemporary) {
  const std::string dir = dw_test::scratch("abandon");
  dw_test::writeBytes(dir + "/dem.tif", "an existing raster");
  const auto g = testGrid();
  const auto v = testValues(g, -1);
  for (bool cog : {false, true}) {
    dw::gdal::GeoTiffOptions o;
    o.cog = cog;
    {
      dw::gdal::GeoTiffWriter w(dir + "/dem.tif", g, o);
      w.writeRows(0, 100, v.data());
      EXPECT_TRUE(dw_test::exists(w.temporaryPath()));
      EXPECT_EQ(w.temporaryPath().find(dir + "/"), 0u);  // beside the target: the rename cannot cross devices
    }  // destroyed before commit(), as when the raster step throws
    EXPECT_EQ(dw_test::readBytes(dir + "/dem.tif"), "an existing raster");
    EXPECT_EQ(dw_test::listFolder(dir), std::vector<std::string>{"dem.tif"});
  }
}

TEST(GeoTiffWriter, AFailedCommitLeavesTheTargetAndNoTemporary) {
  const std::string dir = dw_test::scratch("commit");
  // The target is a non-empty folder: the final rename must fail.
  std::system(("mkdir -p '" + dir + "/dem.tif' && echo keep > '" + dir + "/dem.tif/inside'").c_str());
  const auto g = testGrid();
  const auto v = testValues(g, -1);
  dw::gdal::GeoTiffWriter w(dir + "/dem.tif", g, {});
  w.writeRows(0, g.rows, v.data());
  try {
    w.commit();
    FAIL() << "commit over a folder succeeded";
  } catch (const dw::gdal::RasterError& e) {
    EXPECT_NE(std::string(e.what()).find("dem.tif"), std::string::npos) << e.what();
  }
  EXPECT_EQ(dw_test::readBytes(dir + "/dem.tif/inside"), "keep\n");
  EXPECT_EQ(dw_test::listFolder(dir), std::vector<std::string>{"dem.tif"});
}

TEST(GeoTiffWriter, BadRequestsGiveClearErrors) {
  const std::string dir = dw_test::scratch("bad");
  const auto g = testGrid();
  dw::gdal::GeoTiffOptions o;
  o.compress = "bzip9";
  EXPECT_THROW(dw::gdal::GeoTiffWriter(dir + "/a.tif", g, o), dw::gdal::RasterError);
  try {
    dw::gdal::GeoTiffWriter w(dir + "/no/such/folder/a.tif", g, {});
    FAIL();
  } catch (const dw::gdal::RasterError& e) {
    EXPECT_NE(std::string(e.what()).find("no/such/folder/a.tif"), std::string::npos) << e.what();
  }
  dw::gdal::GeoTiffWriter w(dir + "/a.tif", g, {});
  std::vector<double> row(g.cols);
  EXPECT_THROW(w.writeRows(g.rows, 1, row.data()), dw::gdal::RasterError);
}

TEST(Hillshade, PngOfTheDemWithNodataAsZero) {
  const std::string dir = dw_test::scratch("shade");
  const auto g = testGrid();
  auto v = testValues(g, -9999);
  dw::gdal::writeHillshadePng(dir + "/shade.png", g, v.data(), -9999);
  const Raster r(dir + "/shade.png");
  ASSERT_NE(r.ds, nullptr);
  EXPECT_STREQ(GDALGetDriverShortName(GDALGetDatasetDriver(r.ds)), "PNG");
  EXPECT_EQ(std::size_t(GDALGetRasterXSize(r.ds)), g.cols);
  const auto s = r.values();
  std::size_t lit = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (v[i] == -9999) {
      EXPECT_EQ(s[i], 0) << i;
    }
    lit += s[i] > 0;
  }
  EXPECT_GT(lit, s.size() / 2);
  EXPECT_EQ(dw_test::listFolder(dir), std::vector<std::string>{"shade.png"});
  EXPECT_THROW(dw::gdal::writeHillshadePng(dir + "/none/shade.png", g, v.data(), -9999),
               dw::gdal::RasterError);
}

}  // namespace
