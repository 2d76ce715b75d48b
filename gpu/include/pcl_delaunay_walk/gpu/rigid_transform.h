/// \file rigid_transform.h
/// \brief The 3x3 step of point-to-point ICP on the device: the proper rotation that best maps centred
/// source points onto centred target points, by Horn's quaternion method (the top eigenvector of a 4x4
/// symmetric matrix, found by cyclic Jacobi in double). It is the same optimum as PCL's SVD estimate with
/// its reflection fix (Umeyama / Kabsch), but needs no SVD and no branches on rank, so it runs in one
/// thread of the solve kernel. Header-only and callable from host code, so it is tested on its own.
#pragma once

#include <cmath>

#if defined(__CUDACC__)
#define DW_HOST_DEVICE __host__ __device__
#else
#define DW_HOST_DEVICE
#endif

namespace dw {
namespace gpu {

/// Eigen-decomposition of a symmetric 4x4 matrix by cyclic Jacobi rotations: on return a is (nearly)
/// diagonal with the eigenvalues and the columns of v are the eigenvectors.
DW_HOST_DEVICE inline void jacobiEigenSymmetric4(double a[4][4], double v[4][4]) {
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) v[i][j] = i == j ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 64; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (int p = 0; p < 4; ++p) {
      diag += a[p][p] * a[p][p];
      for (int q = p + 1; q < 4; ++q) off += a[p][q] * a[p][q];
    }
    if (off <= 1e-32 * diag || off == 0.0) break;  // converged to double precision
    for (int p = 0; p < 3; ++p) {
      for (int q = p + 1; q < 4; ++q) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        // the smaller root of t^2 + 2 theta t - 1 = 0 keeps the rotation angle below pi/4 (stable)
        const double t = (theta >= 0.0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < 4; ++k) {
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 4; ++k) {
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 4; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
  }
}

/// Rotation r (row-major 3x3) maximising sum_i t_i . (r p_i), given the centred cross-covariance
/// s[a][b] = sum_i p_i[a] * t_i[b] (p: source, t: target). Horn (1987), closed-form quaternion.
DW_HOST_DEVICE inline void rotationFromCrossCovariance(const double s[3][3], double r[9]) {
  const double sxx = s[0][0], sxy = s[0][1], sxz = s[0][2];
  const double syx = s[1][0], syy = s[1][1], syz = s[1][2];
  const double szx = s[2][0], szy = s[2][1], szz = s[2][2];
  double n[4][4] = {{sxx + syy + szz, syz - szy, szx - sxz, sxy - syx},
                    {syz - szy, sxx - syy - szz, sxy + syx, szx + sxz},
                    {szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy},
                    {sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz}};
  double v[4][4];
  jacobiEigenSymmetric4(n, v);
  int best = 0;
  for (int i = 1; i < 4; ++i)
    if (n[i][i] > n[best][best]) best = i;
  double w = v[0][best], x = v[1][best], y = v[2][best], z = v[3][best];
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  w /= norm;
  x /= norm;
  y /= norm;
  z /= norm;
  r[0] = w * w + x * x - y * y - z * z;
  r[1] = 2.0 * (x * y - w * z);
  r[2] = 2.0 * (x * z + w * y);
  r[3] = 2.0 * (x * y + w * z);
  r[4] = w * w - x * x + y * y - z * z;
  r[5] = 2.0 * (y * z - w * x);
  r[6] = 2.0 * (x * z - w * y);
  r[7] = 2.0 * (y * z + w * x);
  r[8] = w * w - x * x - y * y + z * z;
}

}  // namespace gpu
}  // namespace dw
