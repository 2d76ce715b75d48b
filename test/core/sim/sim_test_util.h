// Small scenes and sensors for the simulator's tests: a 2 x 2-block city and a 16-beam sensor, so a
// scan has a few thousand points and every test runs in well under a second.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <vector>

#include "pcl_delaunay_walk/core/sim/lidar_sensor.h"
#include "pcl_delaunay_walk/core/sim/urban_scene.h"

namespace dw_test {

inline dw::sim::UrbanSceneOptions smallCity(std::uint64_t seed) {
  dw::sim::UrbanSceneOptions o;
  o.seed = seed;
  o.blocks_x = o.blocks_y = 2;
  return o;
}

inline dw::sim::LidarModel smallSensor(double noise) {
  dw::sim::LidarModel m = dw::sim::LidarModel::uniform(16, 2.0, -24.8, 360);
  m.range_noise = noise;
  return m;
}

/// Scan points moved into the map frame by `pose`.
inline std::vector<Eigen::Vector3d> toMap(const dw::sim::LidarScan& scan, const Eigen::Isometry3d& pose) {
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < scan.size(); ++i)
    out.push_back(pose * Eigen::Vector3d(scan.xyzi[4 * i], scan.xyzi[4 * i + 1], scan.xyzi[4 * i + 2]));
  return out;
}

inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = static_cast<std::size_t>(q * (v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

}  // namespace dw_test
