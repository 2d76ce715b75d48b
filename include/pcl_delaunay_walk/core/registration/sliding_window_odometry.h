/// \file sliding_window_odometry.h
/// \brief LiDAR odometry on a sliding-window local map kept as a dw::DynamicDelaunayGraph: each frame is
/// registered onto the map by the ICP loop (exact nearest neighbours), then its downsampled points go
/// in (at most one per map voxel, as KISS-ICP's voxel hash) and points beyond a radius of the sensor,
/// or older than a number of frames, go out. A point that goes out is retired: never a correspondence
/// again, but left in the triangulation until the retired points outnumber a share of the live ones;
/// then the live points are triangulated afresh in one batch. Deleting a Delaunay vertex costs about
/// twenty insertions (the hole is re-triangulated from its link), so batching the deletions into an
/// insertion of the survivors makes the window's upkeep several times cheaper.
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
  /// The triangulation is rebuilt from the live points when the retired ones exceed this share of
  /// them; 0 deletes every frame's retired points from the triangulation at once.
  double compact_ratio = 1.0;

  OdometryOptions() {
    icp.max_correspondence_distance = 1.0;
    icp.max_iterations = 30;
    icp.transformation_epsilon = 1e-8;
  }
};

/// Map maintenance counts and times, summed over frames.
struct OdometryMapStats {
  std::uint64_t inserted = 0, removed = 0;
  std::uint64_t compactions = 0;  ///< rebuilds of the triangulation from the live points
  /// remove_seconds: retiring, deleting and compacting (the rebuilds' time, spread over the removals)
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
  /// The window's triangulation, of its live points only (retired points are compacted out first).
  const DynamicDelaunayGraph& map() const;
  /// Live points in the window (without compacting).
  std::size_t mapSize() const { return points_.size(); }
  /// Points retired from the window but still in the triangulation.
  std::size_t retiredSize() const { return retired_.size(); }
  const OdometryMapStats& mapStats() const { return stats_; }
  std::size_t frames() const { return frame_; }

 private:
  using VoxelKey = std::uint64_t;
  VoxelKey voxelOf(const float p[3]) const;
  using Id = DynamicDelaunayGraph::PointId;
  void updateMap(const std::vector<float>& scan_points, const Eigen::Matrix4d& pose);
  void retire(const Eigen::Vector3d& sensor);
  /// The frame's points in the map frame that go in: one per empty voxel, none equal to a retired
  /// point (which comes back instead). Appends to `in` / `keys`.
  void selectNewPoints(const std::vector<float>& scan_points, const Eigen::Matrix4d& pose,
                       std::vector<float>& in, std::vector<VoxelKey>& keys);
  /// Rebuilds the triangulation from the live points (new ids) and forgets the retired ones.
  void compact() const;
  /// One flag per input of the walk graph whose inputs are `ids`: retired or live.
  std::vector<std::uint8_t> retiredFlags(const std::vector<Id>& ids) const;

  struct MapPoint {
    VoxelKey voxel;
    std::size_t frame;
    float xyz[3];
  };
  OdometryOptions options_;
  // The triangulation of the live and the retired points; compacting it changes no answer, so the
  // const map() may do it.
  mutable DynamicDelaunayGraph map_{std::array<double, 3>{{0.0, 0.0, 0.0}}};
  mutable std::unordered_map<Id, MapPoint> points_;  ///< the live points
  mutable std::unordered_map<Id, MapPoint> retired_;
  mutable std::unordered_map<VoxelKey, Id> voxels_;  ///< the live point of each occupied voxel
  mutable OdometryMapStats stats_;
  IcpWorkspace workspace_;
  Eigen::Matrix4d pose_ = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d velocity_ = Eigen::Matrix4d::Identity();
  std::size_t frame_ = 0;
};

}  // namespace dw
