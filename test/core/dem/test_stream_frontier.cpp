/// \file test_stream_frontier.cpp
/// \brief The streaming DEM's invariant, simulated strip by strip: strips read from north to south,
/// the triangles final after each strip are triangles of the whole cloud's TIN, a cell found final
/// never changes and equals, bit for bit, the in-memory raster's cell; cells go out long before the
/// last strip is read.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <vector>

#include "core/dem/stream_frontier.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

using dw::index_t;
using Triangle = std::array<index_t, 3>;

Triangle canonical(const index_t* t) {
  Triangle a = {t[0], t[1], t[2]};
  std::sort(a.begin(), a.end());
  return a;
}

struct StreamResult {
  std::vector<double> raster;          ///< each cell as written when it became final
  std::vector<unsigned char> written;  ///< cells final so far
  std::vector<std::size_t> rows_after_strip;
  std::vector<double> seams;
  std::vector<std::vector<unsigned char>> final_after_strip;
};

/// Reads the points strip by strip (north to south), re-triangulating the prefix each time (the
/// streaming driver would merge instead; the triangles are the same), and writes each cell once it is
/// final, checking that it is never changed afterwards.
StreamResult stream(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
                    const dw::dem::RasterGrid& g, const dw::dem::TinRasterOptions& ro, unsigned strips,
                    const std::set<Triangle>& whole) {
  std::vector<double> sorted_y = y;
  std::sort(sorted_y.begin(), sorted_y.end());
  const auto hull = dw::dem::detail::convexHull(x.data(), y.data(), x.size());  // the first pass
  StreamResult out;
  out.raster.assign(g.size(), -1);
  out.written.assign(g.size(), 0);
  for (unsigned k = 1; k <= strips; ++k) {
    // Points read so far: y >= seam; every later point has y < seam.
    const double seam = k == strips ? -HUGE_VAL : sorted_y[sorted_y.size() * (strips - k) / strips];
    std::vector<index_t> ids;
    std::vector<double> px, py;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (y[i] >= seam) ids.push_back(index_t(i)), px.push_back(x[i]), py.push_back(y[i]);
    dw::tin::TinOptions to;
    to.num_threads = 2;
    auto tri = dw::tin::triangulate(px.data(), py.data(), px.size(), to).triangles;
    for (auto& v : tri) v = ids[v];  // back to the whole cloud's indices (order kept)
    std::vector<index_t> fin, open;
    dw::dem::detail::splitFinalTriangles(x.data(), y.data(), tri.data(), tri.size(), seam, &hull, fin, open);
    for (std::size_t t = 0; t < fin.size(); t += 3)
      EXPECT_TRUE(whole.count(canonical(&fin[t]))) << "strip " << k << ": a final triangle is not in the TIN";
    if (k == strips) {
      EXPECT_TRUE(open.empty());
    }
    // Ownership by final triangles (killed or not), and their values.
    std::vector<double> ones(x.size(), 1.0), mask(g.size()), values(g.size());
    dw::dem::TinRasterOptions mo;
    mo.nodata = 0;
    dw::dem::rasterizeTinRows(x.data(), y.data(), ones.data(), x.size(), fin.data(), fin.size(), g, 0, g.rows,
                              mask.data(), mo);
    dw::dem::rasterizeTinRows(x.data(), y.data(), z.data(), x.size(), fin.data(), fin.size(), g, 0, g.rows,
                              values.data(), ro);
    std::vector<unsigned char> owned(g.size()), final(g.size());
    for (std::size_t i = 0; i < mask.size(); ++i) owned[i] = mask[i] != 0;
    dw::dem::detail::markFinalCells(g, 0, g.rows, owned.data(), hull, final.data());
    for (std::size_t i = 0; i < g.size(); ++i) {
      if (out.written[i]) {
        EXPECT_TRUE(final[i]) << "cell " << i << " was final and is not after strip " << k;
        EXPECT_EQ(std::memcmp(&out.raster[i], &values[i], sizeof(double)), 0) << "cell " << i << " changed";
      } else if (final[i]) {
        out.raster[i] = values[i];
        out.written[i] = 1;
      }
    }
    out.rows_after_strip.push_back(dw::dem::detail::leadingFinalRows(g, 0, g.rows, owned.data(), hull));
    out.seams.push_back(seam);
    out.final_after_strip.push_back(final);
  }
  return out;
}

