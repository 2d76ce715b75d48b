// Exactness of pcl::search::DelaunayWalk against brute force in PCL's metric: NN, kNN (k = 1..32 and
// k > n), radius (0 .. huge, with and without max_nn), every start strategy, on synthetic, degenerate
// and real clouds.
#include <pcl/search/kdtree.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "search_test_util.h"

using namespace dw_pcl_test;

namespace {

const dw::StartStrategy kStrategies[] = {dw::StartStrategy::Zero, dw::StartStrategy::KdAnn,
                                         dw::StartStrategy::Pnn, dw::StartStrategy::PnnOptimized};

/// Median nearest-neighbour spacing of a few points: the scale the radii are chosen from.
float typicalSpacing(const Cloud& c) {
  std::vector<float> s;
  for (std::size_t i = 0; i < c.size() && s.size() < 25; i += std::max<std::size_t>(1, c.size() / 25)) {
    if (!finite(c[i])) continue;
    const Ref r = bruteAll(c, c[i]);
    for (std::size_t k = 0; k < r.d2.size(); ++k)
      if (r.d2[k] > 0.f) {
        s.push_back(std::sqrt(r.d2[k]));
        break;
      }
  }
  if (s.empty()) return 1.f;
  std::nth_element(s.begin(), s.begin() + s.size() / 2, s.end());
  return s[s.size() / 2];
}

/// Runs the whole query battery on `cloud` (optionally through an indices subset).
void checkCloud(const Cloud::Ptr& cloud, std::size_t num_queries, const std::string& name,
                const pcl::IndicesPtr& subset = nullptr) {
  pcl::search::DelaunayWalk<pcl::PointXYZ> search;
  search.setInputCloud(cloud, subset);
  std::printf("[ info ] %s: %zu points, graph built in %.2f s\n", name.c_str(), cloud->size(),
              search.getLastBuildSeconds());
  const auto queries = queriesFor(*cloud, num_queries, 7);
  const float s = typicalSpacing(*cloud);
  std::size_t n_finite = 0;
  for (const auto& p : *cloud) n_finite += finite(p) ? 1 : 0;
  const bool small = n_finite <= 3000;
  const int ks[] = {1, 2, 3, 8, 13, 32, static_cast<int>(n_finite) + 5};
  const double radii[] = {0.0, 0.5 * s, 2.0 * s, 6.0 * s, 1e30};
  const unsigned max_nns[] = {0u, 1u, 7u};
  pcl::Indices idx;
  std::vector<float> d2;
  for (dw::StartStrategy strategy : kStrategies) {
    search.setStartStrategy(strategy);
    for (std::size_t qi = 0; qi < queries.size(); ++qi) {
      const pcl::PointXYZ& q = queries[qi];
      const Ref all = bruteAll(*cloud, q, subset.get());
      const std::string where = name + " strategy " + dw::toString(strategy) + " query " + std::to_string(qi);
      for (int k : ks) {
        if (k > 32 && !small) continue;
        Ref ref = all;
        const std::size_t m = std::min<std::size_t>(ref.idx.size(), static_cast<std::size_t>(k));
        ref.idx.resize(m);
        ref.d2.resize(m);
        const int found = search.nearestKSearch(q, k, idx, d2);
        ASSERT_EQ(found, static_cast<int>(m)) << where << " k " << k;
        expectSameNeighbours(*cloud, q, ref, idx, d2, where + " k " + std::to_string(k));
      }
      for (double r : radii) {
        for (unsigned max_nn : max_nns) {
          if (r > 1e29 && max_nn == 0 && !small) continue;
          const Ref ref = radiusFrom(all, r, max_nn);
          const int found = search.radiusSearch(q, r, idx, d2, max_nn);
          ASSERT_EQ(found, static_cast<int>(ref.idx.size())) << where << " r " << r << " max_nn " << max_nn;
          expectSameNeighbours(*cloud, q, ref, idx, d2,
                               where + " r " + std::to_string(r) + " max_nn " + std::to_string(max_nn));
        }
      }
    }
  }
}

Cloud::Ptr fromXyz(const std::vector<std::array<float, 3>>& pts) {
  Cloud::Ptr c(new Cloud);
  for (const auto& p : pts) c->push_back(pcl::PointXYZ(p[0], p[1], p[2]));
  return c;
}

}  // namespace

TEST(DelaunayWalkExactness, UniformRandom) {
  checkCloud(uniformCloud(3000, 1), 60, "uniform");
}

