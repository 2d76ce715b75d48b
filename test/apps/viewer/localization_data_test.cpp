// The localization view's numbers: distances on the cropped map equal brute force below the cap, pose
// errors, trajectory segments, and the command line of the mode.
#include "viewer/localization_data.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "viewer/viewer_options.h"

namespace {

dw_viewer::XyzPoints cloud(std::size_t n, std::uint32_t seed, double extent) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-extent, extent);
  dw_viewer::XyzPoints p;
  for (std::size_t i = 0; i < n; ++i) {
    p.xyz.insert(p.xyz.end(), {u(rng), u(rng), 0.2 * u(rng)});
    p.input_index.push_back(static_cast<std::uint32_t>(i));
  }
  return p;
}

TEST(LocalizationData, CroppedMapDistancesEqualBruteForceBelowTheCap) {
  const auto map = cloud(20000, 1, 20.0), scan = cloud(600, 2, 14.0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(1.5, -2.0, 0.3));
  pose.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const double cap = 0.6;
  const auto on = dw_viewer::scanOnMap(map, scan, pose, cap, 2);
  ASSERT_EQ(on.distance.size(), scan.size());
  EXPECT_LT(on.crop_points, map.size());
  std::size_t below = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    double best = HUGE_VAL;
    for (std::size_t j = 0; j < map.size(); ++j) {
      double d2 = 0;
      for (int c = 0; c < 3; ++c) d2 += std::pow(on.xyz[3 * i + c] - map.xyz[3 * j + c], 2);
      best = std::min(best, d2);
    }
    const double truth = std::sqrt(best);
    if (truth < cap) {
      ++below;
      EXPECT_NEAR(on.distance[i], truth, 1e-4) << "point " << i;
    } else {
      EXPECT_FLOAT_EQ(on.distance[i], static_cast<float>(cap)) << "point " << i;
    }
  }
  EXPECT_GT(below, scan.size() / 2);
}

TEST(LocalizationData, PoseErrorAndTrajectorySegments) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = a;
  b.translate(Eigen::Vector3d(3, 4, 0));
  b.rotate(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));
  const auto e = dw_viewer::poseError(a, b);
  EXPECT_NEAR(e[0], 5.0, 1e-12);
  EXPECT_NEAR(e[1], 0.1 * 180.0 / 3.141592653589793, 1e-9);
  const auto seg = dw_viewer::trajectorySegments({a, b, b}, {{1.0, 0.0, 0.0}});
  ASSERT_EQ(seg.size(), 12u);
  EXPECT_FLOAT_EQ(seg[0], -1.0f);
  EXPECT_FLOAT_EQ(seg[3], 2.0f);
  EXPECT_FLOAT_EQ(seg[4], 4.0f);
  EXPECT_TRUE(dw_viewer::trajectorySegments({a}, {{0, 0, 0}}).empty());
}

dw_viewer::ViewerOptions parse(std::vector<std::string> args) {
  std::vector<const char*> argv{"dw_viewer"};
  for (const auto& a : args) argv.push_back(a.c_str());
  return dw_viewer::parseViewerOptions(static_cast<int>(argv.size()), argv.data());
}

TEST(LocalizationData, CommandLineOfTheMode) {
  const auto o = parse({"--map", "m.ply", "--scan", "s.bin", "--poses", "e.txt", "--truth", "t.txt",
                        "--frame", "7", "--distance-scale", "0.25", "--map-shown", "1000"});
  EXPECT_EQ(o.mode, dw_viewer::Mode::Localization);
  EXPECT_EQ(o.map, "m.ply");
  EXPECT_EQ(o.scan, "s.bin");
  EXPECT_EQ(o.truth, "t.txt");
  EXPECT_EQ(o.frame, 7);
  EXPECT_EQ(o.distance_scale, 0.25);
  EXPECT_EQ(o.map_shown, 1000u);
  EXPECT_EQ(parse({"--map", "m.ply", "--scan", "run/scans/000042.bin", "--poses", "e.txt"}).frame, 42);
  EXPECT_EQ(parse({"--map", "m.ply", "--scan", "run/scans/frame42.bin", "--poses", "e.txt"}).frame, 0);
  EXPECT_EQ(parse({"--map", "m.ply", "--scan", "000042.bin", "--poses", "e.txt", "--frame", "3"}).frame, 3);
  EXPECT_THROW(parse({"--map", "m.ply", "--scan", "s.bin"}), dw::Error);
  EXPECT_THROW(parse({"--map", "m.ply", "--scan", "s.bin", "--poses", "e.txt", "a.ply"}), dw::Error);
  EXPECT_THROW(parse({"--map", "m.ply", "--scan", "s.bin", "--poses", "e.txt", "--distance-scale", "0"}),
               dw::Error);
  EXPECT_THROW(parse({"--map", "m.ply", "--scan", "s.bin", "--poses", "e.txt", "--pick", "3"}), dw::Error);
  EXPECT_THROW(parse({"--map", "m.ply", "--scan", "s.bin", "--poses", "e.txt", "--frame", "-1"}), dw::Error);
}

}  // namespace
