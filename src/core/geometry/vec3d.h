/// \file vec3d.h
/// \brief Double-precision 3-vectors for the few geometric set-up computations (affine dimension,
/// plane bases) that must not round like the float point storage.
#pragma once

#include <array>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

using Vec3d = std::array<double, 3>;

inline Vec3d toVec3d(const Vec3f& a) {
  return {a.x, a.y, a.z};
}
inline Vec3d sub(const Vec3d& a, const Vec3d& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline double dot(const Vec3d& a, const Vec3d& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace dw