TEST(DelaunayWalkExactness, PointsOnASphereSurface) {
  Cloud::Ptr c(new Cloud);
  std::mt19937 rng(3);
  std::normal_distribution<float> g(0.f, 1.f);
  for (int i = 0; i < 2000; ++i) {
    float x = g(rng), y = g(rng), z = g(rng);
    const float l = std::sqrt(x * x + y * y + z * z);
    c->push_back(pcl::PointXYZ(x / l, y / l, z / l));
  }
  checkCloud(c, 60, "sphere");
}

TEST(DelaunayWalkExactness, TinyClouds) {
  checkCloud(Cloud::Ptr(new Cloud), 3, "empty");
  std::vector<std::array<float, 3>> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  for (std::size_t n = 1; n <= pts.size(); ++n)
    checkCloud(fromXyz({pts.begin(), pts.begin() + static_cast<std::ptrdiff_t>(n)}), 12,
               "tiny" + std::to_string(n));
}

TEST(DelaunayWalkExactness, NaNsAndDuplicates) {
  Cloud::Ptr c = uniformCloud(800, 5);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < c->size(); i += 9) (*c)[i].y = nan;
  for (std::size_t i = 1; i < 300; i += 3) c->push_back((*c)[i]);  // duplicates (some of NaN points)
  (*c)[4].z = std::numeric_limits<float>::infinity();
  checkCloud(c, 60, "nan+dup");
  Cloud::Ptr all_nan(new Cloud);
  for (int i = 0; i < 5; ++i) all_nan->push_back(pcl::PointXYZ(nan, 0.f, 0.f));
  checkCloud(all_nan, 3, "all-nan");
}

TEST(DelaunayWalkExactness, CoplanarGridWithTies) {
  // Height-normalised LiDAR ground: every point at z = 0, on a grid, so distances tie everywhere.
  Cloud::Ptr c(new Cloud);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) c->push_back(pcl::PointXYZ(0.5f * i, 0.5f * j, 0.f));
  checkCloud(c, 60, "grid-z0");
}

TEST(DelaunayWalkExactness, Collinear) {
  Cloud::Ptr c(new Cloud);
  for (int i = 0; i < 300; ++i) c->push_back(pcl::PointXYZ(0.25f * i, 0.5f * i, -0.125f * i));
  checkCloud(c, 45, "collinear");
}

TEST(DelaunayWalkExactness, ExactlyCospherical) {
  // Integer points of the sphere x^2 + y^2 + z^2 = 25^2, plus its centre: all exactly cospherical.
  Cloud::Ptr c(new Cloud);
  for (int x = -25; x <= 25; ++x)
    for (int y = -25; y <= 25; ++y)
      for (int z = -25; z <= 25; ++z)
        if (x * x + y * y + z * z == 625) c->push_back(pcl::PointXYZ(float(x), float(y), float(z)));
  c->push_back(pcl::PointXYZ(0.f, 0.f, 0.f));
  checkCloud(c, 45, "cospherical");
}

TEST(DelaunayWalkExactness, QuantisedUtmCoordinates) {
  // LAS-like: centimetre-quantised coordinates near 6e6 (float resolution there is 0.5 m, so many
  // points collapse; the caller's float coordinates are what both FLANN and we measure).
  Cloud::Ptr c(new Cloud);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> u(0, 20000);
  for (int i = 0; i < 2500; ++i)
    c->push_back(pcl::PointXYZ(float(500000.0 + 0.01 * u(rng)), float(6000000.0 + 0.01 * u(rng)),
                               float(100.0 + 0.01 * (u(rng) % 500))));
  checkCloud(c, 60, "utm");
}

