#include "core/registration/rigid_estimation.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>

namespace dw {
namespace registration_detail {

Eigen::Matrix4d solvePointToPoint(const PointToPointSums& s, const Eigen::Vector3d& ref_p,
                                  const Eigen::Vector3d& ref_q) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  if (!(s.w > 0)) return t;
  const Eigen::Vector3d mp = s.p / s.w, mq = s.q / s.w;
  // Cross-covariance of the demeaned sets (Umeyama 1991, eq. 38, the scale fixed at 1).
  const Eigen::Matrix3d sigma = s.qp / s.w - mq * mp.transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d d = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) d(2) = -1;  // a reflection otherwise
  const Eigen::Matrix3d r = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
  t.topLeftCorner<3, 3>() = r;
  // q = R (p - ref_p - mp) + ref_q + mq, i.e. t = ref_q + mq - R (ref_p + mp).
  t.topRightCorner<3, 1>() = (ref_q + mq) - r * (ref_p + mp);
  return t;
}

Eigen::Matrix4d solvePointToPlane(const PointToPlaneSums& s, const Eigen::Vector3d& ref_p) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  const Eigen::Matrix<double, 6, 6> h = s.h.selfadjointView<Eigen::Upper>();
  Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(h);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return t;
  const Eigen::Matrix<double, 6, 1> x = ldlt.solve(-s.g);
  if (!x.allFinite()) return t;
  const Eigen::Vector3d omega = x.head<3>();
  const double angle = omega.norm();
  const Eigen::Matrix3d r =
      angle > 0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  // The step is p' = R (p - ref) + ref + t_local in the shifted frame.
  t.topLeftCorner<3, 3>() = r;
  t.topRightCorner<3, 1>() = ref_p + x.tail<3>() - r * ref_p;
  return t;
}

}  // namespace registration_detail
}  // namespace dw
