// The generated data set: determinism, points on surfaces, poses on streets, scans on the map.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/sim/dataset_files.h"
#include "pcl_delaunay_walk/core/sim/lidar_sensor.h"
#include "pcl_delaunay_walk/core/sim/surface_sampler.h"
#include "pcl_delaunay_walk/core/sim/trajectory.h"
#include "pcl_delaunay_walk/core/sim/urban_scene.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "sim_test_util.h"

namespace {

using namespace dw::sim;

bool samePrimitives(const UrbanScene& a, const UrbanScene& b) {
  if (a.primitives().size() != b.primitives().size()) return false;
  for (std::size_t i = 0; i < a.primitives().size(); ++i) {
    const auto &p = a.primitives()[i], &q = b.primitives()[i];
    if (p.centre != q.centre || p.half != q.half || p.yaw != q.yaw || p.shape != q.shape) return false;
  }
  return true;
}

TEST(UrbanScene, SameSeedSameCityOtherSeedOtherCity) {
  const UrbanScene a = UrbanScene::generate(dw_test::smallCity(7)),
                   b = UrbanScene::generate(dw_test::smallCity(7));
  const UrbanScene c = UrbanScene::generate(dw_test::smallCity(8));
  EXPECT_TRUE(samePrimitives(a, b));
  EXPECT_FALSE(samePrimitives(a, c));
  EXPECT_GT(a.primitives().size(), 100u);
  int kinds[7] = {0};
  for (const auto& p : a.primitives()) ++kinds[static_cast<int>(p.kind)];
  for (int k = 1; k < 7; ++k) EXPECT_GT(kinds[k], 0) << "no primitive of kind " << k;
}

TEST(UrbanScene, BadOptionsAreRefused) {
  UrbanSceneOptions o = dw_test::smallCity(1);
  o.blocks_x = 0;
  EXPECT_THROW(UrbanScene::generate(o), dw::Error);
  o = dw_test::smallCity(1);
  o.street_width = 1.0;
  EXPECT_THROW(UrbanScene::generate(o), dw::Error);
  o = dw_test::smallCity(1);
  o.max_height = 1.0;
  EXPECT_THROW(UrbanScene::generate(o), dw::Error);
}

TEST(Trajectory, SmoothDriveOnTheStreetsAtSensorHeight) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(2));
  TrajectoryOptions t;
  const auto poses = generateTrajectory(scene, t, 300, 5);
  ASSERT_EQ(poses.size(), 300u);
  const double step = t.speed / t.rate_hz, pitch = scene.streets().pitch;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const Eigen::Vector3d p = poses[k].translation();
    EXPECT_NEAR(p.z() - scene.ground().height(p.x(), p.y()), t.sensor_height, 1e-9);
    const double off_x = std::fabs(p.x() - pitch * std::round(p.x() / pitch));
    const double off_y = std::fabs(p.y() - pitch * std::round(p.y() / pitch));
    EXPECT_LT(std::min(off_x, off_y), t.corner_radius * (1 - std::sqrt(0.5)) + 1e-6) << "frame " << k;
    EXPECT_LT((poses[k].linear().transpose() * poses[k].linear() - Eigen::Matrix3d::Identity()).norm(), 1e-9);
    if (k == 0) continue;
    const double moved = (p - poses[k - 1].translation()).norm();
    EXPECT_NEAR(moved, step, 0.03 * step) << "frame " << k;  // chords of arcs are a little shorter
    const Eigen::AngleAxisd turn(poses[k - 1].linear().transpose() * poses[k].linear());
    EXPECT_LT(turn.angle(), step / t.corner_radius + 0.01) << "frame " << k;
  }
  const auto again = generateTrajectory(scene, t, 300, 5);
  EXPECT_TRUE(again.back().isApprox(poses.back(), 0.0));
  // On a 3 x 3 grid two seeds can pick the same route; of four others, some must not.
  int differ = 0;
  for (std::uint64_t seed = 6; seed < 10; ++seed)
    differ += !generateTrajectory(scene, t, 300, seed).back().isApprox(poses.back(), 1e-6);
  EXPECT_GT(differ, 0);
}

TEST(LidarSensor, ScanPointsLieOnTheSurfacesWithinTheNoise) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(4));
  const auto poses = generateTrajectory(scene, TrajectoryOptions{}, 3, 4);
  for (const double noise : {0.0, 0.02}) {
    std::size_t beyond_noise_free = 0, total = 0;
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const auto pts =
          dw_test::toMap(simulateScan(scene, dw_test::smallSensor(noise), poses[k], 9, k, 2), poses[k]);
      ASSERT_GT(pts.size(), 16u * 360u / 2);
      for (const auto& p : pts) {
        const double d = scene.surfaceDistance(p, 1.0);
        // Float output: ~1e-5 relative at up to 120 m. Noisy ranges: within 5 sigma.
        EXPECT_LT(d, noise == 0 ? 2e-3 : 5 * noise + 2e-3);
        beyond_noise_free += d > 2e-3;
        ++total;
      }
    }
    if (noise > 0) {
      EXPECT_GT(beyond_noise_free, total / 2) << "the range noise is not applied";
    }
  }
}

