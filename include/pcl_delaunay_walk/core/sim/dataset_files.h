/// \file dataset_files.h
/// \brief Files of a localization data set: KITTI scans (.bin: float32 x, y, z, intensity per point,
/// little endian, sensor frame), KITTI poses (one line per frame, the 12 numbers of the 3x4 matrix
/// [R | t] row by row, map <- sensor) and the prior map as binary PLY, binary PCD or LAS.
/// Writers never leave a half-written file at the destination: they write a temporary file beside
/// it and rename it into place, so an existing file survives a failed write.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/sim/lidar_sensor.h"
#include "pcl_delaunay_walk/core/sim/surface_sampler.h"

namespace dw {
namespace sim {

void writeKittiScan(const std::string& path, const LidarScan& scan);
/// Throws dw::Error naming the file for a missing file or a size that is not a multiple of 16 bytes.
LidarScan readKittiScan(const std::string& path);

void writeKittiPoses(const std::string& path, const std::vector<Eigen::Isometry3d>& poses);
/// Throws dw::Error naming the file and line for a line without exactly 12 finite numbers or a
/// rotation block that is not a rotation (|R^T R - I| > 1e-4, det < 0). Blank lines are skipped.
std::vector<Eigen::Isometry3d> readKittiPoses(const std::string& path);

/// LAS classes of the map: 2 ground, 6 building (facade details too), 5 high vegetation (crowns and
/// trunks), 64 pole (user-defined range), 1 for cars (unclassified: movable).
unsigned lasClass(SurfaceKind kind);

/// Writes the map; the format follows the extension: .ply (binary little endian, float x y z),
/// .pcd (binary, float x y z) or .las (LAS 1.4 format 6, 1 mm scale, with the classes above).
/// Throws dw::Error for another extension or an I/O failure.
void writeMapCloud(const std::string& path, const SurfaceSamples& map);

}  // namespace sim
}  // namespace dw
