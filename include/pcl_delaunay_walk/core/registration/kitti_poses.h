/// \file kitti_poses.h
/// \brief Pose files in the KITTI odometry format: one pose per line, the 12 numbers of the 3x4
/// matrix [R | t] row by row, separated by spaces.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace dw {

/// A pose from 12 numbers (row-major [R | t]). Throws dw::Error unless there are exactly 12 finite
/// numbers and R is a rotation within 1e-4 (R^T R = I, det R = 1).
Eigen::Matrix4d poseFromKittiRow(const std::vector<double>& row);

/// Reads every pose of a KITTI pose file. Throws dw::Error naming the file and line of a defect.
std::vector<Eigen::Matrix4d> readKittiPoses(const std::string& path);

/// Writes the poses (17 significant digits) to `path` through a temporary file renamed over it, so a
/// failed write leaves an existing file intact. Throws dw::Error on failure.
void writeKittiPoses(const std::string& path, const std::vector<Eigen::Matrix4d>& poses);

}  // namespace dw
