// buildDelaunayGraph on hostile clouds: every case either gives a graph on which the search equals
// brute force, or a clear dw::Error; none crashes, hangs or drops points silently.
#include <gtest/gtest.h>

#include <limits>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "robustness_util.h"

using namespace dw;
using namespace dw_robust;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

/// Builds, validates, checks the finite-point bookkeeping and the search against brute force, and
/// round-trips the graph through a file image.
void expectExact(const std::vector<double>& xyz, const std::string& name, std::size_t num_queries = 40) {
  SCOPED_TRACE(name);
  const std::size_t n = xyz.size() / 3;
  DelaunayGraph::Ptr g;
  ASSERT_NO_THROW(
      g = std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), n))));
  ASSERT_NO_THROW(g->validate());
  std::size_t finite = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool ok = finitePoint(&xyz[3 * i]);
    finite += ok;
    EXPECT_EQ(ok, g->input_to_vertex[i] != kInvalidIndex) << "input " << i;
  }
  EXPECT_EQ(g->originals.size(), finite) << "finite points dropped or invented";
  EXPECT_EQ(checkAgainstBruteForce(xyz, g, mixedQueries(*g, xyz, num_queries, 17)), "");
  if (g->numVertices() == 0) return;  // the empty file image has its own test (GraphFileHostile.EmptyGraph)
  const auto bytes = serializeGraph(*g);
  EXPECT_NO_THROW(deserializeGraph(bytes.data(), bytes.size()));
}

std::vector<double> repeatPoint(double x, double y, double z, std::size_t n) {
  std::vector<double> v;
  for (std::size_t i = 0; i < n; ++i) v.insert(v.end(), {x, y, z});
  return v;
}

}  // namespace

TEST(BuildBadInput, EmptyAndNullViews) {
  expectExact({}, "no points");
  EXPECT_NO_THROW(buildDelaunayGraph(PointView::fromFloat(nullptr, 0)));
  EXPECT_THROW(buildDelaunayGraph(PointView::fromFloat(nullptr, 10)), Error) << "null data with a size";
  EXPECT_THROW(buildDelaunayGraph(PointView::fromDouble(nullptr, 1)), Error);
}

TEST(BuildBadInput, OnlyNonFinitePoints) {
  expectExact({kNaN, kNaN, kNaN}, "one NaN");
  expectExact({kInf, 0, 0, 0, -kInf, 0, 0, 0, kNaN, kInf, kInf, kInf}, "Inf in every axis");
  expectExact(std::vector<double>(3 * 1000, kNaN), "1000 NaN");
}

TEST(BuildBadInput, NonFiniteMixedIn) {
  auto xyz = randomCloud(600, 1);
  for (std::size_t i = 0; i < xyz.size(); i += 21) xyz[i + (i / 21) % 3] = (i % 2) ? kNaN : -kInf;
  expectExact(xyz, "every 7th point has one NaN/Inf coordinate");
  // Largest finite doubles are finite: they must be kept (and are far apart, see HugeCoordinates).
  xyz = randomCloud(50, 2);
  xyz.insert(xyz.end(), {kNaN, 1e308, 0});
  expectExact(xyz, "NaN beside 1e308");
}

TEST(BuildBadInput, Duplicates) {
  expectExact(repeatPoint(3, -4, 5, 1), "one point");
  expectExact(repeatPoint(3, -4, 5, 2000), "2000 copies of one point");
  auto two = repeatPoint(0, 0, 0, 300);
  const auto other = repeatPoint(1, 1, 1, 300);
  two.insert(two.end(), other.begin(), other.end());
  expectExact(two, "two points, 300 copies each");
  // Every point duplicated 1..4 times, interleaved, so the originals runs are long and unordered.
  const auto base = randomCloud(300, 3);
  std::vector<double> xyz;
  for (int rep = 0; rep < 4; ++rep)
    for (std::size_t i = 0; i < base.size(); i += 3)
      if (rep <= int(i / 3) % 4) xyz.insert(xyz.end(), {base[i], base[i + 1], base[i + 2]});
  expectExact(xyz, "interleaved duplicates");
  // Distinct doubles that round to the same float collapse: the search answers in float.
  std::vector<double> near_dups;
  for (int i = 0; i < 200; ++i)
    near_dups.insert(near_dups.end(), {1.0 + i * 1e-12, 2.0, 3.0 + (i % 20) * 0.1});
  expectExact(near_dups, "doubles equal in float");
}

