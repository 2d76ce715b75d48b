// Self queries (every vertex asks for its own k nearest, the expansion started at that vertex, as
// pcl::search::DelaunayWalk::nearestKSearch(index, k) runs them) equal brute force, and kNN and radius
// stay exact on clouds whose Delaunay graphs mix very short and very long edges (LiDAR-like scan
// lines), where the expansion's edge cut decides most of the work.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "core/brute_force.h"

using namespace dw;
using namespace dw_test;

namespace {

std::shared_ptr<DelaunayGraph> build(const std::vector<double>& xyz) {
  return std::make_shared<DelaunayGraph>(
      buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3)));
}

/// The tolerance's "scale2" for a graph: tight enough that a wrong neighbour among scan-line points a
/// few millimetres apart shows. Both sides round the same float coordinates, so they differ only by
/// the float rounding of one squared distance (relative 1e-7 of |q| |x|).
float scaleOf(const DelaunayGraph& g) {
  float ext = 0.f;
  for (const Vec3f& p : g.points) ext = std::max({ext, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  return std::max(1e-6f, 1e-3f * ext * ext);
}

/// knn() from every vertex against brute force from that vertex.
void checkSelfKnn(const std::vector<double>& xyz, std::size_t k, const std::string& name) {
  SCOPED_TRACE(name + ", k=" + std::to_string(k));
  const auto g = build(xyz);
  NeighbourSearch search(g);
  const std::size_t expect = std::min(k, g->originals.size());
  const float scale2 = scaleOf(*g);
  std::vector<index_t> idx;
  std::vector<float> d2;
  for (index_t v = 0; v < g->numVertices(); ++v) {
    const Vec3f q = g->points[v];
    const auto all = allDistances(*g, xyz, q);
    search.knn(q, k, WalkResult{v, 0.f, 0}, idx, d2);
    ASSERT_EQ(idx.size(), expect) << "vertex " << v;
    std::set<index_t> distinct(idx.begin(), idx.end());
    ASSERT_EQ(distinct.size(), idx.size()) << "vertex " << v << ": duplicate indices";
    for (std::size_t r = 0; r < idx.size(); ++r) {
      ASSERT_NEAR(d2[r], all[r], tol(all[r], scale2)) << "vertex " << v << " rank " << r;
      const double* p = &xyz[3 * idx[r]];
      ASSERT_NEAR(d2[r], squaredDistance(q, g->toLocal(p[0], p[1], p[2])), tol(d2[r], scale2));
    }
    if (!idx.empty()) {
      EXPECT_EQ(d2[0], 0.f) << "a self query finds its own vertex first";
    }
  }
}

/// Scan lines: points dense along rings, rings far apart, as a spinning LiDAR samples the ground.
std::vector<double> scanLines(std::size_t rings, std::size_t per_ring, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-1e-3, 1e-3);
  std::vector<double> xyz;
  for (std::size_t r = 0; r < rings; ++r) {
    const double radius = 5.0 + 1.5 * double(r * r) / double(rings);
    for (std::size_t i = 0; i < per_ring; ++i) {
      const double a = 6.283185307179586 * double(i) / double(per_ring);
      xyz.insert(xyz.end(), {radius * std::cos(a) + jitter(rng), radius * std::sin(a) + jitter(rng),
                             -1.7 + 0.02 * std::sin(3 * a) + jitter(rng)});
    }
  }
  for (std::size_t i = 0; i < 300; ++i)  // a wall: vertical structure across the rings
    xyz.insert(xyz.end(), {8.0 + jitter(rng), -2.0 + 0.0133 * double(i), -1.7 + 0.01 * double(i % 97)});
  return xyz;
}

}  // namespace

TEST(SelfKnn, EqualsBruteForceOnUniformPoints) {
  const auto xyz = uniformCube(1000, 21);
  for (std::size_t k : {std::size_t(1), std::size_t(8), std::size_t(16), std::size_t(33)})
    checkSelfKnn(xyz, k, "uniform 1000");
}

