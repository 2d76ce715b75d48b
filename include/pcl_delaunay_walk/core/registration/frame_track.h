/// \file frame_track.h
/// \brief What a localizer keeps between frames and decides per frame, whatever runs its ICP (the
/// CPU dw::Localizer, the GPU dw::gpu::Localizer): the pose, the constant-velocity prediction of the
/// next one, and the per-frame status (empty or all-NaN scan, no correspondences, lost track). Both
/// localizers run every frame through FrameTrack::registerFrame, so they downsample, predict, judge and
/// coast by one rule and differ only in the ICP call they pass in.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <limits>
#include <vector>

#include "pcl_delaunay_walk/core/graph/point_view.h"
#include "pcl_delaunay_walk/core/registration/icp.h"

namespace dw {

/// What became of one frame. Every frame gets one; none throws.
enum class FrameStatus {
  Ok,
  EmptyScan,          ///< the scan has no points
  NoFinitePoints,     ///< every point is NaN/Inf
  NoCorrespondences,  ///< fewer than IcpOptions::min_correspondences map points within the distance:
                      ///< the scan is far outside the map (or the prediction is far off)
  LostTrack,          ///< registered, but the fitness or the RMSE is past its bound
};
const char* toString(FrameStatus s);

struct FrameResult {
  /// Sensor -> map. On a frame whose status is not Ok: the prediction, which the track continues from.
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  FrameStatus status = FrameStatus::Ok;
  IcpConvergence convergence = IcpConvergence::NotConverged;
  int iterations = 0;
  /// Fraction of the registered scan points with a map point within the correspondence distance,
  /// in the last iteration (Open3D's "fitness").
  double fitness = 0.0;
  double rmse = 0.0;           ///< of those correspondences, metres
  std::size_t points = 0;      ///< scan points registered (finite, after downsampling)
  double latency_seconds = 0;  ///< wall time of registerScan, downsampling included
  double search_seconds = 0;   ///< of which in the correspondence search (0 where the ICP runs on a GPU)
};

/// The localizer options the frame bracket reads (both localizers fill it from dw::LocalizerOptions).
struct FrameRules {
  double voxel = 0.0;  ///< scan downsampling leaf in metres (0: full resolution, NaN/Inf dropped)
  bool constant_velocity = true;
  double min_fitness = 0.3;
  double max_rmse = std::numeric_limits<double>::infinity();
};

/// The ICP of one frame: registers `scan` (finite float xyz, 3 per point) from `guess` (finite).
using FrameIcp = std::function<IcpResult(const std::vector<float>& scan, const Eigen::Matrix4d& guess)>;

/// The pose of a tracked sensor and its last frame-to-frame motion.
class FrameTrack {
 public:
  /// One frame, whatever runs its ICP: the prediction as the guess; EmptyScan without points;
  /// the voxel filter (which drops NaN/Inf); NoFinitePoints when nothing is left; NoCorrespondences
  /// without calling `icp` when the guess is not finite (a caller's setPose: every moved point would
  /// be NaN); else `icp`, its result fields and registeredStatus; then finish. latency_seconds is the
  /// wall time of the whole call. Never throws for scan content; what `icp` throws passes through.
  FrameResult registerFrame(const PointView& scan, const FrameRules& rules, const FrameIcp& icp);

  /// Sets the current pose (sensor -> map) and forgets the motion.
  void setPose(const Eigen::Matrix4d& pose);
  const Eigen::Matrix4d& pose() const { return pose_; }
  /// The guess the next frame starts from: pose * last motion (body frame) when `constant_velocity`
  /// and a motion is known, else the pose.
  Eigen::Matrix4d predictedPose(bool constant_velocity) const;

  /// The status of a frame whose ICP ran: NoCorrespondences when the loop found too few, LostTrack
  /// when the fitness is below `min_fitness`, the RMSE above `max_rmse` or the pose not finite, else
  /// Ok. NaN fitness or RMSE count as past the bound.
  static FrameStatus registeredStatus(IcpConvergence convergence, double fitness, double rmse,
                                      const Eigen::Matrix4d& pose, double min_fitness, double max_rmse);

  /// Ends a frame: sets r.status; an Ok frame becomes the pose and gives the motion from the previous
  /// one, any other frame coasts (r.pose = guess, which becomes the pose; the motion is kept).
  void finish(FrameResult& r, FrameStatus status, const Eigen::Matrix4d& guess);

 private:
  Eigen::Matrix4d pose_ = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d velocity_ = Eigen::Matrix4d::Identity();  ///< last frame-to-frame motion (body frame)
  bool have_velocity_ = false;
};

}  // namespace dw
