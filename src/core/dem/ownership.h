/// \file ownership.h
/// \brief The rule that gives every cell centre one owning triangle (internal; see tin_raster.h): p is
/// on the inner side of the directed edge u -> v when it is strictly left of it, or on it and the fixed
/// infinitesimal shift p + (e, e^2) moves it to the left (v.y < u.y, or v.y == u.y and v.x > u.x).
/// The same rule decides whether a centre lies inside a convex hull (counter-clockwise).
#pragma once

#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"

namespace dw {
namespace dem {
namespace detail {

inline bool ownsEdge(double ux, double uy, double vx, double vy, double px, double py) {
  const int o = pred::orient2d(ux, uy, vx, vy, px, py);
  if (o != 0) return o > 0;
  return vy < uy || (vy == uy && vx > ux);
}

}  // namespace detail
}  // namespace dem
}  // namespace dw
