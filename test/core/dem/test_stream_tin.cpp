/// \file test_stream_tin.cpp
/// \brief The streaming TIN and raster against the in-memory ones: the final triangles handed on strip
/// after strip are exactly the whole cloud's TIN (as canonical sets), and the rows written as they
/// become final are the in-memory raster bit for bit, for strips of many heights (one point row wide,
/// empty), duplicates, straight tile edges, UTM-sized integers and max-edge kill.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/dem/stream_frontier.h"
#include "core/dem/stream_raster.h"
#include "core/dem/stream_tin.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

using dw::index_t;
using Triangle = std::array<std::uint64_t, 3>;

Triangle canonical(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  Triangle t = {a, b, c};
  std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());  // keeps the orientation
  return t;
}

struct Cloud {
  std::vector<double> x, y, z;
};

/// Integer coordinates (LAS units) on a grid of `w` x `h` units around (x0, y0): a square tile with
/// straight edges (points on them), exact duplicates with other heights, an empty lake.
Cloud makeCloud(std::size_t n, double x0, double y0, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> ux(0, 3000), uy(0, 2000);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = ux(rng), b = uy(rng);
    if (std::hypot(a - 1500, b - 900) < 300) continue;
    c.x.push_back(x0 + a), c.y.push_back(y0 + b);
    c.z.push_back(std::sin(a / 300.0) * 50 + b / 40.0 + double(i % 7));
    if (i % 97 == 0) c.x.push_back(x0 + a), c.y.push_back(y0 + b), c.z.push_back(-1.0 * double(i));
  }
  return c;
}

struct Streamed {
  std::vector<Triangle> triangles;
  std::vector<double> raster;
  std::size_t max_resident = 0;
};

/// Strips between the seams (descending; a point goes to the first strip whose seam is <= its y).
Streamed stream(const Cloud& c, const std::vector<double>& seams, const dw::dem::RasterGrid& g,
                double max_edge) {
  const auto hull = dw::dem::detail::convexHull(c.x.data(), c.y.data(), c.x.size());
  Streamed out;
  out.raster.assign(g.size(), 12345.0);
  std::size_t next_row = 0;
  dw::dem::detail::StreamRaster raster(
      g, hull, max_edge, -9999, [&](std::size_t r, std::size_t k, const double* v) {
        EXPECT_EQ(r, next_row);
        std::memcpy(out.raster.data() + r * g.cols, v, k * g.cols * sizeof(double));
        next_row = r + k;
      });
  dw::dem::detail::StreamTin tin(&hull, 2);
  for (std::size_t s = 0; s <= seams.size(); ++s) {
    const double hi = s == 0 ? HUGE_VAL : seams[s - 1], lo = s == seams.size() ? -HUGE_VAL : seams[s];
    dw::dem::detail::StripPoints strip;
    for (std::size_t i = 0; i < c.x.size(); ++i)
      if (c.y[i] >= lo && c.y[i] < hi) {
        strip.x.push_back(c.x[i]), strip.y.push_back(c.y[i]), strip.value.push_back(c.z[i]);
        strip.index.push_back(i);
      }
    tin.addStrip(std::move(strip), lo,
                 [&](const dw::dem::detail::StripPoints& p, const std::vector<index_t>& t) {
                   for (std::size_t k = 0; k < t.size(); k += 3)
                     out.triangles.push_back(canonical(p.index[t[k]], p.index[t[k + 1]], p.index[t[k + 2]]));
                   raster.add(p, t);
                 });
    raster.flush(s == seams.size());
    out.max_resident = std::max(out.max_resident, tin.residentPoints());
  }
  EXPECT_EQ(next_row, g.rows);
  return out;
}

