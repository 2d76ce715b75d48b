// The block-parallel builder gives exactly the sequential kernel's edge set for any number of blocks,
// on general-position and degenerate input (the perturbation is keyed on global ids, so blocks agree
// at their seams), and through incrementalDelaunayEdges for any thread count.
#include <gtest/gtest.h>

#include <algorithm>

#include "builder3d_test_util.h"
#include "core/builder3d/block_parallel_builder.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

void expectSameForAnyBlockCount(const std::vector<dw::Vec3f>& unsorted, const std::string& what) {
  const auto pts = b3d_test::mortonSorted(unsorted);
  const auto ref = b3d_test::normalise(dw::builder3d::blockParallelDelaunayEdges(pts, 1));
  ASSERT_GT(ref.size(), pts.size());
  for (unsigned blocks : {2u, 3u, 5u}) {
    dw::builder3d::BlockBuildStats stats;
    const auto e = dw::builder3d::blockParallelDelaunayEdges(pts, blocks, &stats);
    EXPECT_EQ(b3d_test::normalise(e).size(), e.size()) << what << ": an edge reported by two blocks";
    EXPECT_EQ(b3d_test::normalise(e), ref) << what << " with " << blocks << " blocks";
    if (stats.blocks > 1) {
      EXPECT_LT(stats.halo_points, blocks * pts.size()) << what;
    }
  }
}

TEST(BlockParallel, Uniform) {
  expectSameForAnyBlockCount(b3d_test::uniformCube(30000, 41), "uniform");
}
TEST(BlockParallel, IntegerGrid) {
  expectSameForAnyBlockCount(b3d_test::grid(24, 20, 16), "grid");
}
TEST(BlockParallel, Quantised) {
  expectSameForAnyBlockCount(b3d_test::quantised(20000, 42, 0.04f), "quantised");
}
TEST(BlockParallel, Torus) {
  expectSameForAnyBlockCount(b3d_test::torusSurface(12000, 43), "torus");
}
TEST(BlockParallel, SphereFallsBackToSequential) {
  // Every point is on the hull: blocks would each insert all of them, so the builder goes sequential.
  const auto pts = b3d_test::mortonSorted(b3d_test::sphereSurface(5000, 44));
  dw::builder3d::BlockBuildStats stats;
  const auto e = dw::builder3d::blockParallelDelaunayEdges(pts, 3, &stats);
  EXPECT_EQ(stats.blocks, 1u);
  EXPECT_EQ(b3d_test::normalise(e), b3d_test::normalise(dw::builder3d::blockParallelDelaunayEdges(pts, 1)));
}

TEST(BlockParallel, RealScan) {
  const std::string path = b3d_test::sharedData("models/dragon_vrip_res3.ply");
  if (!b3d_test::exists(path)) GTEST_SKIP() << "shared data not present: " << path;
  expectSameForAnyBlockCount(b3d_test::toVec3f(dw::readPointsXyz(path)), "dragon res3");
}

TEST(BlockParallel, BuilderEntryPointIsThreadCountInvariant) {
  const auto pts = b3d_test::mortonSorted(b3d_test::uniformCube(60000, 45));
  dw::BuildOptions one, many;
  one.num_threads = 1;
  many.num_threads = 2;  // 60k points: two blocks of at least 25k
  EXPECT_EQ(b3d_test::normalise(dw::incrementalDelaunayEdges(pts, one)),
            b3d_test::normalise(dw::incrementalDelaunayEdges(pts, many)));
}

}  // namespace