TEST(DelaunayWalkExactness, NearTiesFinerInCallerCoordinatesThanInTheGraphsFrame) {
  // The graph stores coordinates relative to its bounding box's centre (here 500, 500, 500). Near the
  // caller's origin the caller's floats are ~1e5 times finer than the graph's, so pairs of points
  // whose distances to a query differ by 1e-4 (relative) can swap order in the graph's frame. The
  // answer must be the caller's nearest: the walk's result is certified, or widened, in the caller's
  // metric. (A search that trusted the graph's frame returned the wrong point of a pair here.)
  Cloud::Ptr c(new Cloud);
  for (int corner = 0; corner < 8; ++corner)
    c->push_back(
        pcl::PointXYZ(corner & 1 ? 1000.f : 0.f, corner & 2 ? 1000.f : 0.f, corner & 4 ? 1000.f : 0.f));
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> pos(0.05f, 1.f), dir(-1.f, 1.f);
  std::vector<pcl::PointXYZ> queries;
  for (int k = 0; k < 300; ++k) {
    const pcl::PointXYZ q(pos(rng), pos(rng), pos(rng));
    float a[3] = {dir(rng), dir(rng), dir(rng)};
    const float len = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const float r = 0.01f / len, r2 = r * (1.f + 1e-4f);
    c->push_back(pcl::PointXYZ(q.x + r * a[0], q.y + r * a[1], q.z + r * a[2]));
    c->push_back(pcl::PointXYZ(q.x - r2 * a[0], q.y - r2 * a[1], q.z - r2 * a[2]));
    queries.push_back(q);
  }
  pcl::search::DelaunayWalk<pcl::PointXYZ> search;
  search.setInputCloud(c);
  pcl::Indices idx;
  std::vector<float> d2;
  for (dw::StartStrategy strategy : kStrategies) {
    search.setStartStrategy(strategy);
    for (std::size_t qi = 0; qi < queries.size(); ++qi) {
      const Ref ref = bruteKnn(*c, queries[qi], 1);
      ASSERT_EQ(search.nearestKSearch(queries[qi], 1, idx, d2), 1);
      expectSameNeighbours(
          *c, queries[qi], ref, idx, d2,
          std::string("strategy ") + dw::toString(strategy) + " query " + std::to_string(qi));
    }
  }
}

TEST(DelaunayWalkExactness, IndicesSubset) {
  Cloud::Ptr c = uniformCloud(1500, 9);
  (*c)[10].x = std::numeric_limits<float>::quiet_NaN();
  pcl::IndicesPtr subset(new pcl::Indices);
  for (int i = 0; i < 1500; i += 2) subset->push_back(i);
  subset->push_back(10);  // a NaN point in the subset
  subset->push_back(7);
  checkCloud(c, 45, "subset", subset);
}

// --- real clouds (skipped when ../shared/data is absent) ---

TEST(DelaunayWalkExactness, StanfordBunnyScan) {
  auto c = loadShared("models/bun000.ply");
  if (!c) GTEST_SKIP() << "shared data models/bun000.ply absent";
  checkCloud(c, 30, "bun000");
}

TEST(DelaunayWalkExactness, DragonRes3) {
  auto c = loadShared("models/dragon_vrip_res3.ply");
  if (!c) GTEST_SKIP() << "shared data models/dragon_vrip_res3.ply absent";
  checkCloud(c, 30, "dragon_res3");
}

TEST(DelaunayWalkExactness, TeapotWithSeamDuplicates) {
  auto c = loadShared("models/teapot_points.ply");
  if (!c) GTEST_SKIP() << "shared data models/teapot_points.ply absent";
  checkCloud(c, 45, "teapot");
}

TEST(DelaunayWalkExactness, LidarFrame) {
  auto c = loadShared("scans/fastgicp_251370668.pcd");
  if (!c) GTEST_SKIP() << "shared data scans/fastgicp_251370668.pcd absent";
  checkCloud(c, 24, "fastgicp");
}

TEST(DelaunayWalkExactness, AirborneUtmTile) {
  auto c = loadShared("airborne/isprs_samp11-utm.pcd");
  if (!c) GTEST_SKIP() << "shared data airborne/isprs_samp11-utm.pcd absent";
  checkCloud(c, 24, "isprs_samp11");
}

TEST(DelaunayWalkExactness, OrganizedKinectFrameWithNaNs) {
  auto c = loadShared("scans/pcl_capture0001.pcd");
  if (!c) GTEST_SKIP() << "shared data scans/pcl_capture0001.pcd absent";
  checkCloud(subsample(*c, 7), 24, "capture0001/7");
}

TEST(DelaunayWalkExactness, SameAsPclKdTreeOnBunny) {
  auto c = loadShared("models/bun_zipper_res2.ply");
  if (!c) GTEST_SKIP() << "shared data models/bun_zipper_res2.ply absent";
  pcl::search::DelaunayWalk<pcl::PointXYZ> walk;
  pcl::search::KdTree<pcl::PointXYZ> tree;
  walk.setInputCloud(c);
  tree.setInputCloud(c);
  pcl::Indices wi, ti;
  std::vector<float> wd, td;
  for (const auto& q : queriesFor(*c, 300, 21)) {
    for (int k : {1, 4, 16}) {
      walk.nearestKSearch(q, k, wi, wd);
      tree.nearestKSearch(q, k, ti, td);
      ASSERT_EQ(wd, td);
    }
    walk.radiusSearch(q, 0.004, wi, wd);
    tree.radiusSearch(q, 0.004, ti, td);
    ASSERT_EQ(wd, td);
  }
}
