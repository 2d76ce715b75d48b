#include "pcl_delaunay_walk/core/registration/frame_track.h"

#include <Eigen/LU>
#include <chrono>
#include <cmath>

#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"

namespace dw {

const char* toString(FrameStatus s) {
  switch (s) {
    case FrameStatus::Ok: return "ok";
    case FrameStatus::EmptyScan: return "empty scan";
    case FrameStatus::NoFinitePoints: return "no finite points";
    case FrameStatus::NoCorrespondences: return "no correspondences (scan outside the map?)";
    case FrameStatus::LostTrack: return "lost track";
  }
  return "?";
}

void FrameTrack::setPose(const Eigen::Matrix4d& pose) {
  pose_ = pose;
  velocity_.setIdentity();
  have_velocity_ = false;
}

Eigen::Matrix4d FrameTrack::predictedPose(bool constant_velocity) const {
  return constant_velocity && have_velocity_ ? Eigen::Matrix4d(pose_ * velocity_) : pose_;
}

FrameStatus FrameTrack::registeredStatus(IcpConvergence convergence, double fitness, double rmse,
                                         const Eigen::Matrix4d& pose, double min_fitness, double max_rmse) {
  if (convergence == IcpConvergence::NoCorrespondences) return FrameStatus::NoCorrespondences;
  if (!(fitness >= min_fitness) || !(rmse <= max_rmse) || !pose.allFinite()) return FrameStatus::LostTrack;
  return FrameStatus::Ok;
}

void FrameTrack::finish(FrameResult& r, FrameStatus status, const Eigen::Matrix4d& guess) {
  r.status = status;
  if (status == FrameStatus::Ok) {
    velocity_ = pose_.inverse() * r.pose;
    have_velocity_ = true;
  } else {
    r.pose = guess;  // the track coasts on the prediction
  }
  pose_ = r.pose;
}

FrameResult FrameTrack::registerFrame(const PointView& scan, const FrameRules& rules, const FrameIcp& icp) {
  const auto t0 = std::chrono::steady_clock::now();
  FrameResult r;
  const Eigen::Matrix4d guess = predictedPose(rules.constant_velocity);
  r.pose = guess;
  auto end = [&](FrameStatus status) {
    finish(r, status, guess);
    r.latency_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
  };
  if (scan.size == 0) return end(FrameStatus::EmptyScan);
  const std::vector<float> pts = voxelDownsample(scan, rules.voxel);
  r.points = pts.size() / 3;
  if (r.points == 0) return end(FrameStatus::NoFinitePoints);
  if (!guess.allFinite()) {
    r.convergence = IcpConvergence::NoCorrespondences;
    return end(FrameStatus::NoCorrespondences);
  }
  const IcpResult result = icp(pts, guess);
  r.iterations = result.iterations;
  r.convergence = result.convergence;
  r.search_seconds = result.search_seconds;
  r.fitness = double(result.correspondences) / double(r.points);
  r.rmse = std::sqrt(result.mse);
  if (result.convergence != IcpConvergence::NoCorrespondences) r.pose = result.transform;
  return end(registeredStatus(r.convergence, r.fitness, r.rmse, r.pose, rules.min_fitness, rules.max_rmse));
}

}  // namespace dw
