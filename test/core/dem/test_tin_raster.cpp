/// \file test_tin_raster.cpp
/// \brief TIN-linear rasterisation against brute force: every centre's value from the triangle that
/// contains it (found by trying every triangle), nodata outside the hull and under killed triangles,
/// one owner per centre on shared edges and vertices, and bit-identical rasters for any thread count,
/// row window, triangle order and rotation.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

using dw::index_t;
using dw::dem::RasterGrid;

struct Cloud {
  std::vector<double> x, y, v;
  std::vector<index_t> tri;
};

Cloud randomCloud(std::size_t n, unsigned seed, double w, double h) {
  Cloud c;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(0, w), uy(0, h);
  for (std::size_t i = 0; i < n; ++i) {
    c.x.push_back(ux(rng));
    c.y.push_back(uy(rng));
    c.v.push_back(std::sin(c.x.back() * 0.3) * 5 + c.y.back() * 0.1);
  }
  dw::tin::TinOptions o;
  o.num_threads = 1;
  c.tri = dw::tin::triangulate(c.x.data(), c.y.data(), n, o).triangles;
  return c;
}

/// Value at p from the first triangle whose closed area holds p; NaN when none does.
double bruteForce(const Cloud& c, double px, double py, std::size_t* which = nullptr) {
  for (std::size_t t = 0; t < c.tri.size() / 3; ++t) {
    const index_t a = c.tri[3 * t], b = c.tri[3 * t + 1], d = c.tri[3 * t + 2];
    using dw::pred::orient2d;
    if (orient2d(c.x[a], c.y[a], c.x[b], c.y[b], px, py) < 0 ||
        orient2d(c.x[b], c.y[b], c.x[d], c.y[d], px, py) < 0 ||
        orient2d(c.x[d], c.y[d], c.x[a], c.y[a], px, py) < 0)
      continue;
    const double det = (c.x[b] - c.x[a]) * (c.y[d] - c.y[a]) - (c.y[b] - c.y[a]) * (c.x[d] - c.x[a]);
    const double wb = ((px - c.x[a]) * (c.y[d] - c.y[a]) - (py - c.y[a]) * (c.x[d] - c.x[a])) / det;
    const double wd = ((c.x[b] - c.x[a]) * (py - c.y[a]) - (c.y[b] - c.y[a]) * (px - c.x[a])) / det;
    if (which) *which = t;
    return c.v[a] * (1 - wb - wd) + c.v[b] * wb + c.v[d] * wd;
  }
  return NAN;
}

RasterGrid grid(double west, double north, double cell, std::size_t cols, std::size_t rows) {
  RasterGrid g;
  g.west = west;
  g.north = north;
  g.cell = cell;
  g.cols = cols;
  g.rows = rows;
  return g;
}

TEST(TinRaster, EveryCentreTakesTheValueOfTheTriangleHoldingItAndNodataOutsideTheHull) {
  const Cloud c = randomCloud(2000, 5, 100, 60);
  const RasterGrid g = grid(-3.3, 62.1, 0.7, 153, 94);  // wider than the points: cells outside the hull
  dw::dem::TinRasterOptions o;
  o.nodata = -1234;
  dw::dem::TinRasterStats s;
  const auto r = dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, o, &s);
  std::size_t inside = 0, outside = 0;
  for (std::size_t row = 0; row < g.rows; ++row)
    for (std::size_t col = 0; col < g.cols; ++col) {
      const double want = bruteForce(c, g.centreX(col), g.centreY(row));
      const double got = r[row * g.cols + col];
      if (std::isnan(want)) {
        EXPECT_EQ(got, -1234) << row << " " << col;
        ++outside;
      } else {
        EXPECT_NEAR(got, want, 1e-9) << row << " " << col;
        ++inside;
      }
    }
  EXPECT_EQ(s.cells_set, inside);
  EXPECT_GT(outside, 1000u);
  EXPECT_GT(inside, 10000u);
}

