// The ray caster against scenes whose answers are known in closed form.
#include <gtest/gtest.h>

#include <cmath>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/sim/lidar_sensor.h"
#include "pcl_delaunay_walk/core/sim/urban_scene.h"
#include "sim_test_util.h"

namespace {

using dw::sim::LidarModel;
using dw::sim::Primitive;
using dw::sim::SurfaceKind;
using dw::sim::UrbanScene;
constexpr double kDeg = 3.141592653589793 / 180.0;

Eigen::Isometry3d at(double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

TEST(RayCaster, FlatGroundGivesRangeHeightOverSine) {
  const UrbanScene scene(dw::sim::GroundModel{}, -500, -500, 500, 500);
  LidarModel m = LidarModel::uniform(8, -5.0, -40.0, 36);
  m.range_noise = 0.0;
  m.max_range = 200.0;
  const auto scan = dw::sim::simulateScan(scene, m, at(3, -4, 2.0), 1, 0, 1);
  ASSERT_EQ(scan.size(), 8u * 36u);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const std::size_t beam = i % 8;
    const double expected = 2.0 / std::sin(-m.elevation_deg[beam] * kDeg);
    const Eigen::Vector3d p(scan.xyzi[4 * i], scan.xyzi[4 * i + 1], scan.xyzi[4 * i + 2]);
    EXPECT_NEAR(p.norm(), expected, 1e-4 * expected) << "point " << i;
    EXPECT_NEAR(p.z(), -2.0, 1e-4);
  }
}

TEST(RayCaster, WallGivesRangeDistanceOverCosine) {
  UrbanScene scene(dw::sim::GroundModel{}, -100, -100, 100, 100);
  scene.addPrimitive(Primitive::box(SurfaceKind::Building, Eigen::Vector3d(12.5, 0, 10),
                                    Eigen::Vector3d(0.5, 50, 10), 0.0, 0.5f));
  LidarModel m = LidarModel::uniform(1, 0.0, 0.0, 360);
  m.range_noise = 0.0;
  const auto scan = dw::sim::simulateScan(scene, m, at(0, 0, 1.5), 1, 0, 2);
  // Azimuths within atan(50 / 12) = 76.5 degrees of +x meet the wall at x = 12; the others see nothing (flat
  // ground, horizontal beam).
  ASSERT_EQ(scan.size(), 153u);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3d p(scan.xyzi[4 * i], scan.xyzi[4 * i + 1], scan.xyzi[4 * i + 2]);
    EXPECT_NEAR(p.x(), 12.0, 1e-4);
    EXPECT_NEAR(p.z(), 0.0, 1e-6);
    EXPECT_GT(scan.xyzi[4 * i + 3], 0.0f);
  }
}

TEST(RayCaster, SlopedUndulatingGroundHitsLieOnTheHeightField) {
  dw::sim::GroundModel g;
  g.slope_x = 0.02;
  g.slope_y = -0.01;
  g.undulation_amplitude = 0.4;
  g.roughness_amplitude = 0.05;
  g.undulation_wavelength = 40.0;
  g.roughness_wavelength = 5.0;
  const UrbanScene scene(g, -300, -300, 300, 300);
  LidarModel m = LidarModel::uniform(24, -1.0, -30.0, 180);
  m.range_noise = 0.0;
  const Eigen::Isometry3d pose = at(10, 20, g.height(10, 20) + 1.8);
  const auto pts = dw_test::toMap(dw::sim::simulateScan(scene, m, pose, 1, 0, 2), pose);
  ASSERT_GT(pts.size(), 24u * 180u * 9 / 10);
  for (const auto& p : pts) EXPECT_NEAR(p.z(), g.height(p.x(), p.y()), 1e-4);
}

TEST(RayCaster, EveryShapeIsHitOnItsSurfaceFacingTheRay) {
  const Primitive shapes[3] = {
      Primitive::box(SurfaceKind::Car, Eigen::Vector3d(20, 5, 1), Eigen::Vector3d(2, 1, 0.7), 0.4, 0.5f),
      Primitive::cylinder(SurfaceKind::Pole, -15, 3, 0, 8, 0.3, 0.5f),
      Primitive::ellipsoid(SurfaceKind::Crown, Eigen::Vector3d(5, -18, 4), Eigen::Vector3d(3, 2, 2.5), 0.5f)};
  const Eigen::Vector3d o(0, 0, 1.7);
  for (const auto& s : shapes) {
    int hits = 0;
    for (int k = 0; k < 200; ++k) {
      // Aim at points spread over the solid's bounding box: some rays miss, every hit must be right.
      const Eigen::Vector3d target =
          s.centre +
          Eigen::Vector3d(std::sin(k * 1.7), std::cos(k * 2.3), std::sin(k * 0.9)).cwiseProduct(s.half * 1.1);
      const Eigen::Vector3d d = (target - o).normalized();
      double t;
      Eigen::Vector3d n;
      if (!s.intersect(o, d, 0.0, 1e3, t, n)) continue;
      ++hits;
      EXPECT_NEAR(s.signedDistance(o + t * d), 0.0, 1e-6);
      EXPECT_LT(n.dot(d), 0.0);
      EXPECT_NEAR(n.norm(), 1.0, 1e-9);
    }
    EXPECT_GT(hits, 50) << "shape " << static_cast<int>(s.shape);
    double t;
    Eigen::Vector3d n;
    EXPECT_TRUE(s.intersect(o, (s.centre - o).normalized(), 0.0, 1e3, t, n));
    EXPECT_FALSE(s.intersect(s.centre, Eigen::Vector3d::UnitX(), 0.0, 1e3, t, n)) << "a ray from inside";
  }
}

TEST(RayCaster, GridAnswersAsTestingEveryPrimitive) {
  const UrbanScene scene = UrbanScene::generate(dw_test::smallCity(3));
  const Eigen::Vector3d o(76.0, 76.0, scene.ground().height(76, 76) + 1.73);
  for (int k = 0; k < 2000; ++k) {
    const double az = k * 0.61, el = -0.4 + 0.45 * std::sin(k * 0.37);
    const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    double best = 120.0;
    bool any = false;
    for (const auto& p : scene.primitives()) {
      double t;
      Eigen::Vector3d n;
      if (p.intersect(o, d, 0.5, best, t, n)) {
        best = t;
        any = true;
      }
    }
    dw::sim::RayHit hit;
    const bool found = scene.intersect(o, d, 0.5, 120.0, hit);
    if (any && (!found || hit.primitive >= 0)) {
      ASSERT_TRUE(found) << "ray " << k;
      EXPECT_NEAR(hit.t, best, 1e-9) << "ray " << k;
    }
    if (found && hit.primitive >= 0) {
      EXPECT_TRUE(any);
    }
  }
}

TEST(LidarModel, HdlLikeDefaultAndBadModelsRefused) {
  const LidarModel m = LidarModel::hdl64();
  ASSERT_EQ(m.elevation_deg.size(), 64u);
  EXPECT_DOUBLE_EQ(m.elevation_deg.front(), 2.0);
  EXPECT_NEAR(m.elevation_deg.back(), -24.8, 1e-9);
  EXPECT_EQ(m.azimuth_steps, 2083);
  EXPECT_NO_THROW(m.check());
  LidarModel bad = m;
  bad.max_range = 0.5;
  EXPECT_THROW(bad.check(), dw::Error);
  bad = m;
  bad.elevation_deg.clear();
  EXPECT_THROW(bad.check(), dw::Error);
  bad = m;
  bad.range_noise = -1;
  EXPECT_THROW(bad.check(), dw::Error);
}

}  // namespace
