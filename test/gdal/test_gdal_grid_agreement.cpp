/// \file test_gdal_grid_agreement.cpp
/// \brief On real airborne tiles, the TIN-linear raster equals GDAL's own Delaunay linear interpolation
/// (GDALGridCreate with GGA_Linear, what `gdal_grid -a linear` runs) within 1e-6 of the z range at every
/// cell both define, and the triangles it was interpolated from are certified Delaunay.
#include <gdal_alg.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <set>

#include "gdal_test_util.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

struct Agreement {
  std::size_t both = 0, only_ours = 0, only_gdal = 0, neither = 0;
  std::size_t disputed_triangles = 0, disputed_cells = 0;  ///< ours not in GDAL's triangulation
  double max_diff = 0, z_range = 0;
};

/// Rasterises `path` (class `cls`, -1: all) at `cell` both ways on the aligned grid of its points;
/// `west_band` > 0 keeps only the points within that distance of the file's western edge (GDAL's
/// gridding of the whole 683k-point tile takes ~35 s here).
Agreement compare(const std::string& path, int cls, double cell, double west_band = 0) {
  dw::las::LasReadOptions lo;
  lo.classification = cls;
  dw::las::LasCloud las = dw::las::readLasFile(path, lo);
  if (west_band > 0) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < las.size(); ++i)
      if (las.x(i) < las.header.min[0] + west_band) {
        las.X[kept] = las.X[i], las.Y[kept] = las.Y[i], las.Z[kept] = las.Z[i];
        ++kept;
      }
    las.X.resize(kept), las.Y.resize(kept), las.Z.resize(kept);
  }
  const std::size_t n = las.size();
  EXPECT_EQ(las.header.scale[0], las.header.scale[1]);
  // Ours: LAS integers as the frame (as dw_dem does), grid converted into it.
  std::vector<double> fx(n), fy(n), wx(n), wy(n), z(n);
  double lo_x = HUGE_VAL, lo_y = HUGE_VAL, hi_x = -HUGE_VAL, hi_y = -HUGE_VAL, zmin = HUGE_VAL,
         zmax = -HUGE_VAL;
  for (std::size_t i = 0; i < n; ++i) {
    fx[i] = las.X[i];
    fy[i] = las.Y[i];
    wx[i] = las.x(i);
    wy[i] = las.y(i);
    z[i] = las.z(i);
    lo_x = std::min(lo_x, wx[i]), hi_x = std::max(hi_x, wx[i]);
    lo_y = std::min(lo_y, wy[i]), hi_y = std::max(hi_y, wy[i]);
    zmin = std::min(zmin, z[i]), zmax = std::max(zmax, z[i]);
  }
  const dw::tin::TinResult tin = dw::tin::triangulate(fx.data(), fy.data(), n);
  const auto cert = dw::tin::certifyDelaunay(fx.data(), fy.data(), n, tin.triangles, tin.num_vertices);
  EXPECT_TRUE(cert.ok) << path << ": " << cert.message;
  const dw::dem::RasterGrid g = dw::dem::alignedGridCovering(lo_x, lo_y, hi_x, hi_y, cell);
  dw::dem::RasterGrid fg = g;
  const double k = las.header.scale[0];
  fg.west = (g.west - las.header.offset[0]) / k;
  fg.north = (g.north - las.header.offset[1]) / k;
  fg.cell = g.cell / k;
  const double nodata = -9999;
  dw::dem::TinRasterOptions ro;
  ro.nodata = nodata;
  const auto ours = dw::dem::rasterizeTin(fx.data(), fy.data(), z.data(), n, tin.triangles, fg, ro);

  // GDAL: world coordinates relative to the grid's centre, the same edges; y from north to south gives
  // row 0 = the northern row. Centred, because on raw projected coordinates (hexbin: UTM, 1 mm scale)
  // GDAL's qhull call returns overlapping triangles (docs/dem.md, "Agreement with gdal_grid").
  const double cx = 0.5 * (g.west + g.east()), cy = 0.5 * (g.north + g.south());
  std::vector<double> gx(n), gy(n);
  for (std::size_t i = 0; i < n; ++i) gx[i] = las.x(i) - cx, gy[i] = las.y(i) - cy;
  GDALGridLinearOptions go;
  go.nSizeOfStructure = sizeof go;
  go.dfRadius = 0;  // outside every triangle: nodata, no nearest-neighbour fill
  go.dfNoDataValue = nodata;
  std::vector<double> theirs(g.size());
  EXPECT_EQ(GDALGridCreate(GGA_Linear, &go, GUInt32(n), gx.data(), gy.data(), z.data(), g.west - cx,
                           g.east() - cx, g.north - cy, g.south() - cy, GUInt32(g.cols), GUInt32(g.rows),
                           GDT_Float64, theirs.data(), nullptr, nullptr),
            CE_None);

  // The triangles GDAL interpolated from (the same qhull call on the same coordinates): where they are
  // not ours, GDAL's are not the Delaunay triangles (ours are certified, and unique up to exact
  // cocircular ties), so the cells under our triangles that GDAL lacks are compared apart.
  GDALTriangulation* dt = GDALTriangulationCreateDelaunay(int(n), gx.data(), gy.data());
  EXPECT_NE(dt, nullptr);
  std::set<std::array<dw::index_t, 3>> theirs_tri;
  for (int f = 0; dt && f < dt->nFacets; ++f) {
    const int* v = dt->pasFacets[f].anVertexIdx;
    std::array<dw::index_t, 3> t = {dw::index_t(v[0]), dw::index_t(v[1]), dw::index_t(v[2])};
    std::sort(t.begin(), t.end());
    theirs_tri.insert(t);
  }
  if (dt) GDALTriangulationFree(dt);
  std::vector<dw::index_t> disputed;
  for (std::size_t k = 0; k < tin.triangles.size(); k += 3) {
    std::array<dw::index_t, 3> t = {tin.triangles[k], tin.triangles[k + 1], tin.triangles[k + 2]};
    std::sort(t.begin(), t.end());
    if (!theirs_tri.count(t))
      disputed.insert(disputed.end(), tin.triangles.begin() + k, tin.triangles.begin() + k + 3);
  }
  const std::vector<double> ones(n, 1.0);
  const auto in_disputed = dw::dem::rasterizeTin(fx.data(), fy.data(), ones.data(), n, disputed, fg, ro);

  Agreement a;
  a.z_range = zmax - zmin;
  a.disputed_triangles = disputed.size() / 3;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const bool o = ours[i] != nodata, t = theirs[i] != nodata;
    if (o && t && in_disputed[i] == 1.0) {
      ++a.disputed_cells;
    } else if (o && t) {
      ++a.both;
      if (std::getenv("DW_DEM_DEBUG") && std::fabs(ours[i] - theirs[i]) > 1e-6 * (zmax - zmin))
        std::printf("cell %zu %zu: ours %.9g gdal %.9g\n", i / g.cols, i % g.cols, ours[i], theirs[i]);
      a.max_diff = std::max(a.max_diff, std::fabs(ours[i] - theirs[i]));
    } else if (o) {
      ++a.only_ours;
    } else if (t) {
      ++a.only_gdal;
    } else {
      ++a.neither;
    }
  }
  std::printf(
      "%s class %d cell %g: %zu x %zu cells, both %zu (max |diff| %.3g, z range %.4g), only ours %zu, only "
      "GDAL "
      "%zu; %zu of %zu triangles not GDAL's, over %zu cells\n",
      path.c_str(), cls, cell, g.cols, g.rows, a.both, a.max_diff, a.z_range, a.only_ours, a.only_gdal,
      a.disputed_triangles, tin.numTriangles(), a.disputed_cells);
  return a;
}

