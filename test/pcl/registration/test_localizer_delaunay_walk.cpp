// The localizer against stock PCL: one registerScan gives the pose of
// pcl::IterativeClosestPoint<PointXYZ, PointXYZ, double> (its KdTree, same distance, iterations and
// epsilons, the same guess) within 1e-6 relative and with the same iteration count, on the bundled
// outdoor LiDAR pair and, when present, on the KITTI frames; and the PCL class tracks and reports.
// PCL's SVD transformation estimation, instantiated here, trips GCC 12 false positives inside Eigen.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <gtest/gtest.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/registration/icp.h>

#include <cstdlib>
#include <fstream>

#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/registration/localizer_delaunay_walk.h"

namespace {

using P = pcl::PointXYZ;
using Cloud = pcl::PointCloud<P>;

Cloud::Ptr loadPcd(const std::string& path) {
  Cloud::Ptr c(new Cloud);
  if (!std::ifstream(path).good() || pcl::io::loadPCDFile(path, *c) < 0) return nullptr;
  return c;
}

Cloud::Ptr loadBin(const std::string& path) {
  if (!std::ifstream(path).good()) return nullptr;
  const auto xyz = dw::readPointsXyz(path);
  Cloud::Ptr c(new Cloud);
  for (std::size_t i = 0; i < xyz.size() / 3; ++i)
    c->push_back(P(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2])));
  return c;
}

Cloud::Ptr voxel(const Cloud::Ptr& c, float leaf) {
  Cloud::Ptr out(new Cloud);
  pcl::VoxelGrid<P> vg;
  vg.setInputCloud(c);
  vg.setLeafSize(leaf, leaf, leaf);
  vg.filter(*out);
  return out;
}

struct StockIcp : pcl::IterativeClosestPoint<P, P, double> {
  using pcl::IterativeClosestPoint<P, P, double>::nr_iterations_;
};

struct IcpParameters {
  double max_distance = 1.0;
  int max_iterations = 30;
  double epsilon = 1e-8;
  Eigen::Matrix4d guess = Eigen::Matrix4d::Identity();
};

/// Stock ICP and the localizer on the same map, scan and parameters: same pose, same iterations.
void expectSameAsStock(const Cloud::Ptr& map, const Cloud::Ptr& scan, const IcpParameters& s,
                       const char* what) {
  StockIcp icp;
  icp.setInputSource(scan);
  icp.setInputTarget(map);
  icp.setMaxCorrespondenceDistance(s.max_distance);
  icp.setMaximumIterations(s.max_iterations);
  icp.setTransformationEpsilon(s.epsilon);
  Cloud aligned;
  icp.align(aligned, s.guess);
  const Eigen::Matrix4d stock = icp.getFinalTransformation();

  pcl::registration::LocalizerDelaunayWalk<P> loc;
  loc.setMaxCorrespondenceDistance(s.max_distance);
  loc.setMaximumIterations(s.max_iterations);
  loc.setTransformationEpsilon(s.epsilon);
  loc.setMinimumFitness(0.0);  // the status must not hide the pose: compare every frame
  loc.setNumberOfThreads(2);
  loc.setInputMap(map);
  loc.setPose(s.guess);
  const dw::FrameResult r = loc.registerScan(*scan);
  ASSERT_EQ(r.status, dw::FrameStatus::Ok) << what;
  EXPECT_EQ(r.iterations, icp.nr_iterations_) << what;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      EXPECT_NEAR(r.pose(i, j), stock(i, j), 1e-6 * std::max(1.0, std::fabs(stock(i, j))))
          << what << " element (" << i << ", " << j << ")";
  EXPECT_TRUE(icp.hasConverged()) << what;
}

TEST(LocalizerDelaunayWalk, EqualsStockPclIcpOnTheOutdoorPair) {
  const Cloud::Ptr map = loadPcd(std::string(DW_TEST_DATA_DIR) + "/fastgicp_251370668.pcd");
  const Cloud::Ptr full = loadPcd(std::string(DW_TEST_DATA_DIR) + "/fastgicp_251371071.pcd");
  ASSERT_TRUE(map && full);
  const Cloud::Ptr scan = voxel(full, 0.5f);
  for (double d : {0.5, 2.0}) {
    IcpParameters s;
    s.max_distance = d;
    expectSameAsStock(map, scan, s, d == 0.5 ? "outdoor pair, 0.5 m" : "outdoor pair, 2 m");
  }
}

TEST(LocalizerDelaunayWalk, EqualsStockPclIcpOnKittiFrames) {
  // The shared data beside the checkout, or where DW_SHARED_DATA_DIR points (a worktree elsewhere).
  const char* env = std::getenv("DW_SHARED_DATA_DIR");
  const std::string dir = std::string(env ? env : DW_SHARED_DATA_DIR) + "/scans/";
  const Cloud::Ptr map = loadBin(dir + "kitti_000000.bin"), full = loadBin(dir + "kitti_000001.bin");
  if (!map || !full) GTEST_SKIP() << "shared data scans/kitti_00000{0,1}.bin absent";
  IcpParameters s;
  s.guess(0, 3) = 0.5;  // roughly the car's motion between the frames, as a prediction would give
  expectSameAsStock(map, voxel(full, 0.4f), s, "KITTI 000001 onto 000000");
}

TEST(LocalizerDelaunayWalk, RecoversTheReferenceMotionAndSavesItsMap) {
  const Cloud::Ptr map = loadPcd(std::string(DW_TEST_DATA_DIR) + "/fastgicp_251370668.pcd");
  const Cloud::Ptr scan = voxel(loadPcd(std::string(DW_TEST_DATA_DIR) + "/fastgicp_251371071.pcd"), 0.3f);
  std::ifstream rel(std::string(DW_TEST_DATA_DIR) + "/fastgicp_relative.txt");
  Eigen::Matrix4d ref;
  for (int i = 0; i < 16; ++i) rel >> ref(i / 4, i % 4);
  ASSERT_TRUE(rel);
  pcl::registration::LocalizerDelaunayWalk<P> loc;
  loc.setMaxCorrespondenceDistance(1.0);
  loc.setUsePointToPlane(true);
  loc.setNumberOfThreads(2);
  loc.setInputMap(map);
  const dw::FrameResult r = loc.registerScan(*scan);
  EXPECT_EQ(r.status, dw::FrameStatus::Ok);
  EXPECT_LT((r.pose.topRightCorner<3, 1>() - ref.topRightCorner<3, 1>()).norm(), 0.05);
  EXPECT_GT(r.fitness, 0.8);
  const std::string path = std::string(DW_BINARY_DIR) + "/test_pcl_localizer_map.graph";
  loc.saveMap(path);
  pcl::registration::LocalizerDelaunayWalk<P> again;
  again.loadMap(path);
  EXPECT_EQ(again.getLocalizer()->mapPoints(), loc.getLocalizer()->mapPoints());
  std::remove(path.c_str());
  // An empty scan is a status, not an exception; no map is an exception.
  EXPECT_EQ(loc.registerScan(Cloud()).status, dw::FrameStatus::EmptyScan);
  pcl::registration::LocalizerDelaunayWalk<P> none;
  EXPECT_THROW(none.registerScan(*scan), dw::Error);
}

}  // namespace