TEST(TinRaster, CentresOnSharedEdgesAndVerticesAreOwnedOnceOnALattice) {
  // Points on an integer lattice (every square cocircular), centres on every vertex and on the middle
  // of every horizontal and vertical edge: no hole may open inside the hull, and a plane is exact.
  Cloud c;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 12; ++j) {
      c.x.push_back(i);
      c.y.push_back(j);
      c.v.push_back(3 * i - 2 * j + 7);
    }
  c.tri = dw::tin::triangulate(c.x.data(), c.y.data(), c.x.size()).triangles;
  const RasterGrid g = grid(-0.25, 12.25, 0.5, 41, 25);  // centres at multiples of 0.5
  dw::dem::TinRasterStats s;
  const auto r = dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, {}, &s);
  std::size_t interior = 0;
  for (std::size_t row = 0; row < g.rows; ++row)
    for (std::size_t col = 0; col < g.cols; ++col) {
      const double px = g.centreX(col), py = g.centreY(row);
      const double got = r[row * g.cols + col];
      if (px > 0 && px < 20 && py > 0 && py < 12) {
        ++interior;
        ASSERT_NE(got, -9999) << "hole at " << px << " " << py;
        EXPECT_NEAR(got, 3 * px - 2 * py + 7, 1e-12);
      } else if (got != -9999) {
        EXPECT_NEAR(got, 3 * px - 2 * py + 7, 1e-12);  // hull boundary: owned by the rule or not
      }
    }
  EXPECT_EQ(interior, 39u * 23u);
  EXPECT_GE(s.cells_set, interior);
}

TEST(TinRaster, RasterIsBitIdenticalForThreadsWindowsAndTriangleOrder) {
  Cloud c = randomCloud(30000, 9, 300, 200);
  const RasterGrid g = grid(0, 200, 0.37, 811, 541);
  dw::dem::TinRasterOptions one;
  one.num_threads = 1;
  const auto ref = dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, one);
  dw::dem::TinRasterOptions three;
  three.num_threads = 3;
  auto same = [&](const std::vector<double>& r) {
    return std::memcmp(r.data(), ref.data(), ref.size() * 8) == 0;
  };
  EXPECT_TRUE(same(dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, three)));
  // Row windows of uneven heights, written one after the other.
  std::vector<double> windows(g.size());
  const std::size_t cuts[] = {0, 1, 77, 78, 300, 541};
  for (int k = 0; k + 1 < 6; ++k)
    dw::dem::rasterizeTinRows(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri.data(), c.tri.size(), g,
                              cuts[k], cuts[k + 1], windows.data() + cuts[k] * g.cols, three);
  EXPECT_TRUE(same(windows));
  // Shuffled triangles, each rotated.
  std::vector<std::array<index_t, 3>> t(c.tri.size() / 3);
  for (std::size_t k = 0; k < t.size(); ++k) {
    const int rot = int(k % 3);
    for (int j = 0; j < 3; ++j) t[k][j] = c.tri[3 * k + (j + rot) % 3];
  }
  std::shuffle(t.begin(), t.end(), std::mt19937(4));
  for (std::size_t k = 0; k < t.size(); ++k)
    for (int j = 0; j < 3; ++j) c.tri[3 * k + j] = t[k][j];
  EXPECT_TRUE(same(dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, three)));
}

