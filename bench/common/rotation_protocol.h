/// \file rotation_protocol.h
/// \brief The seed's ICP protocol (§5): register a cloud to itself after rotations of -20..20 degrees in
/// 10-degree steps in roll, pitch and yaw, optionally with Gaussian noise added to the target.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dwb {

/// One initial misalignment, in degrees; applied about the cloud's centroid so that it is a pure
/// rotation of the shape (about the origin it would add a translation that grows with the offset).
struct Rotation {
  int roll = 0, pitch = 0, yaw = 0;

  std::string label() const {
    return "r" + std::to_string(roll) + "p" + std::to_string(pitch) + "y" + std::to_string(yaw);
  }

  Eigen::Matrix3d matrix() const {
    const double k = M_PI / 180.0;
    return (Eigen::AngleAxisd(yaw * k, Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(pitch * k, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(roll * k, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
  }

  /// x -> R (x - c) + c as a 4x4 transform.
  Eigen::Matrix4d about(const Eigen::Vector3d& c) const {
    Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
    const Eigen::Matrix3d r = matrix();
    t.topLeftCorner<3, 3>() = r;
    t.topRightCorner<3, 1>() = c - r * c;
    return t;
  }
};

/// Which rotations to run:
///  "grid"  every (roll, pitch, yaw) in {-20,-10,0,10,20}^3 except the identity: 124 (the seed's set);
///  "axes"  one axis at a time, +-10 and +-20 degrees: 12;
///  "one"   roll = pitch = yaw = 10 degrees (the ICP-like query sequence of the NN benchmarks).
inline std::vector<Rotation> rotationSet(const std::string& mode) {
  std::vector<Rotation> out;
  const int steps[] = {-20, -10, 0, 10, 20};
  if (mode == "grid") {
    for (int r : steps)
      for (int p : steps)
        for (int y : steps)
          if (r || p || y) out.push_back({r, p, y});
  } else if (mode == "axes") {
    for (int axis = 0; axis < 3; ++axis)
      for (int s : steps) {
        if (!s) continue;
        Rotation rot;
        (axis == 0 ? rot.roll : axis == 1 ? rot.pitch : rot.yaw) = s;
        out.push_back(rot);
      }
  } else if (mode == "one") {
    out.push_back({10, 10, 10});
  } else {
    throw dw::Error("dw_bench: unknown rotation set '" + mode + "' (expected grid, axes or one)");
  }
  return out;
}

inline Eigen::Vector3d centroid(const std::vector<float>& xyz) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  const std::size_t n = xyz.size() / 3;
  for (std::size_t i = 0; i < n; ++i) c += Eigen::Vector3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return n ? Eigen::Vector3d(c / double(n)) : c;
}

inline std::vector<float> transformed(const std::vector<float>& xyz, const Eigen::Matrix4d& t) {
  std::vector<float> out(xyz.size());
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    const Eigen::Vector4d p(xyz[i], xyz[i + 1], xyz[i + 2], 1.0);
    const Eigen::Vector4d q = t * p;
    out[i] = float(q.x()), out[i + 1] = float(q.y()), out[i + 2] = float(q.z());
  }
  return out;
}

/// Root-mean-square distance between the axis-aligned bounding box corners: a scale for noise and
/// tolerances that does not depend on the units of the file.
inline double bboxDiagonal(const std::vector<float>& xyz) {
  if (xyz.size() < 3) return 0.0;
  double lo[3] = {xyz[0], xyz[1], xyz[2]}, hi[3] = {xyz[0], xyz[1], xyz[2]};
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3)
    for (int a = 0; a < 3; ++a)
      lo[a] = std::min(lo[a], double(xyz[i + a])), hi[a] = std::max(hi[a], double(xyz[i + a]));
  return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                   (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

/// The target with isotropic Gaussian noise of standard deviation `sigma` (fixed seed: repeatable).
inline std::vector<float> withNoise(const std::vector<float>& xyz, double sigma, std::uint32_t seed = 42) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma);
  std::vector<float> out(xyz);
  for (float& v : out) v = float(v + n(rng));
  return out;
}

/// Rotation angle (degrees) of the residual a^-1 b, and the distance of their translations. The angle
/// comes from |R - I|_F = 2 sqrt(2) sin(theta/2), which stays accurate for tiny angles where
/// acos((trace - 1) / 2) of a float matrix cannot resolve below ~0.02 degrees.
inline void poseError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double& angle_deg, double& trans) {
  const Eigen::Matrix4d d = a.inverse() * b;
  const double f = (d.topLeftCorner<3, 3>() - Eigen::Matrix3d::Identity()).norm();
  angle_deg = 2.0 * std::asin(std::min(1.0, f / (2.0 * std::sqrt(2.0)))) * 180.0 / M_PI;
  trans = d.topRightCorner<3, 1>().norm();
}

}  // namespace dwb
