/// \file las_cloud.h
/// \brief LAS and LAZ inputs of the PCL apps that work on float xyz clouds (dw_graph, dw_icp).
/// Georeferenced tiles do not fit float (5e6 m keeps half-metre steps), so a tile is loaded relative
/// to an origin on its integer grid near the data's centre (pcl::io::loadLASFile), and a second tile
/// is moved into the first one's frame in double before its one rounding to float. The frame is
/// deterministic (the header's bounds), so the same file gives the same floats in every app: a graph
/// saved by dw_graph matches dw_icp's target.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/io/las_io.h"

namespace dw_apps {

/// True for names ending in .las or .laz (any case).
inline bool isLasPath(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".las" || ext == ".laz";
}

/// A LAS/LAZ file's points relative to `origin`. `centre` false: world coordinates (origin 0), for a
/// tile used beside a PLY/PCD cloud in world coordinates. Throws (dw::las::LasError) on a bad file.
inline pcl::PointCloud<pcl::PointXYZ> loadLasCloud(const std::string& path, Eigen::Vector3d& origin,
                                                   bool centre = true) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::io::LASLoadOptions o;
  o.centre = centre;
  pcl::io::loadLASFile(path, cloud, &origin, o);
  if (cloud.empty()) throw dw::Error("'" + path + "' has no points");
  return cloud;
}

/// Moves points stored relative to `from` so that they are relative to `to`.
inline void reframe(pcl::PointCloud<pcl::PointXYZ>& cloud, const Eigen::Vector3d& from,
                    const Eigen::Vector3d& to) {
  const Eigen::Vector3d d = from - to;
  for (auto& p : cloud) {
    p.x = float(double(p.x) + d.x());
    p.y = float(double(p.y) + d.y());
    p.z = float(double(p.z) + d.z());
  }
}

inline void printLasOrigin(const Eigen::Vector3d& origin) {
  std::printf("LAS origin   %.6f %.6f %.6f (subtracted from the points; world = point + origin)\n",
              origin.x(), origin.y(), origin.z());
}

}  // namespace dw_apps
