/// \file trajectory.h
/// \brief A smooth drive through the scene's streets: a random route over the street grid (straight on
/// or turning at each intersection, never turning back), its corners rounded by circular arcs, driven
/// at constant speed and sampled at the sensor rate. The sensor sits `sensor_height` above the ground
/// on the street centreline, x forward, y left, z up (the KITTI Velodyne frame), pitched and rolled
/// with the ground under the vehicle.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/core/sim/urban_scene.h"

namespace dw {
namespace sim {

struct TrajectoryOptions {
  double speed = 8.0;           ///< m/s
  double rate_hz = 10.0;        ///< scans per second
  double sensor_height = 1.73;  ///< above the ground (KITTI's Velodyne mount)
  double corner_radius = 8.0;   ///< of the arcs at turns; at most half the street pitch
  double straight_probability = 0.5;
  double wheelbase = 2.7;  ///< the ground slope under the vehicle is averaged over it
};

/// `frames` sensor poses (map <- sensor) along a random route on `scene.streets()`, deterministic for
/// `seed`. Throws dw::Error for invalid options or a street grid with fewer than 2 x 2 intersections.
std::vector<Eigen::Isometry3d> generateTrajectory(const UrbanScene& scene, const TrajectoryOptions& options,
                                                  std::size_t frames, std::uint64_t seed);

}  // namespace sim
}  // namespace dw
