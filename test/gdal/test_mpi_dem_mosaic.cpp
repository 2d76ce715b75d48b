/// \file test_mpi_dem_mosaic.cpp
/// \brief The VRT mosaic of row-band tiles (gdal/vrt_mosaic.h) read back through GDAL, and the checker
/// the mpi.run.dem_* tests run on dw_tin_mpi's output: the mosaic equals the single-process dw_dem
/// raster of the same input bit for bit (seams between the ranks' bands and strips included), with
/// the same CRS, geotransform and nodata, and every tile is a GeoTIFF georeferenced at its rows.
#include <cpl_conv.h>
#include <cpl_string.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>

#include <cmath>
#include <cstdlib>
#include <cstring>

#include "gdal_test_util.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#include "pcl_delaunay_walk/gdal/vrt_mosaic.h"

namespace {

using dw_test::Raster;

std::string epsgWkt(int code) {
  OGRSpatialReferenceH s = OSRNewSpatialReference(nullptr);
  EXPECT_EQ(OSRImportFromEPSG(s, code), OGRERR_NONE);
  char* w = nullptr;
  OSRExportToWkt(s, &w);
  std::string out(w);
  CPLFree(w);
  OSRDestroySpatialReference(s);
  return out;
}

void expectSameGeoreferencing(const Raster& a, const Raster& b) {
  ASSERT_NE(a.ds, nullptr);
  ASSERT_NE(b.ds, nullptr);
  EXPECT_EQ(GDALGetRasterXSize(a.ds), GDALGetRasterXSize(b.ds));
  EXPECT_EQ(GDALGetRasterYSize(a.ds), GDALGetRasterYSize(b.ds));
  double ga[6], gb[6];
  ASSERT_EQ(GDALGetGeoTransform(a.ds, ga), CE_None);
  ASSERT_EQ(GDALGetGeoTransform(b.ds, gb), CE_None);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(ga[k], gb[k]) << "geotransform " << k;
  int ha = 0, hb = 0;
  EXPECT_EQ(GDALGetRasterNoDataValue(GDALGetRasterBand(a.ds, 1), &ha),
            GDALGetRasterNoDataValue(GDALGetRasterBand(b.ds, 1), &hb));
  EXPECT_TRUE(ha && hb);
  EXPECT_EQ(GDALGetRasterDataType(GDALGetRasterBand(a.ds, 1)),
            GDALGetRasterDataType(GDALGetRasterBand(b.ds, 1)));
  OGRSpatialReferenceH sa = GDALGetSpatialRef(a.ds), sb = GDALGetSpatialRef(b.ds);
  ASSERT_EQ(sa == nullptr, sb == nullptr);
  if (sa) {
    EXPECT_TRUE(OSRIsSame(sa, sb));
  }
}

/// Every cell's bits (read as doubles: Float32 widens exactly).
void expectSameBits(const Raster& a, const Raster& b) {
  const std::vector<double> va = a.values(), vb = b.values();
  ASSERT_EQ(va.size(), vb.size());
  std::size_t differ = 0, first = va.size();
  for (std::size_t i = 0; i < va.size(); ++i)
    if (std::memcmp(&va[i], &vb[i], sizeof(double)) != 0) ++differ, first = std::min(first, i);
  EXPECT_EQ(differ, 0u) << "first at cell " << first;
}

TEST(VrtMosaic, BandsOfGeoTiffsReadBackAsTheWholeRaster) {
  const std::string dir = dw_test::scratch("vrt");
  const dw::dem::RasterGrid g =
      dw::dem::gridFromBounds(393700.5, 3689000, 393700.5 + 0.5 * 300, 3689000 + 0.5 * 70, 0.5);
  std::vector<double> v(g.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = i % 13 == 0 ? -9999 : 3100 + 0.001 * double(i);
  dw::gdal::GeoTiffOptions o;
  o.srs_wkt = epsgWkt(32642);
  dw::gdal::writeGeoTiff(dir + "/whole.tif", g, v.data(), o);
  std::system(("mkdir -p '" + dir + "/t'").c_str());
  std::vector<dw::gdal::VrtBand> bands;
  const std::size_t cuts[] = {0, 23, 24, 70};
  for (int k = 0; k < 3; ++k) {
    dw::dem::RasterGrid tg = g;
    tg.north = g.north - double(cuts[k]) * g.cell;
    tg.rows = cuts[k + 1] - cuts[k];
    dw::gdal::writeGeoTiff(dir + "/t/b" + std::to_string(k) + ".tif", tg, v.data() + cuts[k] * g.cols, o);
    bands.push_back({"t/b" + std::to_string(k) + ".tif", cuts[k], tg.rows});
  }
  std::swap(bands[0], bands[2]);  // any order
  dw::gdal::writeVrtMosaic(dir + "/m.vrt", g, bands, o);
  const Raster whole(dir + "/whole.tif"), mosaic(dir + "/m.vrt");
  expectSameGeoreferencing(whole, mosaic);
  expectSameBits(whole, mosaic);
}

TEST(VrtMosaic, BadBandsAreRefusedAndKeepTheExistingFile) {
  const std::string dir = dw_test::scratch("vrt_bad");
  const dw::dem::RasterGrid g = dw::dem::gridFromBounds(0, 0, 10, 10, 1);
  dw_test::writeBytes(dir + "/m.vrt", "an existing mosaic");
  const dw::gdal::GeoTiffOptions o;
  EXPECT_THROW(dw::gdal::writeVrtMosaic(dir + "/m.vrt", g, {{"a.tif", 0, 6}, {"b.tif", 5, 5}}, o),
               dw::gdal::RasterError);  // overlap
  EXPECT_THROW(dw::gdal::writeVrtMosaic(dir + "/m.vrt", g, {{"a.tif", 8, 3}}, o), dw::gdal::RasterError);
  EXPECT_THROW(dw::gdal::writeVrtMosaic(dir + "/missing/m.vrt", g, {{"a.tif", 0, 10}}, o), dw::Error);
  EXPECT_EQ(dw_test::readBytes(dir + "/m.vrt"), "an existing mosaic");
  EXPECT_EQ(dw_test::listFolder(dir), std::vector<std::string>{"m.vrt"});
}

TEST(GeoTiffWriterFinish, FinishLeavesTheTargetUntilCommit) {
  const std::string dir = dw_test::scratch("finish");
  dw_test::writeBytes(dir + "/dem.tif", "old");
  const dw::dem::RasterGrid g = dw::dem::gridFromBounds(0, 0, 4, 3, 1);
  const std::vector<double> v(g.size(), 2.5);
  dw::gdal::GeoTiffWriter w(dir + "/dem.tif", g, {});
  w.writeRows(0, g.rows, v.data());
  w.finish();
  EXPECT_EQ(dw_test::readBytes(dir + "/dem.tif"), "old");
  EXPECT_TRUE(dw_test::exists(w.temporaryPath()));
  w.commit();
  EXPECT_EQ(Raster(dir + "/dem.tif").values(), v);
  EXPECT_THROW(w.commit(), dw::gdal::RasterError);
}

/// The checker of test/mpi/run/dem_mosaic.cmake: DW_MPI_DEM_VRT (dw_tin_mpi's mosaic) against
/// DW_MPI_DEM_REFERENCE (dw_dem's raster), DW_MPI_DEM_TILES tiles expected.
TEST(MpiDemMosaic, MosaicEqualsTheSingleProcessRasterBitForBit) {
  const char* vrt = std::getenv("DW_MPI_DEM_VRT");
  const char* ref = std::getenv("DW_MPI_DEM_REFERENCE");
  const char* tiles = std::getenv("DW_MPI_DEM_TILES");
  if (!vrt || !ref || !tiles) GTEST_SKIP() << "run by mpi.run.dem_*";
  const Raster mosaic(vrt), single(ref);
  ASSERT_NE(mosaic.ds, nullptr) << vrt;
  EXPECT_STREQ(GDALGetDriverShortName(GDALGetDatasetDriver(mosaic.ds)), "VRT");
  expectSameGeoreferencing(single, mosaic);
  expectSameBits(single, mosaic);
  const std::vector<double> v = single.values();
  int has = 0;
  const double nodata = GDALGetRasterNoDataValue(GDALGetRasterBand(single.ds, 1), &has);
  std::size_t set = 0;
  for (double x : v) set += x != nodata;
  EXPECT_GT(set, v.size() / 4) << "too few cells set for a meaningful comparison";
  EXPECT_LT(set, v.size()) << "no nodata cell to compare";

  // Each tile a GeoTIFF of the mosaic's CRS and nodata at its rows.
  char** files = GDALGetFileList(mosaic.ds);
  int n = 0;
  double gm[6];
  GDALGetGeoTransform(mosaic.ds, gm);
  for (int i = 0; files && files[i]; ++i) {
    if (std::strstr(files[i], ".vrt")) continue;
    ++n;
    const Raster t(files[i]);
    ASSERT_NE(t.ds, nullptr) << files[i];
    EXPECT_STREQ(GDALGetDriverShortName(GDALGetDatasetDriver(t.ds)), "GTiff");
    double gt[6];
    ASSERT_EQ(GDALGetGeoTransform(t.ds, gt), CE_None);
    EXPECT_EQ(gt[0], gm[0]);
    EXPECT_EQ(gt[1], gm[1]);
    EXPECT_EQ(gt[5], gm[5]);
    const double row = (gm[3] - gt[3]) / gm[1];
    EXPECT_EQ(row, std::round(row)) << files[i];
    EXPECT_EQ(GDALGetRasterXSize(t.ds), GDALGetRasterXSize(mosaic.ds));
    int th = 0;
    EXPECT_EQ(GDALGetRasterNoDataValue(GDALGetRasterBand(t.ds, 1), &th), nodata);
    OGRSpatialReferenceH st = GDALGetSpatialRef(t.ds), sm = GDALGetSpatialRef(mosaic.ds);
    ASSERT_EQ(st == nullptr, sm == nullptr);
    if (st) {
      EXPECT_TRUE(OSRIsSame(st, sm));
    }
  }
  CSLDestroy(files);
  EXPECT_EQ(n, std::atoi(tiles));
}

}  // namespace
