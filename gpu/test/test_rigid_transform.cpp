// Horn's quaternion step (rigid_transform.h) against PCL's SVD rule with its reflection fix. Host only:
// runs everywhere, no GPU needed.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "pcl_delaunay_walk/gpu/rigid_transform.h"

namespace {

Eigen::Matrix3d svdRotation(const Eigen::Matrix3d& h) {  // TransformationEstimationSVD's R = V U^T
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU(), v = svd.matrixV();
  if (u.determinant() * v.determinant() < 0) v.col(2) *= -1.0;
  return v * u.transpose();
}

Eigen::Matrix3d hornRotation(const Eigen::Matrix3d& h) {
  double s[3][3], r[9];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) s[a][b] = h(a, b);
  dw::gpu::rotationFromCrossCovariance(s, r);
  Eigen::Matrix3d out;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) out(a, b) = r[3 * a + b];
  return out;
}

TEST(RigidTransform, HornEqualsSvdOnRandomPointSets) {
  std::mt19937 rng(17);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Matrix3d rot =
        Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    for (int i = 0; i < 30; ++i) {
      const Eigen::Vector3d p(n(rng), n(rng), 0.2 * n(rng));
      const Eigen::Vector3d t = rot * p + 0.05 * Eigen::Vector3d(n(rng), n(rng), n(rng));
      h += p * t.transpose();
    }
    const Eigen::Matrix3d a = hornRotation(h), b = svdRotation(h);
    EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
    EXPECT_NEAR(a.determinant(), 1.0, 1e-12);
    EXPECT_LT((a * a.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(RigidTransform, ReflectionIsNeverReturned) {
  // A cross-covariance whose best orthogonal fit is a reflection: both methods must give a rotation.
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  h.diagonal() << 3.0, 2.0, -1.0;
  const Eigen::Matrix3d a = hornRotation(h), b = svdRotation(h);
  EXPECT_NEAR(a.determinant(), 1.0, 1e-12);
  EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(RigidTransform, IdentityForAlignedSets) {
  Eigen::Matrix3d h;
  h << 2.0, 0.1, 0.0, 0.1, 1.5, 0.2, 0.0, 0.2, 0.7;  // symmetric positive definite: R = I
  EXPECT_LT((hornRotation(h) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace
