// Exact affine span test: a point distinct from the first, then one off their line, then one off their
// plane. Exact predicates, so a float-rounded "nearly flat" set counts as 3D exactly when the kernel can
// triangulate it.
#include "affine_span.h"

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
}  // namespace dw
