// Degenerate inputs through the whole pipeline (buildDelaunayGraph with the incremental builder, then
// NeighbourSearch): nearest and kNN distances equal brute force. Where the Delaunay triangulation is
// not unique any choice is exact for the walk (every Voronoi-facet neighbour is an edge of every
// Delaunay triangulation), so these tests judge the graph by what the walk needs.
#include <gtest/gtest.h>

#include <memory>

#include "builder3d_test_util.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

dw::DelaunayGraph buildIncremental(const std::vector<double>& xyz, unsigned threads = 1) {
  dw::BuildOptions opt;
  opt.builder = dw::BuilderType::Incremental;
  opt.num_threads = threads;
  return dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3), opt);
}

std::vector<double> toDouble(const std::vector<dw::Vec3f>& p, double offset = 0.0) {
  std::vector<double> xyz;
  for (const auto& q : p) {
    xyz.push_back(q.x + offset);
    xyz.push_back(q.y + offset);
    xyz.push_back(q.z);
  }
  return xyz;
}

// Nearest and 6-NN distances of `queries` random queries (and every vertex perturbed by a tie-making
// half step) against brute force in the graph's own float frame.
void expectExactSearch(const std::vector<double>& xyz, const std::string& what, double jitter) {
  auto graph = std::make_shared<dw::DelaunayGraph>(buildIncremental(xyz));
  graph->validate();
  ASSERT_EQ(graph->dimension, 3) << what;
  dw::NeighbourSearch search(graph);
  const std::size_t n = xyz.size() / 3;
  std::vector<dw::Vec3f> local(n);
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < n; ++i) {
    local[i] = graph->toLocal(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], xyz[3 * i + k]);
      hi[k] = std::max(hi[k], xyz[3 * i + k]);
    }
  }
  const double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  const float scale2 = float(ext * ext);
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(-0.2, 1.2);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  std::vector<dw::index_t> idx;
  std::vector<float> d2;
  for (int it = 0; it < 400; ++it) {
    double q[3];
    if (it % 2 == 0) {
      for (int k = 0; k < 3; ++k) q[k] = lo[k] + u(rng) * (hi[k] - lo[k]);
    } else {  // near a vertex, on a tie-making offset (grid half steps)
      const std::size_t v = pick(rng);
      for (int k = 0; k < 3; ++k) q[k] = xyz[3 * v + k] + ((it / 2 + k) % 3 - 1) * jitter;
    }
    const dw::Vec3f ql = graph->toLocal(q[0], q[1], q[2]);
    std::vector<float> all(n);
    for (std::size_t i = 0; i < n; ++i) all[i] = dw::squaredDistance(ql, local[i]);
    std::sort(all.begin(), all.end());
    for (dw::StartStrategy s : {dw::StartStrategy::Zero, dw::StartStrategy::KdAnn}) {
      const dw::WalkResult nn = search.nearest(ql, s);
      ASSERT_NEAR(nn.dist2, all[0], 1e-5f * all[0] + 1e-7f * scale2) << what << " query " << it;
    }
    const dw::WalkResult nn = search.nearest(ql);
    const std::size_t k = 6;
    ASSERT_EQ(search.knn(ql, k, nn, idx, d2), std::min(k, n));
    for (std::size_t j = 0; j < d2.size(); ++j)
      ASSERT_NEAR(d2[j], all[j], 1e-5f * all[j] + 1e-7f * scale2) << what << " query " << it << " rank " << j;
  }
}

TEST(DegenerateExactness, IntegerGrid) {
  expectExactSearch(toDouble(b3d_test::grid(9, 8, 7)), "grid", 0.5);
}

TEST(DegenerateExactness, CosphericalLattice) {
  auto pts = b3d_test::latticeSphere(25 * 25);
  pts.push_back({0, 0, 0});  // the centre: equidistant from everything
  expectExactSearch(toDouble(pts), "cospherical", 0.5);
}

TEST(DegenerateExactness, QuantisedCoordinates) {
  expectExactSearch(toDouble(b3d_test::quantised(4000, 31, 0.05f)), "quantised", 0.025);
}

TEST(DegenerateExactness, HugeOffsetsWithDuplicates) {
  // UTM-like coordinates with a centimetre grid, plus exact duplicates: the builder gets the centred,
  // deduplicated float points from the preparation stage.
  auto pts = b3d_test::grid(10, 10, 6, 0.25f);
  auto xyz = toDouble(pts, 6.0e6);
  for (std::size_t i = 0; i < 30; ++i)
    for (int k = 0; k < 3; ++k) xyz.push_back(xyz[3 * (7 * i) + k]);
  expectExactSearch(xyz, "huge offsets", 0.125);
}

TEST(DegenerateExactness, TeapotSeamDuplicatesAndSymmetry) {
  const std::string path = b3d_test::sharedData("models/teapot_points.ply");
  if (!b3d_test::exists(path)) GTEST_SKIP() << "shared data not present: " << path;
  expectExactSearch(dw::readPointsXyz(path), "teapot", 0.01);
}

TEST(DegenerateExactness, SameGraphForOneAndManyThreads) {
  const auto xyz = toDouble(b3d_test::grid(8, 8, 8));
  const dw::DelaunayGraph a = buildIncremental(xyz, 1), b = buildIncremental(xyz, 4);
  ASSERT_EQ(a.offsets, b.offsets);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  for (std::size_t i = 0; i < a.edges.size(); ++i) ASSERT_EQ(a.edges[i].j, b.edges[i].j);
}

}  // namespace
