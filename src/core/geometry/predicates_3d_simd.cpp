// The cold paths of the lane predicates: their filters could not decide.
#include "predicates_3d_simd.h"

namespace dw {
namespace predicates {
namespace detail {

double insphereTailOfFloats(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d, const double* e) {
  const double da[3] = {a.x, a.y, a.z}, db[3] = {b.x, b.y, b.z}, dc[3] = {c.x, c.y, c.z},
               dd[3] = {d.x, d.y, d.z};
  return insphereTail(da, db, dc, dd, e);
}

void orient3dFacesTailOfFloats(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d,
                               const double* p, unsigned undecided, double out[4]) {
  // As predicates::orient3dFaces: orient3d with p in slot f.
  const double q[4][3] = {{a.x, a.y, a.z}, {b.x, b.y, b.z}, {c.x, c.y, c.z}, {d.x, d.y, d.z}};
  for (int f = 0; f < 4; ++f) {
    if (!(undecided >> f & 1u)) continue;
    out[f] = orient3d(f == 0 ? p : q[0], f == 1 ? p : q[1], f == 2 ? p : q[2], f == 3 ? p : q[3]);
  }
}

}  // namespace detail
}  // namespace predicates
}  // namespace dw