TEST(BuildBadInput, DegenerateGeometry) {
  expectExact({0, 0, 0, 1, 0, 0}, "two points");
  expectExact({0, 0, 0, 1, 0, 0, 2, 0, 0}, "three collinear");
  expectExact({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, "square");
  std::vector<double> line, plane, cube, circle, two_planes;
  for (int i = 0; i < 500; ++i) line.insert(line.end(), {i * 0.5, i * 0.5, i * 0.5});
  expectExact(line, "diagonal line, evenly spaced");
  for (int x = 0; x < 30; ++x)
    for (int y = 0; y < 30; ++y) plane.insert(plane.end(), {double(x), double(y), 7.0});
  expectExact(plane, "regular grid in a plane (every square cocircular)");
  for (int x = 0; x < 9; ++x)
    for (int y = 0; y < 9; ++y)
      for (int z = 0; z < 9; ++z) cube.insert(cube.end(), {double(x), double(y), double(z)});
  expectExact(cube, "integer lattice (every cube cospherical)");
  for (int i = 0; i < 360; ++i)
    circle.insert(circle.end(), {std::cos(i * M_PI / 180), std::sin(i * M_PI / 180), 0.0});
  expectExact(circle, "points on one circle");
  for (int x = 0; x < 20; ++x)
    for (int y = 0; y < 20; ++y) {
      two_planes.insert(two_planes.end(), {double(x), double(y), 0.0});
      two_planes.insert(two_planes.end(), {double(x), double(y), 1.0});
    }
  expectExact(two_planes, "two parallel grids");
  // A plane plus one point barely off it: 3D, but nearly flat.
  auto almost = plane;
  almost.insert(almost.end(), {14.5, 14.5, 7.0 + 1e-7});
  expectExact(almost, "grid plus one point 1e-7 off the plane");
}

TEST(BuildBadInput, HugeCoordinatesAndExtents) {
  // Georeferenced (UTM / ECEF) offsets: the double origin keeps float coordinates fine.
  for (double offset : {6.0e6, 4.0e7, 1.0e12}) {
    auto xyz = randomCloud(400, 4, 0.0, 100.0);
    for (double& v : xyz) v += offset;
    expectExact(xyz, "offset " + std::to_string(offset));
  }
  // Extents whose squared distances still fit in float.
  for (double ext : {1e6, 1e12, 1e17})
    expectExact(randomCloud(300, 5, -ext, ext), "extent " + std::to_string(ext));
  // Tiny extents, down to where float subnormals begin.
  for (double ext : {1e-6, 1e-15})
    expectExact(randomCloud(300, 6, -ext, ext), "extent " + std::to_string(ext));
}

TEST(BuildBadInput, ExtentsBeyondFloatRangeGiveAClearError) {
  // Beyond ~1.8e19 squared distances overflow float and every comparison would tie; beyond ~1.7e38
  // even the edge vectors overflow. Such a cloud must be refused with dw::Error (or still answer
  // exactly), never answered wrongly or turned into a graph that fails its own validate().
  // BUG (src/core/graph_builder.cpp / assembleEdges): with points near +-3e38 the build succeeds and
  // returns a graph whose edge records are not finite ("invalid graph: non-finite edge record" from
  // validate(); saveGraph output then fails to load). Found by fuzz/fuzz_search.
  for (std::size_t n : {3, 100})  // 3 + 2 points take the complete-graph path, 102 a Delaunay builder
    for (double far : {1e30, 3e38}) {
      std::vector<double> xyz = randomCloud(n, 7);
      xyz.insert(xyz.end(), {far, 0, 0, -far, 1, 0});
      SCOPED_TRACE(std::to_string(n) + " points and two at +-" + std::to_string(far));
      DelaunayGraph::Ptr g;
      try {
        g = std::make_shared<DelaunayGraph>(
            buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3)));
      } catch (const Error&) {
        continue;  // a clear refusal is acceptable
      }
      ASSERT_NO_THROW(g->validate());
      EXPECT_EQ(checkAgainstBruteForce(xyz, g, mixedQueries(*g, xyz, 30, 9)), "");
    }
}

