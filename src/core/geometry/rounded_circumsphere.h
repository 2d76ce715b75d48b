/// \file rounded_circumsphere.h
/// \brief The circumsphere of a tetrahedron, enlarged by a bound on its rounding: the ball inside which
/// a point may conflict with the tetrahedron, as the block builders (threads and MPI) certify it.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace builder3d {

struct RoundedCircumsphere {
  double centre[3] = {0.0, 0.0, 0.0};
  /// Radius plus a rounding bound; +inf (or NaN) for a flat sliver, whose ball may hold any point.
  double radius = 0.0;
  bool unbounded() const { return !std::isfinite(radius); }
};

/// Circumsphere of the tetrahedron (a, b, c, d) computed in double from the float vertices, its
/// radius enlarged by 64 eps (L^4 + r L^3) / |det| (L the longest edge from a, det the edge
/// triple product: a generous bound on the rounding of the centre and radius) plus 1e-9 (r + scale),
/// `scale` the caller's cell size. Points strictly outside that ball cannot be in conflict.
inline RoundedCircumsphere roundedCircumsphere(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d,
                                               double scale) {
  const Vec3f* vertex[4] = {&a, &b, &c, &d};
  double P[4][3];
  for (unsigned k = 0; k < 4; ++k) P[k][0] = vertex[k]->x, P[k][1] = vertex[k]->y, P[k][2] = vertex[k]->z;
  double u[3], v[3], w[3];
  for (int k = 0; k < 3; ++k) u[k] = P[1][k] - P[0][k], v[k] = P[2][k] - P[0][k], w[k] = P[3][k] - P[0][k];
  const double vxw[3] = {v[1] * w[2] - v[2] * w[1], v[2] * w[0] - v[0] * w[2], v[0] * w[1] - v[1] * w[0]};
  const double wxu[3] = {w[1] * u[2] - w[2] * u[1], w[2] * u[0] - w[0] * u[2], w[0] * u[1] - w[1] * u[0]};
  const double uxv[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  const double vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  const double ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  const double det = u[0] * vxw[0] + u[1] * vxw[1] + u[2] * vxw[2];
  double off[3], r = 0.0;
  for (int k = 0; k < 3; ++k) {
    off[k] = (uu * vxw[k] + vv * wxu[k] + ww * uxv[k]) / (2.0 * det);
    r += off[k] * off[k];
  }
  r = std::sqrt(r);
  const double L = std::sqrt(std::max({uu, vv, ww}));
  const double eps = std::numeric_limits<double>::epsilon();
  const double margin = 64.0 * eps * (L * L * L * L + r * L * L * L) / std::fabs(det) + 1e-9 * (r + scale);
  RoundedCircumsphere s;
  s.radius = r + margin;
  for (int k = 0; k < 3; ++k) s.centre[k] = P[0][k] + off[k];
  return s;
}

}  // namespace builder3d
}  // namespace dw
