#include "pcl_delaunay_walk/core/registration/frame_track.h"

#include <Eigen/LU>

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

}  // namespace dw