TEST(BuildBadInput, IntegerGridCaseFoundByFuzzer) {
  // BUG (3D Delaunay builder, BuilderType::Auto = the incremental kernel when built): on these 67
  // integer points (64 distinct; many cospherical quintuples) the walk from the Zero start stops at
  // a vertex at squared distance 14.75 from (2.5, 2.5, 2.5) while the nearest point is at 12.75, so
  // the graph misses a Delaunay edge. Found by fuzz/fuzz_search (mode 0, builder auto).
  const std::vector<double> xyz{
      6,  0,  0,  4,  -3, -2, -4, -6, -6, 0,  0,  4,  -6, 6,  3,  0,  2,  -2, -4, -6, -3, 4,  6,  -1, -4, 6,
      -3, 5,  -3, -2, -5, -5, -6, 4,  3,  -3, 3,  -4, 2,  -4, -6, 5,  -2, -5, 0,  2,  0,  -1, 3,  2,  -6, -4,
      4,  4,  0,  0,  4,  -3, 4,  1,  -5, -3, -6, -1, -6, -6, -3, -4, -5, 4,  4,  -1, 3,  -1, -3, 3,  -2, 3,
      5,  4,  0,  4,  -6, 3,  6,  -3, 1,  3,  6,  -2, -3, -1, 4,  0,  1,  -5, 0,  -1, -3, -6, 2,  -5, -2, 5,
      -4, 3,  -5, -1, -3, 6,  4,  0,  -2, -2, -3, 2,  5,  -2, -5, 5,  2,  1,  -1, 3,  0,  -2, -4, 3,  3,  -5,
      3,  -4, -6, 4,  -2, -1, 1,  0,  0,  -3, -4, -6, -5, -4, 6,  0,  0,  4,  -3, -2, -4, -6, -6, 0,  0,  4,
      -6, 6,  3,  0,  2,  -1, -4, -6, 4,  -2, -5, -5, -6, 4,  3,  -3, 3,  -4, 2,  -4, -6, 5,  -2, -5, 0,  2,
      0,  -1, 3,  2,  -6, -4, -5, -6, -6, -6, -3, -6, -6, -6, -3, -6, -6, -6, -5};
  for (BuilderType b : {BuilderType::Auto, BuilderType::Qhull, BuilderType::Incremental}) {
    if (b == BuilderType::Qhull && !haveQhullBuilder()) continue;
    if (b == BuilderType::Incremental && !haveIncrementalBuilder()) continue;
    SCOPED_TRACE(b == BuilderType::Auto ? "auto" : b == BuilderType::Qhull ? "qhull" : "incremental");
    BuildOptions o;
    o.builder = b;
    auto g = std::make_shared<DelaunayGraph>(
        buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3), o));
    std::vector<Vec3f> queries{g->toLocal(2.5, 2.5, 2.5)};
    const auto more = mixedQueries(*g, xyz, 200, 23);
    queries.insert(queries.end(), more.begin(), more.end());
    for (int x = -6; x <= 6; x += 2)
      for (int y = -6; y <= 6; y += 2)
        for (int z = -6; z <= 6; z += 2) queries.push_back(g->toLocal(x + 0.5, y + 0.5, z + 0.5));
    EXPECT_EQ(checkAgainstBruteForce(xyz, g, queries), "");
  }
}

TEST(BuildBadInput, StridedFloatViewWithPadding) {
  // PCL's PointXYZ is 16 bytes (x y z pad); a view with a padding stride must read only x, y, z.
  const auto base = randomCloud(500, 8);
  std::vector<float> padded;
  std::vector<double> as_double;
  for (std::size_t i = 0; i < base.size(); i += 3) {
    padded.insert(padded.end(), {float(base[i]), float(base[i + 1]), float(base[i + 2]), std::nanf("")});
    as_double.insert(as_double.end(), {float(base[i]), float(base[i + 1]), float(base[i + 2])});
  }
  const auto g = buildDelaunayGraph(PointView::fromFloat(padded.data(), 500, 16));
  EXPECT_EQ(g.originals.size(), 500u) << "the NaN padding must not be read as a coordinate";
  expectExact(as_double, "float cloud");
}