void expectAgreement(const Agreement& a) {
  EXPECT_GT(a.both, 1000u);
  EXPECT_LE(a.max_diff, 1e-6 * a.z_range);
  // Cells one side defines and the other not can only be centres on the hull boundary (within
  // rounding of GDAL's barycentric test): a thin fringe, never a region.
  EXPECT_LE(a.only_ours + a.only_gdal, a.both / 1000 + 10);
  // GDAL's non-Delaunay triangles are a handful, not a region.
  EXPECT_LE(a.disputed_cells, a.both / 500 + 10);
}

const char* kAutzen = "airborne/autzen_trim.las";
const char* kHexbin = "airborne/hexbin-crop.las";
const char* kExtraBytes = "airborne/las_with_several_extra_byte_bloc.laz";

#define SKIP_WITHOUT(rel)                                                                \
  if (!dw_test::exists(dw_test::sharedData(rel))) {                                      \
    GTEST_SKIP() << dw_test::sharedData(rel) << " is absent (the shared real data set)"; \
  }

TEST(GdalGridAgreement, BundledAutzenCropAllReturnsAndGround) {
  const std::string crop = std::string(DW_TEST_DATA_DIR) + "/autzen_crop.las";
  expectAgreement(compare(crop, -1, 1.0));  // feet
  expectAgreement(compare(crop, 2, 2.0));
}

TEST(GdalGridAgreement, AutzenAllReturnsAndGround) {
  SKIP_WITHOUT(kAutzen);
  expectAgreement(compare(dw_test::sharedData(kAutzen), -1, 2.0));  // feet
  expectAgreement(compare(dw_test::sharedData(kAutzen), 2, 3.0));
}

TEST(GdalGridAgreement, HexbinMountainCrop) {
  SKIP_WITHOUT(kHexbin);
  expectAgreement(compare(dw_test::sharedData(kHexbin), -1, 0.5));
}

TEST(GdalGridAgreement, ExtraBytesTileGroundFromLaz) {
  SKIP_WITHOUT(kExtraBytes);
  expectAgreement(compare(dw_test::sharedData(kExtraBytes), 2, 1.0, 80.0));
}

}  // namespace
