/// \file datasets.h
/// \brief The benchmark data sets (seed §5: teapot, bunny, dragon, plus one real LiDAR frame), loaded
/// from the shared data folder, with the gzipped dragons unpacked once into the build directory.
#pragma once

#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "point_files.h"

namespace dwb {

/// One reference cloud: finite points only (every peer gets exactly the same input), xyz floats.
struct Dataset {
  std::string name;    ///< protocol name, e.g. "dragon-100k"
  std::string source;  ///< file it came from
  std::vector<float> xyz;
  std::size_t size() const { return xyz.size() / 3; }
};

/// Data set names in protocol order (small to large). A ":half" suffix keeps every second point (the
/// seed's "downsampled by 2" fidelity for sets we have at one resolution only), ":quarter" every
/// fourth (the half of a ":half" base, where the full set is too big for the rotation grid).
inline std::vector<std::string> knownDatasets() {
  return {"teapot-792", "dragon-5k", "bunny-8k",    "dragon-23k",
          "bunny-36k",  "lidar-69k", "dragon-100k", "dragon-437k"};
}

/// The finite points of a file as floats: PCD through PCL, PLY and KITTI .bin through the core reader.
inline std::vector<float> loadFiniteXyz(const std::string& path) {
  std::vector<float> xyz;
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".pcd") == 0) {
    pcl::PointCloud<pcl::PointXYZ> cloud;
    if (pcl::io::loadPCDFile(path, cloud) != 0) throw dw::Error("dw_bench: cannot read PCD '" + path + "'");
    xyz.reserve(cloud.size() * 3);
    for (const auto& p : cloud.points) appendFinite(xyz, p.x, p.y, p.z);
  } else {
    const std::vector<double> raw = dw::readPointsXyz(path);
    xyz.reserve(raw.size());
    for (std::size_t i = 0; i + 2 < raw.size(); i += 3) appendFinite(xyz, raw[i], raw[i + 1], raw[i + 2]);
  }
  return xyz;
}

/// Loads a data set by protocol name; throws dw::Error for an unknown name or a missing file.
inline Dataset loadDataset(const std::string& full_name) {
  std::string name = full_name;
  std::size_t stride = 1;  // keep every stride-th point
  for (const auto& [suffix, k] : {std::pair<std::string, std::size_t>{":half", 2}, {":quarter", 4}})
    if (name.size() > suffix.size() &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      stride = k;
      name.resize(name.size() - suffix.size());
      break;
    }
  struct Entry {
    const char* name;
    const char* subdir;
    const char* file;
  };
  static const Entry entries[] = {
      {"teapot-792", "models", "teapot_points.ply"},    {"bunny-8k", "models", "bun_zipper_res2.ply"},
      {"bunny-36k", "models", "bun_zipper.ply"},        {"dragon-5k", "models", "dragon_vrip_res4.ply"},
      {"dragon-23k", "models", "dragon_vrip_res3.ply"}, {"dragon-100k", "models", "dragon_vrip_res2.ply.gz"},
      {"dragon-437k", "models", "dragon_vrip.ply.gz"},  {"lidar-69k", "scans", "fastgicp_251370668.pcd"},
  };
  const Entry* e = nullptr;
  for (const auto& c : entries)
    if (name == c.name) e = &c;
  if (!e) {
    std::string msg = "dw_bench: unknown data set '" + full_name + "' (known:";
    for (const auto& c : entries) msg += std::string(" ") + c.name;
    throw dw::Error(msg + "; append :half or :quarter for every second or fourth point)");
  }
  Dataset d;
  d.name = full_name;
  std::string path = findDataFile(e->subdir, e->file);
  const std::string file = e->file;
  if (file.size() > 3 && file.compare(file.size() - 3, 3, ".gz") == 0) path = gunzipToCache(path);
  d.source = path;
  d.xyz = loadFiniteXyz(path);
  if (stride > 1) {
    std::vector<float> kept;
    kept.reserve(d.xyz.size() / stride + 3);
    for (std::size_t i = 0; i < d.size(); i += stride)
      kept.insert(kept.end(), &d.xyz[3 * i], &d.xyz[3 * i] + 3);
    d.xyz.swap(kept);
  }
  if (d.size() == 0) throw dw::Error("dw_bench: data set '" + full_name + "' has no finite points");
  return d;
}

/// A pcl::PointCloud view of a data set (what PCL's searches and ICP take).
inline pcl::PointCloud<pcl::PointXYZ>::Ptr toCloud(const std::vector<float>& xyz) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
  c->resize(xyz.size() / 3);
  for (std::size_t i = 0; i < c->size(); ++i)
    (*c)[i] = pcl::PointXYZ(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  c->width = static_cast<std::uint32_t>(c->size());
  c->height = 1;
  c->is_dense = true;
  return c;
}

}  // namespace dwb
