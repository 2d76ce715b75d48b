// Partitioned parallel insertion (Triangulation3D::insertParallel and build's batched form): for any
// thread count the triangulation is valid and has exactly the sequential edge set, on general-position
// and degenerate input, with ids in Morton order (compact cells) or not (cells scattered over the
// cloud: slower, still exact). The ParallelInsertion.* tests also run under TSan (its filter matches
// the name); the heavier PartitionedInsertion.* ones do not.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "builder3d_test_util.h"
#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

using b3d_test::Edges;
using dw::builder3d::Triangulation3D;

Edges edgesOf(const Triangulation3D& k) {
  return b3d_test::kernelEdges(k, 2);
}

// Batches of these test clouds (15k-40k points) are shared among threads only below the default
// of 8192 points per thread.
constexpr std::size_t kTestMinPerThread = 2048;

// BRIO rounds as batches, as incrementalDelaunayEdges builds.
Edges parallelBuild(const std::vector<dw::Vec3f>& pts, unsigned threads,
                    Triangulation3D::Stats* stats = nullptr) {
  std::vector<std::size_t> rounds;
  const auto order = dw::builder3d::brioOrder(pts, rounds);
  Triangulation3D k;
  k.setMinPointsPerThread(kTestMinPerThread);
  k.setPoints(pts.data(), pts.size());
  k.build(order.data(), order.size(), {}, rounds, threads);
  k.validate();
  if (stats) *stats = k.stats();
  return edgesOf(k);
}

void expectSameForAnyThreadCount(const std::vector<dw::Vec3f>& pts, const std::string& what,
                                 bool expect_threads_used = true) {
  const Edges ref = parallelBuild(pts, 1);
  ASSERT_GT(ref.size(), pts.size()) << what;
  for (unsigned threads : {2u, 3u, 5u}) {
    Triangulation3D::Stats stats;
    EXPECT_EQ(parallelBuild(pts, threads, &stats), ref) << what << " on " << threads << " threads";
    EXPECT_EQ(stats.fallback_locations, 0u) << what;
    ::testing::Test::RecordProperty(
        what + " threads " + std::to_string(threads) + " shared",
        std::to_string(stats.parallel_inserted) + " of " + std::to_string(pts.size()));
    // Not vacuous: the threads did insert (the batches are big enough to be shared).
    if (expect_threads_used) {
      EXPECT_GT(stats.parallel_inserted, pts.size() / 4) << what << ", " << threads;
    }
  }
}

TEST(ParallelInsertion, UniformMortonIds) {
  expectSameForAnyThreadCount(b3d_test::mortonSorted(b3d_test::uniformCube(40000, 51)), "uniform");
}

TEST(PartitionedInsertion, UniformScatteredIdsStillExact) {
  // Random ids: cells are spatial, but consecutive points of a thread are far apart (long walks).
  expectSameForAnyThreadCount(b3d_test::uniformCube(20000, 52), "scattered ids", false);
}

TEST(PartitionedInsertion, CospericalGridAndQuantisedTies) {
  expectSameForAnyThreadCount(b3d_test::mortonSorted(b3d_test::grid(30, 26, 22)), "grid", false);
  expectSameForAnyThreadCount(b3d_test::mortonSorted(b3d_test::quantised(30000, 53, 0.03f)), "quantised");
}

TEST(PartitionedInsertion, SurfacesAndHullHeavyInput) {
  // Every point of a sphere is on the hull, and the big interior tetrahedra join far-apart points, so
  // most cavities reach other cells and go to the calling thread: exact, but little is shared.
  expectSameForAnyThreadCount(b3d_test::mortonSorted(b3d_test::sphereSurface(15000, 54)), "sphere", false);
  expectSameForAnyThreadCount(b3d_test::mortonSorted(b3d_test::torusSurface(15000, 55)), "torus", false);
}