TEST(LidarSensor, SameSeedSameScanForAnyThreadCount) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(4));
  const auto pose = generateTrajectory(scene, TrajectoryOptions{}, 1, 4)[0];
  const auto m = dw_test::smallSensor(0.02);
  const auto a = simulateScan(scene, m, pose, 11, 3, 1), b = simulateScan(scene, m, pose, 11, 3, 2);
  const auto c = simulateScan(scene, m, pose, 12, 3, 2), d = simulateScan(scene, m, pose, 11, 4, 2);
  EXPECT_EQ(a.xyzi, b.xyzi);
  EXPECT_NE(a.xyzi, c.xyzi);
  EXPECT_NE(a.xyzi, d.xyzi) << "the scan index must key the noise";
}

TEST(SurfaceSampler, ExactCountOnVisibleSurfacesForAnyThreadCount) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(5));
  SurfaceSamplingOptions o;
  o.points = 40000;
  o.seed = 3;
  o.threads = 1;
  const SurfaceSamples a = sampleSurfaces(scene, o);
  o.threads = 2;
  const SurfaceSamples b = sampleSurfaces(scene, o);
  ASSERT_EQ(a.size(), 40000u);
  ASSERT_EQ(a.xyz.size(), 3u * 40000u);
  EXPECT_EQ(a.xyz, b.xyz);
  std::size_t ground = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector3d p(a.xyz[3 * i], a.xyz[3 * i + 1], a.xyz[3 * i + 2]);
    ASSERT_LT(scene.surfaceDistance(p, 1.0), 1e-3) << "point " << i;
    ASSERT_FALSE(scene.hidden(p, -2, 0.01)) << "point " << i << " is inside a solid";
    ground += a.kind[i] == SurfaceKind::Ground;
  }
  EXPECT_GT(ground, a.size() / 5);
  EXPECT_LT(ground, a.size() * 9 / 10);
  o.seed = 4;
  EXPECT_NE(sampleSurfaces(scene, o).xyz, a.xyz);
  o.points = 0;
  EXPECT_THROW(sampleSurfaces(scene, o), dw::Error);
}

/// Nearest-neighbour distances of `pts` to the map, by the Delaunay walk.
std::vector<double> mapDistances(const dw::DelaunayGraph::ConstPtr& g,
                                 const std::vector<Eigen::Vector3d>& pts) {
  const dw::NeighbourSearch search(g);
  std::vector<double> d;
  for (const auto& p : pts) d.push_back(std::sqrt(search.nearest(g->toLocal(p.x(), p.y(), p.z())).dist2));
  return d;
}

TEST(UrbanDataSet, ScanMovedByItsTruePoseLiesOnTheMap) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(6));
  SurfaceSamplingOptions o;
  o.points = 300000;
  o.seed = 6;
  const SurfaceSamples map = sampleSurfaces(scene, o);
  dw::BuildOptions bo;
  bo.num_threads = 2;
  const auto graph = std::make_shared<const dw::DelaunayGraph>(
      dw::buildDelaunayGraph(dw::PointView::fromFloat(map.xyz.data(), map.size()), bo));
  const auto poses = generateTrajectory(scene, TrajectoryOptions{}, 20, 6);
  const Eigen::Isometry3d pose = poses.back();
  const LidarScan scan = simulateScan(scene, dw_test::smallSensor(0.02), pose, 6, 19, 2);
  // Points near the sensor only: far away the 16 beams see little, and the map's spacing (~0.5 m
  // here) is what bounds the distance, not the pose.
  std::vector<Eigen::Vector3d> near;
  for (const auto& p : dw_test::toMap(scan, pose))
    if ((p - pose.translation()).norm() < 40) near.push_back(p);
  ASSERT_GT(near.size(), 2000u);
  const auto d = mapDistances(graph, near);
  const double median = dw_test::quantile(d, 0.5), p95 = dw_test::quantile(d, 0.95);
  EXPECT_LT(median, 0.3);
  EXPECT_LT(p95, 0.6);
  // The same scan at a pose off by 0.7 m and 3 degrees is visibly off the map.
  Eigen::Isometry3d wrong = pose;
  wrong.translate(Eigen::Vector3d(0.5, 0.4, 0.3));
  wrong.rotate(Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()));
  const auto dw_ = mapDistances(graph, dw_test::toMap(scan, wrong));
  EXPECT_GT(dw_test::quantile(dw_, 0.5), 1.5 * median);
}

