/// \file icp_sequence.h
/// \brief ICP-like query sequences: the source points as an ICP run moves them, iteration by
/// iteration. This is the query order the walk is built for (seed §4: each query is close to the
/// previous iteration's answer for the same point), so the NN benchmarks replay it for every peer.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "nn_method.h"
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

/// One point-to-point ICP run (SVD/Umeyama, as PCL's TransformationEstimationSVD) of `source` onto
/// `target` with the exact NN of `nn` (already built over target): pairs farther than max_dist are
/// left out of each step, and the run stops after max_iterations or when the update is below PCL's
/// transformation criteria at epsilon `eps`. `nn`'s hints carry from iteration to iteration (PNN).
struct IcpResult {
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  ///< final pose (target ~ pose * source)
  std::vector<Eigen::Matrix4d, Eigen::aligned_allocator<Eigen::Matrix4d>>
      poses;  ///< pose at each iteration's start
  bool converged = false;
  double nn_seconds = 0, solve_seconds = 0;  ///< process CPU time of the NN batches and of the rest
};

inline IcpResult pointToPointIcp(const std::vector<float>& source, const std::vector<float>& target,
                                 NnMethod& nn, std::size_t max_iterations, double max_dist = 1e300,
                                 double eps = 1e-11, unsigned threads = 1) {
  IcpResult run;
  const std::size_t n = source.size() / 3;
  NnBatch batch;
  batch.resize(n);
  batch.resetHints();
  Eigen::Matrix3Xd src(3, n), dst(3, n);
  const double max2 = max_dist < 1e150 ? max_dist * max_dist : 1e300;
  for (std::size_t it = 0; it < max_iterations; ++it) {
    run.poses.push_back(run.pose);
    // CPU time: steady on a shared machine (with threads > 1 it sums the threads' time).
    const double t0 = processCpuSeconds();
    const std::vector<float> q = transformed(source, run.pose);
    const double t1 = processCpuSeconds();
    nn.nearest(q.data(), n, batch, threads);
    const double t2 = processCpuSeconds();
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = static_cast<std::size_t>(batch.index[i]);
      const Eigen::Vector3d a(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
      const Eigen::Vector3d b(target[3 * k], target[3 * k + 1], target[3 * k + 2]);
      if ((a - b).squaredNorm() > max2) continue;
      src.col(m) = a, dst.col(m) = b, ++m;
    }
    if (m < 3) break;
    const Eigen::Matrix4d step = Eigen::umeyama(src.leftCols(m), dst.leftCols(m), false);
    run.pose = step * run.pose;
    run.nn_seconds += t2 - t1;
    run.solve_seconds += (t1 - t0) + (processCpuSeconds() - t2);
    // PCL's DefaultConvergenceCriteria: the update is "similar to identity".
    const double cos_angle = 0.5 * (step.topLeftCorner<3, 3>().trace() - 1.0);
    if (cos_angle >= 1.0 - eps && step.topRightCorner<3, 1>().squaredNorm() <= eps) {
      run.converged = true;
      break;
    }
  }
  return run;
}

/// Runs point-to-point ICP of `target` rotated by `rot` onto `target` (pointToPointIcp) and keeps its
/// per-iteration poses: the query sequence.
inline IcpSequence makeIcpSequence(const std::vector<float>& target, const Rotation& rot, NnMethod& reference,
                                   std::size_t max_iterations, double eps = 1e-11) {
  IcpSequence seq;
  seq.source = transformed(target, rot.about(centroid(target)));
  seq.poses = pointToPointIcp(seq.source, target, reference, max_iterations, 1e300, eps).poses;
  return seq;
}

/// The query sequence of a real pair: `source` (e.g. the next LiDAR frame) registered onto `target`,
/// pairs beyond max_dist rejected as ICP does with a correspondence distance.
inline IcpSequence makeIcpSequence(const std::vector<float>& source, const std::vector<float>& target,
                                   NnMethod& reference, std::size_t max_iterations, double max_dist,
                                   double eps = 1e-11) {
  IcpSequence seq;
  seq.source = source;
  seq.poses = pointToPointIcp(seq.source, target, reference, max_iterations, max_dist, eps).poses;
  return seq;
}

}  // namespace dwb
