// A host ICP that follows PCL 1.13 rule for rule (IterativeClosestPoint::computeTransformation,
// TransformationEstimationSVD, DefaultConvergenceCriteria), with exact NN from the core's CPU walk.
// It is the reference the GPU loop is tested against; it never touches the GPU code paths.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"

namespace dwgpu_test {

struct ReferenceIcpResult {
  Eigen::Matrix4d transformation = Eigen::Matrix4d::Identity();
  int iterations = 0;
  dw::gpu::ConvergenceState state = dw::gpu::ConvergenceState::NotConverged;
  bool converged = false;
};

inline ReferenceIcpResult referenceIcp(const dw::NeighbourSearch& target,
                                       const std::vector<double>& source_xyz, const dw::gpu::IcpParameters& p,
                                       const Eigen::Matrix4d& guess) {
  using dw::gpu::ConvergenceState;
  const dw::DelaunayGraph& g = target.graph();
  const Eigen::Vector3d origin(g.origin[0], g.origin[1], g.origin[2]);
  // PCL keeps the transformed source as float points and transforms it in place every iteration.
  std::vector<Eigen::Vector3f> cur;
  for (std::size_t i = 0; i + 2 < source_xyz.size(); i += 3) {
    const Eigen::Vector3d s(source_xyz[i], source_xyz[i + 1], source_xyz[i + 2]);
    if (!s.allFinite()) continue;
    cur.push_back((guess.topLeftCorner<3, 3>() * s + guess.topRightCorner<3, 1>()).cast<float>());
  }
  ReferenceIcpResult r;
  r.transformation = guess;
  const double max_d2 = p.max_correspondence_distance * p.max_correspondence_distance;
  const double rot_th = p.transformation_rotation_epsilon > 0 ? p.transformation_rotation_epsilon
                                                              : 1.0 - p.transformation_epsilon;
  double prev_mse = std::numeric_limits<double>::max();
  int similar = 0;
  std::vector<Eigen::Vector3d> cs, ct;
  std::vector<double> cd;
  do {
    cs.clear();
    ct.clear();
    cd.clear();
    for (const auto& q : cur) {
      const dw::Vec3f ql = g.toLocal(q.x(), q.y(), q.z());
      const dw::WalkResult w = target.nearest(ql, dw::StartStrategy::KdAnn);
      if (w.vertex == dw::kInvalidIndex || double(w.dist2) > max_d2) continue;
      const auto& t = g.points[w.vertex];
      cs.push_back(q.cast<double>());
      ct.push_back(Eigen::Vector3d(t.x, t.y, t.z) + origin);
      cd.push_back(w.dist2);
    }
    if (cs.size() < p.min_number_correspondences) {
      r.state = ConvergenceState::NoCorrespondences;
      r.converged = false;
      break;
    }
    Eigen::Vector3d ms = Eigen::Vector3d::Zero(), mt = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < cs.size(); ++i) {
      ms += cs[i];
      mt += ct[i];
    }
    ms /= double(cs.size());
    mt /= double(cs.size());
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < cs.size(); ++i) h += (cs[i] - ms) * (ct[i] - mt).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d u = svd.matrixU(), v = svd.matrixV();
    if (u.determinant() * v.determinant() < 0) v.col(2) *= -1.0;
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    step.topLeftCorner<3, 3>() = v * u.transpose();
    step.topRightCorner<3, 1>() = mt - step.topLeftCorner<3, 3>() * ms;
    const Eigen::Matrix4f stepf = step.cast<float>();
    for (auto& q : cur) q = stepf.topLeftCorner<3, 3>() * q + stepf.topRightCorner<3, 1>();
    r.transformation = step * r.transformation;
    ++r.iterations;

    // DefaultConvergenceCriteria::hasConverged
    bool is_similar = false, done = false;
    if (r.iterations >= p.max_iterations) {
      if (!p.failure_after_max_iterations) {
        r.state = ConvergenceState::Iterations;
        break;
      }
      r.state = ConvergenceState::FailureAfterMaxIterations;
    }
    double cos_angle = 0.5 * (step(0, 0) + step(1, 1) + step(2, 2) - 1.0);
    double tsq = step.topRightCorner<3, 1>().squaredNorm();
    if (p.float_transform_criteria) {  // PCL's expressions on its float Matrix4, evaluated in float
      const Eigen::Matrix4f sf = step.cast<float>();
      const float trace = sf(0, 0) + sf(1, 1) + sf(2, 2) - 1.f;
      const float t2 = sf(0, 3) * sf(0, 3) + sf(1, 3) * sf(1, 3) + sf(2, 3) * sf(2, 3);
      cos_angle = 0.5 * trace;
      tsq = t2;
    }
    if (cos_angle >= rot_th && tsq <= p.transformation_epsilon) {
      if (similar >= p.max_iterations_similar_transforms) {
        r.state = ConvergenceState::Transform;
        break;
      }
      is_similar = true;
    }
    double mse = 0.0;
    for (double d : cd) mse += d;
    mse /= double(cd.size());
    if (std::abs(mse - prev_mse) < p.mse_threshold_absolute) {
      if (similar >= p.max_iterations_similar_transforms) {
        r.state = ConvergenceState::AbsMse;
        break;
      }
      is_similar = true;
    }
    if (std::abs(mse - prev_mse) / prev_mse < p.euclidean_fitness_epsilon) {
      if (similar >= p.max_iterations_similar_transforms) {
        r.state = ConvergenceState::RelMse;
        break;
      }
      is_similar = true;
    }
    similar = is_similar ? similar + 1 : 0;
    prev_mse = mse;
    done = r.state == ConvergenceState::FailureAfterMaxIterations;
    if (done) break;
  } while (true);
  r.converged = r.state != ConvergenceState::NotConverged && r.state != ConvergenceState::NoCorrespondences &&
                r.state != ConvergenceState::FailureAfterMaxIterations;
  return r;
}

inline Eigen::Matrix4d toEigen(const dw::gpu::Matrix4d& m) {
  Eigen::Matrix4d e;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) e(r, c) = m[4 * r + c];
  return e;
}
inline dw::gpu::Matrix4d fromEigen(const Eigen::Matrix4d& e) {
  dw::gpu::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[4 * r + c] = e(r, c);
  return m;
}

}  // namespace dwgpu_test
