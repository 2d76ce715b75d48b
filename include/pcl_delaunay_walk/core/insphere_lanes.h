/// \file insphere_lanes.h
/// \brief predicates::insphere for float points, with the tetrahedron's four vertices in the four
/// lanes of a vector: the Delaunay kernel's conflict test (~43 per inserted point).
///
/// Every lane performs the very operations of detail::insphereDeterminant, on the same operands and
/// in the same order (the vector only runs four of them side by side), so the determinant and the
/// largest lift are the same doubles bit for bit, and the same semi-static filter decides with the
/// same guarantee. Where it cannot, the same out-of-line tail runs. Bit-identity holds because IEEE
/// operations on lanes round exactly as on scalars, x - y*w equals x + y*(-w), and u - w is exactly
/// -(w - u); it needs the core's -ffp-contract=off, like the scalar filter. test_predicates_3d
/// compares the two bit for bit.
///
/// Scalar, the conflict test converted 12 coordinates and evaluated ~87 separate operations; in
/// lanes the same work is ~30 vector operations and a transpose. Written with GCC's generic vectors,
/// so the kernel's baseline and x86-64-v3 versions both compile it (as two SSE2 halves, or AVX).
#pragma once

#include "pcl_delaunay_walk/core/predicates_3d.h"
#include "pcl_delaunay_walk/core/types.h"

namespace dw {
namespace predicates {

namespace detail {
/// insphereTail on the points converted to double; out of line, so that the inline filter keeps
/// nothing in registers for it.
[[gnu::cold]] double insphereTailOfFloats(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d,
                                          const double* e);
}  // namespace detail

namespace lanes {
typedef double V4d __attribute__((vector_size(32)));
typedef long long V4dMask __attribute__((vector_size(32)));

// Lane i takes lane i + k (mod 4). Masks rather than functions: a function passing a 32-byte vector
// by value draws GCC's warning that the ABI changes without AVX.
constexpr V4dMask kRotate1 = {1, 2, 3, 0}, kRotate2 = {2, 3, 0, 1}, kRotate3 = {3, 0, 1, 2};
constexpr V4dMask kReverse = {3, 2, 1, 0};
}  // namespace lanes

/// The point being inserted, broadcast once per insertion.
struct InsphereQuery {
  lanes::V4d x, y, z;
  double p[3];
  explicit InsphereQuery(const double* e)
      : x{e[0], e[0], e[0], e[0]},
        y{e[1], e[1], e[1], e[1]},
        z{e[2], e[2], e[2], e[2]},
        p{e[0], e[1], e[2]} {}
};

/// insphere(a, b, c, d, e) for float a..d: the same value, sign-exact (see the file comment).
[[gnu::always_inline]] inline double insphereLanes(const Vec3f& a, const Vec3f& b, const Vec3f& c,
                                                   const Vec3f& d, const InsphereQuery& e) {
  using lanes::V4d;
  const V4d x = V4d{a.x, b.x, c.x, d.x} - e.x;
  const V4d y = V4d{a.y, b.y, c.y, d.y} - e.y;
  const V4d z = V4d{a.z, b.z, c.z, d.z} - e.z;
  // The xy minors of consecutive points, (ab, bc, cd, da), and of points two apart, (ac, bd, -ac, -bd).
  const V4d m1 = x * __builtin_shuffle(y, lanes::kRotate1) - __builtin_shuffle(x, lanes::kRotate1) * y;
  const V4d m2 = x * __builtin_shuffle(y, lanes::kRotate2) - __builtin_shuffle(x, lanes::kRotate2) * y;
  // (abc, bcd, cda, dab): e.g. abc = aez bc - bez ac + cez ab, and cda = cez da + dez ac + aez cd,
  // whose middle term is here dez ac = -(dez (-ac)).
  const V4d det3 = (z * __builtin_shuffle(m1, lanes::kRotate1) - __builtin_shuffle(z, lanes::kRotate1) * m2) +
                   __builtin_shuffle(z, lanes::kRotate2) * m1;
  const V4d lift = (x * x + y * y) + z * z;
  // (dlift abc, alift bcd, blift cda, clift dab); the determinant is (first - last) + (third - second).
  const V4d terms = __builtin_shuffle(lift, lanes::kRotate3) * det3;
  const V4d pairs = terms - __builtin_shuffle(terms, lanes::kReverse);
  const double det = pairs[0] + pairs[2];
  const double l = detail::maxOf(detail::maxOf(lift[0], lift[1]), detail::maxOf(lift[2], lift[3]));
  // The scalar filter's test (predicates::insphere).
  const double l2 = l * l, l5 = l2 * l2 * l;
  if (l5 > detail::kStaticMinSq && det * det > detail::kIspStaticSq * l5) return det;
  return detail::insphereTailOfFloats(a, b, c, d, e.p);
}

}  // namespace predicates
}  // namespace dw
