// The affine dimension, exact (affineSpan: a point distinct from the first, then one off their line,
// then one off their plane; a float-rounded "nearly flat" set counts as 3D exactly when the kernel can
// triangulate it) and within a tolerance (toleranceAffineDimension: farthest points, in double).
#include "affine_span.h"

#include <algorithm>
#include <cmath>

#include "core/geometry/vec3d.h"
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"

namespace dw {
namespace builder3d {
namespace {

void toDouble(const Vec3f& p, double out[3]) {
  out[0] = p.x;
  out[1] = p.y;
  out[2] = p.z;
}

// Three points are collinear iff all three axis-plane projections are.
bool collinear(const double* a, const double* b, const double* c) {
  for (int k = 0; k < 3; ++k) {
    const int i = k, j = (k + 1) % 3;
    const double pa[2] = {a[i], a[j]}, pb[2] = {b[i], b[j]}, pc[2] = {c[i], c[j]};
    if (predicates::orient2d(pa, pb, pc) != 0.0) return false;
  }
  return true;
}

}  // namespace

int affineSpan(const Vec3f* points, const index_t* ids, std::size_t n, std::size_t positions[4]) {
  if (n == 0) return -1;
  double p0[3], p1[3], p2[3], q[3];
  toDouble(points[ids[0]], p0);
  std::size_t k1 = 1;
  for (; k1 < n; ++k1) {
    toDouble(points[ids[k1]], p1);
    if (p1[0] != p0[0] || p1[1] != p0[1] || p1[2] != p0[2]) break;
  }
  if (k1 >= n) return 0;
  std::size_t k2 = k1 + 1;
  for (; k2 < n; ++k2) {
    toDouble(points[ids[k2]], p2);
    if (!collinear(p0, p1, p2)) break;
  }
  if (k2 >= n) return 1;
  for (std::size_t k3 = k1 + 1; k3 < n; ++k3) {
    if (k3 == k2) continue;
    toDouble(points[ids[k3]], q);
    if (predicates::orient3d(p0, p1, p2, q) != 0.0) {
      if (positions) {
        positions[0] = 0;
        positions[1] = k1;
        positions[2] = k2;
        positions[3] = k3;
      }
      return 3;
    }
  }
  return 2;
}

bool spans3D(const Vec3f* points, const index_t* ids, std::size_t n, index_t* tetrahedron) {
  std::size_t k[4];
  if (affineSpan(points, ids, n, k) != 3) return false;
  if (tetrahedron)
    for (int j = 0; j < 4; ++j) tetrahedron[j] = ids[k[j]];
  return true;
}

}  // namespace builder3d

int toleranceAffineDimension(const std::vector<Vec3f>& p, double basis[6], double rel_tol) {
  if (p.empty()) return 0;
  const auto p0 = toVec3d(p[0]);
  std::size_t i1 = 0;
  double best = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto d = sub(toVec3d(p[i]), p0);
    const double l = dot(d, d);
    if (l > best) best = l, i1 = i;
  }
  if (best == 0) return 0;
  const double extent = std::sqrt(best);
  const double tol = rel_tol * extent;
  auto dir = sub(toVec3d(p[i1]), p0);
  for (double& c : dir) c /= extent;
  std::size_t i2 = 0;
  best = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto d = sub(toVec3d(p[i]), p0);
    const auto c = cross(dir, d);
    const double l = dot(c, c);
    if (l > best) best = l, i2 = i;
  }
  basis[0] = dir[0], basis[1] = dir[1], basis[2] = dir[2];
  if (std::sqrt(best) <= tol) return 1;
  auto w = sub(toVec3d(p[i2]), p0);
  const double t = dot(w, dir);
  for (int a = 0; a < 3; ++a) w[a] -= t * dir[a];
  const double wl = std::sqrt(dot(w, w));
  for (double& c : w) c /= wl;
  basis[3] = w[0], basis[4] = w[1], basis[5] = w[2];
  const auto nrm = cross(dir, w);
  double off = 0;
  for (const Vec3f& q : p) off = std::max(off, std::fabs(dot(sub(toVec3d(q), p0), nrm)));
  return off <= tol ? 2 : 3;
}

}  // namespace dw