TEST(TinRaster, MaxEdgeKillsTheCellsOfLongTrianglesOnly) {
  // Two dense patches with an empty gap between them: the triangles bridging it are long.
  Cloud c;
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 3000; ++i) {
    const double x = u(rng) * 40, y = u(rng) * 40;
    c.x.push_back(x < 20 ? x : x + 30);  // gap 20 <= x < 50
    c.y.push_back(y);
    c.v.push_back(x + y);
  }
  c.tri = dw::tin::triangulate(c.x.data(), c.y.data(), c.x.size()).triangles;
  const RasterGrid g = grid(0, 40, 0.5, 140, 80);
  dw::dem::TinRasterOptions o;
  const auto all = dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, o);
  o.max_edge = 5;
  dw::dem::TinRasterStats s;
  const auto cut = dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri, g, o, &s);
  EXPECT_GT(s.triangles_killed, 0u);
  std::size_t killed_cells = 0;
  for (std::size_t row = 0; row < g.rows; ++row)
    for (std::size_t col = 0; col < g.cols; ++col) {
      const std::size_t i = row * g.cols + col;
      std::size_t t = 0;
      const double want = bruteForce(c, g.centreX(col), g.centreY(row), &t);
      if (std::isnan(want)) continue;
      double longest = 0;
      for (int j = 0; j < 3; ++j) {
        const index_t a = c.tri[3 * t + j], b = c.tri[3 * t + (j + 1) % 3];
        longest = std::max(longest, std::hypot(c.x[a] - c.x[b], c.y[a] - c.y[b]));
      }
      // Random points put no centre on an edge, so the brute-force triangle is the owner.
      ASSERT_NE(all[i], -9999);
      EXPECT_EQ(cut[i] == -9999, longest > 5) << row << " " << col << " longest edge " << longest;
      if (cut[i] == -9999)
        ++killed_cells;
      else
        EXPECT_EQ(cut[i], all[i]);
    }
  EXPECT_GE(killed_cells, 56u * 70u);  // most of the gap's 28 m x 40 m
}

TEST(TinRaster, BadInputIsRefused) {
  const Cloud c = randomCloud(100, 1, 10, 10);
  const RasterGrid g = grid(0, 10, 1, 10, 10);
  std::vector<double> out(100);
  EXPECT_THROW(dw::dem::rasterizeTinRows(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri.data(),
                                         c.tri.size(), g, 5, 11, out.data()),
               dw::Error);
  EXPECT_THROW(dw::dem::rasterizeTinRows(c.x.data(), c.y.data(), c.v.data(), 50, c.tri.data(), c.tri.size(),
                                         g, 0, 10, out.data()),
               dw::Error);
  EXPECT_THROW(dw::dem::rasterizeTinRows(c.x.data(), c.y.data(), c.v.data(), c.x.size(), c.tri.data(), 4, g,
                                         0, 10, out.data()),
               dw::Error);
}

TEST(RasterGrid, BoundsGiveCeilCellsAndAlignedGridsCoverThePoints) {
  const RasterGrid g = dw::dem::gridFromBounds(10, 20, 15.5, 23, 1);
  EXPECT_EQ(g.cols, 6u);
  EXPECT_EQ(g.rows, 3u);
  EXPECT_EQ(g.west, 10);
  EXPECT_EQ(g.north, 23);
  EXPECT_EQ(g.centreX(0), 10.5);
  EXPECT_EQ(g.centreY(2), 20.5);
  const RasterGrid a = dw::dem::alignedGridCovering(636001.3, 4202000.2, 636999.9, 4202500.01, 2);
  EXPECT_EQ(a.west, 636000);
  EXPECT_EQ(a.north, 4202502);
  EXPECT_GE(a.east(), 636999.9);
  EXPECT_LE(a.south(), 4202000.2);
  EXPECT_EQ(std::fmod(a.south(), 2.0), 0.0);
  EXPECT_THROW(dw::dem::gridFromBounds(0, 0, 1, 1, 0), dw::Error);
  EXPECT_THROW(dw::dem::gridFromBounds(0, 0, -1, 1, 1), dw::Error);
  EXPECT_THROW(dw::dem::gridFromBounds(0, 0, NAN, 1, 1), dw::Error);
  EXPECT_THROW(dw::dem::gridFromBounds(0, 0, 1e300, 1, 1e-10), dw::Error);
}

}  // namespace
