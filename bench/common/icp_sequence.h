/// \file icp_sequence.h
/// \brief ICP-like query sequences: the source points as an ICP run moves them, iteration by
/// iteration. This is the query order the walk is built for (seed §4: each query is close to the
/// previous iteration's answer for the same point), so the NN benchmarks replay it for every peer.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "nn_methods.h"
#include "rotation_protocol.h"

namespace dwb {

/// Per-iteration transforms of a point-to-point ICP run and the source they apply to.
struct IcpSequence {
  std::vector<float> source;                                                      ///< xyz of the moving cloud
  std::vector<Eigen::Matrix4d, Eigen::aligned_allocator<Eigen::Matrix4d>> poses;  ///< pose at each iteration
  std::size_t numQueries() const { return source.size() / 3 * poses.size(); }
  /// The queries of iteration t (the source under poses[t]).
  std::vector<float> queries(std::size_t t) const { return transformed(source, poses[t]); }
};

/// Runs point-to-point ICP (SVD/Umeyama, as PCL's TransformationEstimationSVD) of `target` rotated
/// by `rot` onto `target`, with the exact NN of `reference` (already built over target). Stops after
/// max_iterations or when the update is below PCL's transformation criteria at epsilon `eps`.
inline IcpSequence makeIcpSequence(const std::vector<float>& target, const Rotation& rot, NnMethod& reference,
                                   std::size_t max_iterations, double eps = 1e-11) {
  IcpSequence seq;
  seq.source = transformed(target, rot.about(centroid(target)));
  const std::size_t n = seq.source.size() / 3;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  NnBatch nn;
  Eigen::Matrix3Xd src(3, n), dst(3, n);
  for (std::size_t it = 0; it < max_iterations; ++it) {
    seq.poses.push_back(pose);
    const std::vector<float> q = transformed(seq.source, pose);
    reference.nearest(q.data(), n, nn);
    for (std::size_t i = 0; i < n; ++i) {
      src.col(i) = Eigen::Vector3d(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
      const std::size_t k = static_cast<std::size_t>(nn.index[i]);
      dst.col(i) = Eigen::Vector3d(target[3 * k], target[3 * k + 1], target[3 * k + 2]);
    }
    const Eigen::Matrix4d step = Eigen::umeyama(src, dst, false);
    pose = step * pose;
    // PCL's DefaultConvergenceCriteria: the update is "similar to identity".
    const double cos_angle = 0.5 * (step.topLeftCorner<3, 3>().trace() - 1.0);
    if (cos_angle >= 1.0 - eps && step.topRightCorner<3, 1>().squaredNorm() <= eps) break;
  }
  return seq;
}

}  // namespace dwb
