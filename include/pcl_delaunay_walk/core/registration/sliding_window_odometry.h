/// \file sliding_window_odometry.h
/// \brief LiDAR odometry on a sliding-window local map kept as a dw::DynamicDelaunayGraph: each frame is
/// registered onto the map by the ICP loop (exact nearest neighbours), then its downsampled points go
/// in (at most one per map voxel, as KISS-ICP's voxel hash) and points beyond a radius of the sensor,
/// or older than a number of frames, go out.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "pcl_delaunay_walk/core/graph/dynamic_delaunay_graph.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"

namespace dw {

struct OdometryOptions {
  IcpOptions icp;
  double voxel = 0.5;        ///< scan downsampling leaf and map voxel, metres (> 0)
  double max_range = 100.0;  ///< map points farther than this from the sensor are removed
  unsigned max_age = 0;      ///< frames a map point lives (0: no limit)
  double min_fitness = 0.3;  ///< LostTrack below this
  unsigned num_threads = 1;  ///< correspondence search threads (0: all cores)

  OdometryOptions() {
    icp.max_correspondence_distance = 1.0;
    icp.max_iterations = 30;
    icp.transformation_epsilon = 1e-8;
  }
};

/// Map maintenance counts and times, summed over frames.
struct OdometryMapStats {
  std::uint64_t inserted = 0, removed = 0;
  double insert_seconds = 0, remove_seconds = 0, graph_seconds = 0;
};

class SlidingWindowOdometry {
 public:
  explicit SlidingWindowOdometry(const OdometryOptions& options = {});

  /// Registers one scan (sensor coordinates) onto the local map and updates the map. The first
  /// frame defines the map frame (pose identity, or the one set by setPose). Never throws for bad
  /// scan content; a frame that is not Ok does not change the map.
  FrameResult registerScan(const PointView& scan);

  void setPose(const Eigen::Matrix4d& pose);
  const Eigen::Matrix4d& pose() const { return pose_; }
  const DynamicDelaunayGraph& map() const { return map_; }
  const OdometryMapStats& mapStats() const { return stats_; }
  std::size_t frames() const { return frame_; }

 private:
  using VoxelKey = std::uint64_t;
  VoxelKey voxelOf(const float p[3]) const;
  void updateMap(const std::vector<float>& scan_points, const Eigen::Matrix4d& pose);

  OdometryOptions options_;
  DynamicDelaunayGraph map_{std::array<double, 3>{{0.0, 0.0, 0.0}}};
  struct MapPoint {
    VoxelKey voxel;
    std::size_t frame;
    float xyz[3];
  };
  std::unordered_map<DynamicDelaunayGraph::PointId, MapPoint> points_;
  std::unordered_map<VoxelKey, DynamicDelaunayGraph::PointId> voxels_;
  IcpWorkspace workspace_;
  Eigen::Matrix4d pose_ = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d velocity_ = Eigen::Matrix4d::Identity();
  std::size_t frame_ = 0;
  OdometryMapStats stats_;
};

}  // namespace dw