void expectSameAsInMemory(const Cloud& c, const std::vector<double>& seams, double max_edge) {
  dw::tin::TinOptions to;
  to.num_threads = 2;
  const auto whole = dw::tin::triangulate(c.x.data(), c.y.data(), c.x.size(), to);
  std::vector<Triangle> expected;
  for (std::size_t k = 0; k < whole.triangles.size(); k += 3)
    expected.push_back(canonical(whole.triangles[k], whole.triangles[k + 1], whole.triangles[k + 2]));
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  for (std::size_t i = 0; i < c.x.size(); ++i) {
    lo[0] = std::min(lo[0], c.x[i]), hi[0] = std::max(hi[0], c.x[i]);
    lo[1] = std::min(lo[1], c.y[i]), hi[1] = std::max(hi[1], c.y[i]);
  }
  // A grid wider than the points (rows of nodata north and south) with a cell of 7 units.
  const auto g = dw::dem::gridFromBounds(lo[0] - 30, lo[1] - 50, hi[0] + 20, hi[1] + 40, 7.0);
  dw::dem::TinRasterOptions ro;
  ro.max_edge = max_edge;
  ro.num_threads = 2;
  const auto in_memory =
      dw::dem::rasterizeTin(c.x.data(), c.y.data(), c.z.data(), c.x.size(), whole.triangles, g, ro);

  Streamed s = stream(c, seams, g, max_edge);
  std::sort(expected.begin(), expected.end());
  std::sort(s.triangles.begin(), s.triangles.end());
  EXPECT_EQ(s.triangles.size(), expected.size());
  EXPECT_TRUE(s.triangles == expected) << "the streamed TIN differs from the in-memory TIN";
  ASSERT_EQ(s.raster.size(), in_memory.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < in_memory.size(); ++i)
    differ += std::memcmp(&s.raster[i], &in_memory[i], sizeof(double)) != 0;
  EXPECT_EQ(differ, 0u) << "cells differing from the in-memory raster";
  if (seams.size() > 3) {
    EXPECT_LT(s.max_resident, c.x.size() / 2);
  }
}

std::vector<double> evenSeams(double y0, double height, unsigned strips) {
  std::vector<double> s;
  for (unsigned k = 1; k < strips; ++k) s.push_back(y0 + height * double(strips - k) / strips);
  return s;
}

TEST(StreamTin, StreamedTinAndRasterEqualTheInMemoryOnesForManyStripHeights) {
  const Cloud c = makeCloud(20000, 0, 0, 1);
  for (unsigned strips : {1u, 2u, 7u, 25u}) {
    SCOPED_TRACE(strips);
    expectSameAsInMemory(c, evenSeams(0, 2000, strips), 0);
  }
}

TEST(StreamTin, OnePointRowStripsEmptyStripsAndMaxEdgeGiveTheInMemoryRaster) {
  const Cloud c = makeCloud(20000, 0, 0, 2);
  // Seams one unit apart give strips holding a single row of integer y; others hold none (north of the
  // data, inside the lake's latitude band only at its rim, south of the data).
  std::vector<double> seams = {3000, 2500, 2001};
  for (double y = 1500; y >= 1490; y -= 1) seams.push_back(y);
  for (double y = 1200.5; y > 1200; y -= 0.25) seams.push_back(y);  // empty: no integer between
  seams.push_back(800), seams.push_back(0), seams.push_back(-10);
  expectSameAsInMemory(c, seams, 0);
  expectSameAsInMemory(c, evenSeams(0, 2000, 9), 40);
}

TEST(StreamTin, UtmSizedIntegersStreamLikeTheInMemoryTin) {
  // Centimetre integers of a UTM tile: x ~ 5e7, y ~ 5.3e8.
  const Cloud c = makeCloud(15000, 51234500, 532100000, 3);
  expectSameAsInMemory(c, evenSeams(532100000, 2000, 6), 0);
}

TEST(StreamTin, CollinearFirstStripsKeepTheirPoints) {
  Cloud c;
  for (int i = 0; i < 50; ++i) c.x.push_back(i), c.y.push_back(100), c.z.push_back(i);  // one line first
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> u(0, 99);
  for (int i = 0; i < 3000; ++i) c.x.push_back(u(rng)), c.y.push_back(u(rng) * 0.99), c.z.push_back(i % 13);
  expectSameAsInMemory(c, {100.5, 99.5, 60, 30}, 0);
}

}  // namespace
