/// \file lidar_sensor.h
/// \brief A spinning multi-beam LiDAR ray-cast into an UrbanScene: per revolution, `azimuth_steps`
/// columns of one ray per beam, first return only, Gaussian range noise, the return's intensity from
/// the surface's reflectivity and the incidence angle. A scan is taken at one instant (no motion
/// distortion): what a deskewed scan looks like.
///
/// The default model is HDL-64E-like: 64 beams from +2.0 to -24.8 degrees (32 upper beams at ~1/3
/// degree to -8.33, 32 lower at ~1/2 degree), 2083 azimuth steps (0.173 degrees), 0.9-120 m.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/core/sim/urban_scene.h"

namespace dw {
namespace sim {

struct LidarModel {
  std::vector<double> elevation_deg;  ///< one per beam, top first
  int azimuth_steps = 2083;
  double min_range = 0.9, max_range = 120.0;
  double range_noise = 0.02;  ///< standard deviation (m)

  /// The HDL-64E-like model above.
  static LidarModel hdl64();
  /// `beams` beams evenly from `top_deg` down to `bottom_deg`: small sensors for tests.
  static LidarModel uniform(int beams, double top_deg, double bottom_deg, int azimuth_steps);
  /// Throws dw::Error naming the bad field.
  void check() const;
};

/// Returns in the sensor frame, 4 floats per point (x, y, z, intensity in [0, 1]), ordered by azimuth
/// column (counter-clockwise from +x), beams top to bottom within a column: the KITTI .bin layout.
struct LidarScan {
  std::vector<float> xyzi;
  std::size_t size() const { return xyzi.size() / 4; }
};

/// Casts one revolution from `pose` (map <- sensor). The noise of ray r of scan `scan_index` is drawn
/// from a stream keyed by (seed, scan_index, r), so the scan is the same for any `threads` (0: all).
LidarScan simulateScan(const UrbanScene& scene, const LidarModel& model, const Eigen::Isometry3d& pose,
                       std::uint64_t seed, std::uint64_t scan_index, unsigned threads = 0);

}  // namespace sim
}  // namespace dw