TEST(PartitionedInsertion, RealScan) {
  const std::string path = std::string(DW_TEST_DATA_DIR) + "/dragon_vrip_res3.ply";
  if (!b3d_test::exists(path)) GTEST_SKIP() << "test data not present: " << path;
  const auto xyz = dw::readPointsXyz(path);
  expectSameForAnyThreadCount(b3d_test::mortonSorted(b3d_test::toVec3f(xyz)), "dragon res3", false);
}

TEST(PartitionedInsertion, BatchIntoBuiltTriangulationEqualsFreshBuild) {
  // A sliding map grows: half the cloud exists, the other half arrives as one parallel batch.
  const auto pts = b3d_test::mortonSorted(b3d_test::uniformCube(30000, 56));
  std::vector<dw::index_t> first, second;
  for (dw::index_t i = 0; i < pts.size(); ++i) (i % 2 ? second : first).push_back(i);
  Triangulation3D k;
  k.setMinPointsPerThread(kTestMinPerThread);
  k.setPoints(pts.data(), pts.size());
  const auto order = dw::builder3d::brioOrder(pts, first);
  k.build(order.data(), order.size());
  k.insertParallel(second.data(), second.size(), 4);
  k.validate();
  EXPECT_EQ(k.numVertices(), pts.size());
  EXPECT_GT(k.stats().parallel_inserted, second.size() / 2);
  EXPECT_EQ(edgesOf(k), parallelBuild(pts, 1));
}

TEST(PartitionedInsertion, SmallBatchIntoBigTriangulationEqualsFreshBuild) {
  // A sliding window's update: a batch of a few percent of the points. Its passes find each vertex's
  // cell through the split tree rather than a per-point table (the other tests take the table).
  const auto pts = b3d_test::mortonSorted(b3d_test::uniformCube(40000, 58));
  std::vector<dw::index_t> first, second;
  for (dw::index_t i = 0; i < pts.size(); ++i) (i % 16 == 3 ? second : first).push_back(i);
  Triangulation3D k;
  k.setMinPointsPerThread(kTestMinPerThread);
  k.setPoints(pts.data(), pts.size());
  const auto order = dw::builder3d::brioOrder(pts, first);
  k.build(order.data(), order.size());
  ASSERT_LT(second.size() * 8, pts.size());
  k.insertParallel(second.data(), second.size(), 4);
  k.validate();
  EXPECT_EQ(k.numVertices(), pts.size());
  EXPECT_GT(k.stats().parallel_inserted, second.size() / 2);
  EXPECT_EQ(edgesOf(k), parallelBuild(pts, 1));
}

TEST(ParallelInsertion, BadBatchesThrowAndLeaveAValidTriangulation) {
  auto pts = b3d_test::mortonSorted(b3d_test::uniformCube(20000, 57));
  std::vector<dw::index_t> first, second;
  for (dw::index_t i = 0; i < pts.size(); ++i) (i % 3 ? second : first).push_back(i);
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  const auto order = dw::builder3d::brioOrder(pts, first);
  k.build(order.data(), order.size());
  const std::size_t before = k.numVertices();

  std::vector<dw::index_t> out_of_range = second;
  out_of_range.push_back(static_cast<dw::index_t>(pts.size()));
  EXPECT_THROW(k.insertParallel(out_of_range.data(), out_of_range.size(), 3), dw::Error);
  EXPECT_EQ(k.numVertices(), before);

  // A point already present, in the middle of a batch a thread inserts: a clear error, no corruption.
  std::vector<dw::index_t> with_duplicate = second;
  with_duplicate.insert(with_duplicate.begin() + with_duplicate.size() / 2, first[first.size() / 2]);
  EXPECT_THROW(k.insertParallel(with_duplicate.data(), with_duplicate.size(), 3), dw::Error);
  k.validate();

  Triangulation3D births;
  births.setPoints(pts.data(), pts.size());
  births.trackBirths(true);
  births.build(order.data(), order.size());
  EXPECT_THROW(births.insertParallel(second.data(), second.size(), 2), dw::Error);
}

}  // namespace
