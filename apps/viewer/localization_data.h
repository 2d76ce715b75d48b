/// \file localization_data.h
/// \brief What the viewer's localization mode shows, computed apart from the drawing: the scan moved
/// by its estimated pose, each point's distance to the map by the Delaunay walk, the error of the
/// estimate against the truth, and the trajectories as polylines.
///
/// The walk runs on the map points near the scan only: every map point within `cap` of a scan point
/// lies in a voxel (edge >= cap) next to that scan point's voxel, so the crop answers exactly for
/// every distance below `cap`, and distances from `cap` up are shown as `cap`, the end of the colour
/// scale. A 10M-point map thus costs a graph of the seen surfaces, not of the whole city.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_set>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/sim/dataset_files.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "viewer/cloud_input.h"

namespace dw_viewer {

/// Points of a scan or map: KITTI .bin (x, y, z of each record) or anything loadXyz reads.
inline XyzPoints loadPointsAnyFormat(const std::string& path, int las_class = -1) {
  if (detail::lowerExtension(path) != "bin") return loadXyz(path, las_class);
  dw::sim::LidarScan scan;
  try {
    scan = dw::sim::readKittiScan(path);
  } catch (const dw::Error& e) {
    throw dw::Error(std::string("dw_viewer: ") + e.what());
  }
  XyzPoints pts;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const float* p = &scan.xyzi[4 * i];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      ++pts.skipped;
      continue;
    }
    pts.xyz.insert(pts.xyz.end(), {p[0], p[1], p[2]});
    pts.input_index.push_back(static_cast<std::uint32_t>(i));
  }
  if (pts.size() == 0) throw dw::Error("dw_viewer: " + path + " has no finite points");
  return pts;
}

/// KITTI poses, with the file named in errors.
inline std::vector<Eigen::Isometry3d> loadPoses(const std::string& path) {
  try {
    auto poses = dw::sim::readKittiPoses(path);
    if (poses.empty()) throw dw::Error(path + " holds no pose");
    return poses;
  } catch (const dw::Error& e) {
    throw dw::Error(std::string("dw_viewer: cannot read poses ") + e.what());
  }
}

struct ScanOnMap {
  std::vector<double> xyz;      ///< the scan in the map frame (3 per point)
  std::vector<float> distance;  ///< to the nearest map point, capped at `cap`
  double cap = 0;
  std::size_t crop_points = 0;  ///< map points the graph was built on
  double build_seconds = 0, query_seconds = 0;

  /// The q-quantile of the distances (q in [0, 1]).
  double quantile(double q) const {
    if (distance.empty()) return 0.0;
    std::vector<float> d = distance;
    const std::size_t k = static_cast<std::size_t>(q * (d.size() - 1));
    std::nth_element(d.begin(), d.begin() + k, d.end());
    return d[k];
  }
  std::size_t atCap() const {
    return static_cast<std::size_t>(
        std::count_if(distance.begin(), distance.end(), [&](float d) { return d >= cap; }));
  }
};

namespace detail {
inline std::uint64_t voxelKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  // 21 bits per axis. Beyond +-2^20 voxels (georeferenced maps) keys wrap and distant voxels share a
  // key: the crop then holds extra points, never fewer, so the distances stay exact.
  const std::uint64_t m = (1u << 21) - 1;
  return ((static_cast<std::uint64_t>(x + (1 << 20)) & m) << 42) |
         ((static_cast<std::uint64_t>(y + (1 << 20)) & m) << 21) |
         (static_cast<std::uint64_t>(z + (1 << 20)) & m);
}
}  // namespace detail

/// Moves `scan` (sensor frame) by `pose` and measures every point's distance to `map` with the walk.
inline ScanOnMap scanOnMap(const XyzPoints& map, const XyzPoints& scan, const Eigen::Isometry3d& pose,
                           double cap, unsigned threads) {
  using Clock = std::chrono::steady_clock;
  ScanOnMap out;
  out.cap = cap;
  out.xyz.resize(scan.xyz.size());
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3d p =
        pose * Eigen::Vector3d(scan.xyz[3 * i], scan.xyz[3 * i + 1], scan.xyz[3 * i + 2]);
    for (int k = 0; k < 3; ++k) out.xyz[3 * i + k] = p[k];
  }
  const double voxel = std::max(cap, 0.25);
  auto cell = [&](double v) { return static_cast<std::int64_t>(std::floor(v / voxel)); };
  std::unordered_set<std::uint64_t> near;
  near.reserve(scan.size() * 4);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const std::int64_t x = cell(out.xyz[3 * i]), y = cell(out.xyz[3 * i + 1]), z = cell(out.xyz[3 * i + 2]);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) near.insert(detail::voxelKey(x + dx, y + dy, z + dz));
  }
  std::vector<double> crop;
  for (std::size_t i = 0; i < map.size(); ++i)
    if (near.count(
            detail::voxelKey(cell(map.xyz[3 * i]), cell(map.xyz[3 * i + 1]), cell(map.xyz[3 * i + 2]))))
      crop.insert(crop.end(), {map.xyz[3 * i], map.xyz[3 * i + 1], map.xyz[3 * i + 2]});
  out.crop_points = crop.size() / 3;
  out.distance.assign(scan.size(), static_cast<float>(cap));
  if (crop.empty()) return out;
  const auto t0 = Clock::now();
  dw::BuildOptions bo;
  bo.num_threads = threads;
  const auto graph = std::make_shared<const dw::DelaunayGraph>(
      dw::buildDelaunayGraph(dw::PointView::fromDouble(crop.data(), crop.size() / 3), bo));
  const auto t1 = Clock::now();
  const dw::NeighbourSearch search(graph);
  const unsigned workers = dw::workerCount(scan.size(), threads, 4096);
  dw::parallelFor(scan.size(), workers, [&](std::size_t b, std::size_t e, unsigned) {
    dw::WalkResult prev;  // consecutive scan points are neighbours: the last answer is a good start
    for (std::size_t i = b; i < e; ++i) {
      const dw::Vec3f q = graph->toLocal(out.xyz[3 * i], out.xyz[3 * i + 1], out.xyz[3 * i + 2]);
      prev = search.nearest(q, dw::StartStrategy::PnnOptimized, prev.vertex);
      out.distance[i] = std::min(static_cast<float>(cap), std::sqrt(prev.dist2));
    }
  });
  out.build_seconds = std::chrono::duration<double>(t1 - t0).count();
  out.query_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
  return out;
}

/// Translation (m) and rotation (degrees) of the error estimate^-1 * truth.
inline std::array<double, 2> poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d e = estimate.inverse() * truth;
  return {{e.translation().norm(), Eigen::AngleAxisd(e.linear()).angle() * 180.0 / 3.141592653589793}};
}

/// The trajectory's positions as line segments relative to `origin` (6 floats each).
inline std::vector<float> trajectorySegments(const std::vector<Eigen::Isometry3d>& poses,
                                             const std::array<double, 3>& origin) {
  std::vector<float> seg;
  for (std::size_t k = 1; k < poses.size(); ++k)
    for (const auto* T : {&poses[k - 1], &poses[k]})
      for (int c = 0; c < 3; ++c) seg.push_back(static_cast<float>(T->translation()[c] - origin[c]));
  return seg;
}

}  // namespace dw_viewer
