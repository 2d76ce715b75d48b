/// \file rigid_estimation.h
/// \brief The two rigid-increment estimators of the ICP loop, as sums that blocks of correspondences
/// fill independently and that are then added in block order (so the result does not depend on the
/// thread count):
///   - point-to-point: weighted Umeyama (closed form by SVD of the cross-covariance; with unit
///     weights the estimate of pcl::TransformationEstimationSVD / pcl::umeyama);
///   - point-to-plane: one Gauss-Newton step of r = n . (p - q) linearised in (omega, t), the 6x6
///     normal equations solved by LDLT, the rotation made exact by Rodrigues' formula.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dw {
namespace registration_detail {

/// Sums for the closed form. Coordinates are taken relative to a reference point shared by all
/// blocks (the first correspondence), so the covariance is not a small difference of large sums.
struct PointToPointSums {
  double w = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
  Eigen::Matrix3d qp = Eigen::Matrix3d::Zero();  ///< sum w (q - ref_q)(p - ref_p)^T

  void add(const Eigen::Vector3d& ps, const Eigen::Vector3d& qs, double weight) {
    w += weight;
    p += weight * ps;
    q += weight * qs;
    qp += weight * qs * ps.transpose();
  }
  void add(const PointToPointSums& o) {
    w += o.w;
    p += o.p;
    q += o.q;
    qp += o.qp;
  }
};

/// The rigid transform taking the (reference-shifted) source points onto the targets in the
/// weighted least-squares sense. Identity when the sums are empty.
Eigen::Matrix4d solvePointToPoint(const PointToPointSums& s, const Eigen::Vector3d& ref_p,
                                  const Eigen::Vector3d& ref_q);

/// The normal equations of point-to-plane ICP in the reference-shifted frame.
struct PointToPlaneSums {
  Eigen::Matrix<double, 6, 6> h = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();

  /// p: source point (shifted), n: target normal, r: residual n . (p - q), weight: kernel weight.
  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double r, double weight) {
    Eigen::Matrix<double, 6, 1> j;
    j.head<3>() = p.cross(n);
    j.tail<3>() = n;
    h.selfadjointView<Eigen::Upper>().rankUpdate(j, weight);
    g += weight * r * j;
  }
  void add(const PointToPlaneSums& o) {
    h += o.h;
    g += o.g;
  }
};

/// The increment of one Gauss-Newton step, in caller coordinates. Identity when the system is
/// singular (e.g. all normals parallel leave a direction unconstrained: that direction is not moved).
Eigen::Matrix4d solvePointToPlane(const PointToPlaneSums& s, const Eigen::Vector3d& ref_p);

}  // namespace registration_detail
}  // namespace dw
