// The incremental builder against Qhull on general-position input: identical edge sets on synthetic
// volumes and surfaces and on real scanned models. (Exactly degenerate models such as the teapot have
// several Delaunay triangulations; they are judged by walk exactness in test_degenerate_exactness.cpp.)
#include <gtest/gtest.h>

#include "builder3d_test_util.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

void expectSameAsQhull(const std::vector<dw::Vec3f>& pts, const std::string& what) {
  if (!dw::haveQhullBuilder())
    GTEST_SKIP() << "Qhull builder not compiled in: nothing to cross-check against";
  const b3d_test::Edges ours = b3d_test::normalise(dw::incrementalDelaunayEdges(pts, {}));
  const b3d_test::Edges qhull = b3d_test::normalise(dw::qhullDelaunayEdges(pts, 3, nullptr));
  std::size_t missing = 0, extra = 0;
  std::size_t i = 0, j = 0;
  while (i < ours.size() || j < qhull.size()) {
    if (j == qhull.size() || (i < ours.size() && ours[i] < qhull[j])) {
      ++extra;
      ++i;
    } else if (i == ours.size() || qhull[j] < ours[i]) {
      ++missing;
      ++j;
    } else {
      ++i;
      ++j;
    }
  }
  EXPECT_EQ(missing, 0u) << what << ": Qhull edges missing from ours";
  EXPECT_EQ(extra, 0u) << what << ": edges that Qhull does not have";
  EXPECT_GT(qhull.size(), pts.size()) << what;
}

TEST(QhullCrossCheck, UniformCube) {
  expectSameAsQhull(b3d_test::uniformCube(5000, 21), "uniform");
}
// Points exactly on a sphere or torus (up to float rounding) are nearly cospherical: Qhull's joggle (QJ)
// then picks a slightly different graph (measured: 37 of 15k edges on the sphere, 1 on the torus),
// while CGAL's exact Delaunay_triangulation_3 gives exactly ours (docs/builder3d.md). Scanner-like
// noise of 1e-3 puts the samples in general position, where Qhull is a valid reference.
std::vector<dw::Vec3f> withNoise(std::vector<dw::Vec3f> p, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1e-3f, 1e-3f);
  for (auto& q : p) q = {q.x + u(rng), q.y + u(rng), q.z + u(rng)};
  return b3d_test::distinct(p);
}
TEST(QhullCrossCheck, SphereSurface) {
  expectSameAsQhull(withNoise(b3d_test::sphereSurface(3000, 22), 1), "sphere");
}
TEST(QhullCrossCheck, TorusSurface) {
  expectSameAsQhull(withNoise(b3d_test::torusSurface(3000, 23), 2), "torus");
}
TEST(QhullCrossCheck, Clustered) {
  // Dense clusters of very different scales: long walks between clusters, tiny tetrahedra inside.
  std::vector<dw::Vec3f> pts = b3d_test::uniformCube(1000, 24);
  const auto small = b3d_test::uniformCube(1000, 25);
  for (const auto& p : small) pts.push_back({0.3f + 1e-3f * p.x, -0.2f + 1e-3f * p.y, 0.5f + 1e-3f * p.z});
  expectSameAsQhull(b3d_test::distinct(pts), "clustered");
}

class RealCloud : public ::testing::TestWithParam<const char*> {};

TEST_P(RealCloud, SameEdgesAsQhull) {
  const std::string path = b3d_test::sharedData(GetParam());
  if (!b3d_test::exists(path)) GTEST_SKIP() << "shared data not present: " << path;
  const auto pts = b3d_test::toVec3f(dw::readPointsXyz(path));
  ASSERT_GT(pts.size(), 100u);
  expectSameAsQhull(pts, GetParam());
}

INSTANTIATE_TEST_SUITE_P(Models, RealCloud,
                         ::testing::Values("models/bun_zipper_res4.ply", "models/bun_zipper_res3.ply",
                                           "models/dragon_vrip_res4.ply", "models/dragon_vrip_res3.ply"));

}  // namespace