struct Case {
  std::vector<double> x, y, z;
  std::set<Triangle> whole;
  std::vector<double> ref;
  StreamResult streamed;
};

/// Terrain-like heights on 20000 random points in 300 m x 200 m, optionally around an empty lake of
/// radius 25 m (whose long triangles max-edge kills), streamed in six strips.
Case run(bool lake, const dw::dem::RasterGrid& g, const dw::dem::TinRasterOptions& ro) {
  Case c;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> ux(0, 300), uy(0, 200);
  while (c.x.size() < 20000) {
    const double a = ux(rng), b = uy(rng);
    if (lake && std::hypot(a - 150, b - 90) < 25) continue;
    c.x.push_back(a), c.y.push_back(b), c.z.push_back(100 + 5 * std::sin(a / 17) + b / 9);
  }
  const auto tin = dw::tin::triangulate(c.x.data(), c.y.data(), c.x.size());
  for (std::size_t t = 0; t < tin.triangles.size(); t += 3) c.whole.insert(canonical(&tin.triangles[t]));
  c.ref = dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.z.data(), c.x.size(), tin.triangles, g, ro);
  c.streamed = stream(c.x, c.y, c.z, g, ro, 6, c.whole);
  for (auto r : c.streamed.rows_after_strip) std::printf("%zu ", r);
  std::printf("rows of %zu written after each strip\n", g.rows);
  return c;
}

TEST(StreamFrontier, StripByStripCellsEqualTheInMemoryRasterBitForBit) {
  const dw::dem::RasterGrid g = dw::dem::gridFromBounds(-5, -5, 305, 205, 0.7);
  dw::dem::TinRasterOptions ro;
  ro.max_edge = 6;
  const Case c = run(true, g, ro);
  ASSERT_EQ(c.streamed.rows_after_strip.back(), g.rows);
  EXPECT_EQ(std::count(c.streamed.written.begin(), c.streamed.written.end(), 1), std::ptrdiff_t(g.size()));
  EXPECT_EQ(std::memcmp(c.streamed.raster.data(), c.ref.data(), c.ref.size() * sizeof(double)), 0);
  for (std::size_t k = 1; k < c.streamed.rows_after_strip.size(); ++k)
    EXPECT_GT(c.streamed.rows_after_strip[k], c.streamed.rows_after_strip[k - 1]) << "after strip " << k + 1;
}

TEST(StreamFrontier, CellsGoOutOnceTheSeamIsAFewSpacingsSouth) {
  // Without the lake the open band is a few point spacings (~1.7 m) deep: every cell 15 m north of the
  // seam and 20 m inside the east and west edges is final after that strip. Along those straight
  // edges the hull's thin triangles keep their circles open for longer, so whole rows lag (printed).
  const dw::dem::RasterGrid g = dw::dem::gridFromBounds(-5, -5, 305, 205, 0.7);
  const Case c = run(false, g, {});
  EXPECT_EQ(std::memcmp(c.streamed.raster.data(), c.ref.data(), c.ref.size() * sizeof(double)), 0);
  for (std::size_t k = 0; k + 1 < c.streamed.seams.size(); ++k) {
    std::size_t missing = 0;
    for (std::size_t r = 0; r < g.rows; ++r)
      for (std::size_t col = 0; col < g.cols; ++col)
        if (g.centreY(r) > c.streamed.seams[k] + 15 && g.centreX(col) > 20 && g.centreX(col) < 280)
          missing += !c.streamed.final_after_strip[k][r * g.cols + col];
    EXPECT_EQ(missing, 0u) << "after strip " << k + 1;
  }
}

TEST(StreamFrontier, HullIsConvexCounterClockwiseAndDropsCollinearPoints) {
  const std::vector<double> x = {0, 1, 2, 2, 2, 1, 0, 0, 1, 1};
  const std::vector<double> y = {0, 0, 0, 1, 2, 2, 2, 1, 1, 0};
  const auto h = dw::dem::detail::convexHull(x.data(), y.data(), x.size());
  EXPECT_EQ(h.x, (std::vector<double>{0, 2, 2, 0}));
  EXPECT_EQ(h.y, (std::vector<double>{0, 0, 2, 2}));
  const std::vector<double> lx = {0, 1, 2}, ly = {0, 1, 2};
  EXPECT_LT(dw::dem::detail::convexHull(lx.data(), ly.data(), 3).x.size(), 3u);
}

}  // namespace