TEST(SelfKnn, EqualsBruteForceOnScanLines) {
  checkSelfKnn(scanLines(12, 150, 3), 16, "scan lines");
}

TEST(SelfKnn, DuplicatesCountAsInputs) {
  auto xyz = uniformCube(400, 22);
  for (std::size_t i = 0; i < 400; i += 5) {  // one point in five twice, one in fifteen three times
    xyz.insert(xyz.end(), {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
    if (i % 15 == 0) xyz.insert(xyz.end(), {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
  }
  xyz.insert(xyz.end(), {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0});
  for (std::size_t k : {std::size_t(2), std::size_t(9), std::size_t(24)}) checkSelfKnn(xyz, k, "duplicates");
}

TEST(SelfKnn, DegenerateAndTinySets) {
  auto plane = uniformCube(600, 23);
  for (std::size_t i = 0; i < plane.size(); i += 3) plane[i + 2] = 0.5 * plane[i] - 0.25 * plane[i + 1];
  checkSelfKnn(plane, 12, "plane");
  std::vector<double> line;
  for (int i = 0; i < 200; ++i) line.insert(line.end(), {0.01 * (i * 61 % 200), 1.0, 2.0});
  checkSelfKnn(line, 7, "line");
  std::vector<double> grid;  // exact ties everywhere
  for (int x = 0; x < 9; ++x)
    for (int y = 0; y < 9; ++y)
      for (int z = 0; z < 5; ++z) grid.insert(grid.end(), {0.5 * x, 0.5 * y, 0.5 * z});
  checkSelfKnn(grid, 10, "grid");
  for (std::size_t n = 1; n <= 6; ++n)
    checkSelfKnn(uniformCube(n, 40 + unsigned(n)), 4, "n=" + std::to_string(n));
}

TEST(Expansion, KnnAndRadiusExactOnScanLines) {
  // Off-vertex queries too: the edge cut must hold for a query anywhere, not only on a vertex.
  const auto xyz = scanLines(10, 120, 5);
  const auto g = build(xyz);
  NeighbourSearch search(g);
  const float scale2 = scaleOf(*g);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-14, 14);
  std::vector<index_t> idx;
  std::vector<float> d2;
  for (int qn = 0; qn < 300; ++qn) {
    const Vec3f q = g->toLocal(u(rng), u(rng), qn % 2 ? -1.7 : 0.1 * u(rng));
    const auto all = allDistances(*g, xyz, q);
    const WalkResult nn = search.nearest(q);
    for (std::size_t k : {std::size_t(4), std::size_t(16), std::size_t(40)}) {
      search.knn(q, k, nn, idx, d2);
      ASSERT_EQ(idx.size(), k);
      for (std::size_t r = 0; r < k; ++r) ASSERT_NEAR(d2[r], all[r], tol(all[r], scale2)) << "k " << k;
    }
    for (double rad : {0.05, 0.4, 2.0}) {
      const float r2 = float(rad * rad);
      search.radius(q, r2, nn, idx, d2);
      const std::size_t lo = std::lower_bound(all.begin(), all.end(), r2 - tol(r2, scale2)) - all.begin();
      const std::size_t hi = std::upper_bound(all.begin(), all.end(), r2 + tol(r2, scale2)) - all.begin();
      ASSERT_GE(idx.size(), lo) << "radius " << rad;
      ASSERT_LE(idx.size(), hi) << "radius " << rad;
      for (std::size_t r = 0; r < idx.size(); ++r) ASSERT_NEAR(d2[r], all[r], tol(all[r], scale2));
      search.radius(q, r2, nn, idx, d2, 5);
      if (lo == hi)
        ASSERT_EQ(idx.size(), std::min<std::size_t>(5, lo)) << "radius " << rad << ", max_nn 5";
      else
        ASSERT_LE(idx.size(), 5u);
      for (std::size_t r = 0; r < idx.size(); ++r) ASSERT_NEAR(d2[r], all[r], tol(all[r], scale2));
    }
  }
}
