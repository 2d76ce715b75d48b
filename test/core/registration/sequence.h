// Programmatic sequences for the localizer and odometry tests: a real cloud (the bundled dragon,
// scaled to a 20 m scene) seen by a sensor moving along a known trajectory; each scan is the part of
// the cloud within a radius of the sensor, thinned at random, jittered and put in the sensor frame.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/util/point_file.h"

namespace dw_test {

/// The dragon scaled to about 20 m, centred at the origin, as floats.
inline std::vector<float> dragonScene() {
  const std::vector<double> xyz = dw::readPointsXyz(std::string(DW_TEST_DATA_DIR) + "/dragon_vrip_res3.ply");
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t i = 0; i < xyz.size(); i += 3) {
    const Eigen::Vector3d p(xyz[i], xyz[i + 1], xyz[i + 2]);
    lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  const double s = 20.0 / (hi - lo).maxCoeff();
  std::vector<float> out(xyz.size());
  for (std::size_t i = 0; i < xyz.size(); i += 3)
    for (int k = 0; k < 3; ++k) out[i + std::size_t(k)] = float((xyz[i + std::size_t(k)] - c(k)) * s);
  return out;
}

/// Sensor -> map poses: a gentle arc through the scene, `step` metres and `yaw` radians per frame.
inline std::vector<Eigen::Matrix4d> arcTrajectory(std::size_t frames, double step = 0.3, double yaw = 0.02) {
  std::vector<Eigen::Matrix4d> poses;
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topRightCorner<3, 1>() = Eigen::Vector3d(-3.0, -1.0, 0.5);
  Eigen::Matrix4d delta = Eigen::Matrix4d::Identity();
  delta.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(0.3 * yaw, Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
  delta.topRightCorner<3, 1>() = Eigen::Vector3d(step, 0.1 * step, 0.02 * step);
  for (std::size_t k = 0; k < frames; ++k) {
    poses.push_back(t);
    t = t * delta;
  }
  return poses;
}

/// The points within `radius` of the sensor, each kept with probability `keep`, moved by Gaussian
/// noise of `sigma` metres, in the sensor frame (3 floats each).
inline std::vector<float> cutScan(const std::vector<float>& scene, const Eigen::Matrix4d& pose, double radius,
                                  unsigned seed, double keep = 0.7, double sigma = 0.005) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, sigma);
  const Eigen::Matrix4d inv = pose.inverse();
  const Eigen::Vector3d c = pose.topRightCorner<3, 1>();
  std::vector<float> out;
  for (std::size_t i = 0; i < scene.size(); i += 3) {
    const Eigen::Vector3d p(scene[i], scene[i + 1], scene[i + 2]);
    if ((p - c).norm() > radius || u(rng) > keep) continue;
    const Eigen::Vector3d n(g(rng), g(rng), g(rng));
    const Eigen::Vector3d s = inv.topLeftCorner<3, 3>() * (p + n) + inv.topRightCorner<3, 1>();
    out.insert(out.end(), {float(s(0)), float(s(1)), float(s(2))});
  }
  return out;
}

inline double translationError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  return (a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>()).norm();
}
inline double rotationError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  const Eigen::Matrix3d r = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  return std::acos(std::min(1.0, std::max(-1.0, 0.5 * (r.trace() - 1))));
}

}  // namespace dw_test