std::string tempPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_core_sim_" + name;
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

TEST(DataSetFiles, PosesAndScansRoundTripAndBadFilesAreNamed) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(1));
  const auto poses = generateTrajectory(scene, TrajectoryOptions{}, 5, 1);
  const std::string pose_path = tempPath("poses.txt");
  writeKittiPoses(pose_path, poses);
  const auto back = readKittiPoses(pose_path);
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) EXPECT_TRUE(back[k].isApprox(poses[k], 1e-8));
  { std::ofstream(tempPath("bad_poses.txt")) << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n"; }
  try {
    readKittiPoses(tempPath("bad_poses.txt"));
    FAIL() << "a line of 11 numbers was accepted";
  } catch (const dw::Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad_poses.txt:2"), std::string::npos) << e.what();
  }
  { std::ofstream(tempPath("skew_poses.txt")) << "2 0 0 0 0 1 0 0 0 0 1 0\n"; }
  EXPECT_THROW(readKittiPoses(tempPath("skew_poses.txt")), dw::Error);

  const LidarScan scan = simulateScan(scene, dw_test::smallSensor(0.02), poses[0], 1, 0, 2);
  writeKittiScan(tempPath("scan.bin"), scan);
  EXPECT_EQ(readKittiScan(tempPath("scan.bin")).xyzi, scan.xyzi);
  const auto xyz = dw::readPointsXyz(tempPath("scan.bin"));  // the core's reader agrees
  ASSERT_EQ(xyz.size(), 3 * scan.size());
  EXPECT_EQ(static_cast<float>(xyz[3]), scan.xyzi[4]);
  { std::ofstream(tempPath("short.bin"), std::ios::binary) << "0123456789"; }
  EXPECT_THROW(readKittiScan(tempPath("short.bin")), dw::Error);
  EXPECT_THROW(readKittiScan(tempPath("missing.bin")), dw::Error);
}

TEST(DataSetFiles, MapWritesPlyAndAFailedWriteKeepsTheOldFile) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(1));
  SurfaceSamplingOptions o;
  o.points = 5000;
  const SurfaceSamples map = sampleSurfaces(scene, o);
  const std::string ply = tempPath("map.ply");
  writeMapCloud(ply, map);
  const auto xyz = dw::readPointsXyz(ply);
  ASSERT_EQ(xyz.size(), map.xyz.size());
  for (std::size_t i = 0; i < xyz.size(); ++i) ASSERT_EQ(static_cast<float>(xyz[i]), map.xyz[i]);
  writeMapCloud(tempPath("map.las"), map);
  {  // the project's LAS reader sees every point, at 1 mm, with its class
    dw::las::LasReader reader(tempPath("map.las"));
    ASSERT_EQ(reader.header().point_count, map.size());
    EXPECT_EQ(reader.header().point_format, 6);
    std::vector<dw::las::LasRecord> records;
    std::size_t i = 0;
    while (reader.read(records) > 0)
      for (const auto& r : records) {
        EXPECT_NEAR(r.X * reader.header().scale[0] + reader.header().offset[0], map.xyz[3 * i], 6e-4);
        EXPECT_NEAR(r.Z * reader.header().scale[2] + reader.header().offset[2], map.xyz[3 * i + 2], 6e-4);
        EXPECT_EQ(r.classification, lasClass(map.kind[i]));
        ++i;
      }
    EXPECT_EQ(i, map.size());
  }
  writeMapCloud(tempPath("map.pcd"), map);
  EXPECT_EQ(slurp(tempPath("map.pcd")).find("DATA binary\n") + 12 + 12 * map.size(),
            slurp(tempPath("map.pcd")).size());
  EXPECT_THROW(writeMapCloud(tempPath("map.xyz"), map), dw::Error);
  // A folder that does not exist: an error naming the file.
  try {
    writeMapCloud(tempPath("no_such_folder/map.ply"), map);
    FAIL() << "a write into a missing folder succeeded";
  } catch (const dw::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_folder/map.ply"), std::string::npos) << e.what();
  }
  // A write that fails half-way (a coordinate beyond LAS's 32-bit range at 1 mm) keeps the old file
  // and leaves no temporary behind.
  const std::string las = tempPath("map.las"), before = slurp(las);
  SurfaceSamples far = map;
  far.xyz[3 * 4000] = 3.0e6f;
  EXPECT_THROW(writeMapCloud(las, far), dw::Error);
  EXPECT_EQ(slurp(las), before);
  EXPECT_FALSE(std::ifstream(las + ".tmp-" + std::to_string(static_cast<long>(::getpid()))).good());
  SurfaceSamples mismatched = map;
  mismatched.kind.pop_back();
  EXPECT_THROW(writeMapCloud(ply, mismatched), dw::Error);
}

}  // namespace
