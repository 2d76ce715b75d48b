/// \file predicates_3d_lanes.h
/// \brief The Delaunay kernel's two hot predicates for float points, with a tetrahedron's four
/// vertices in the four lanes of a vector: insphere (the conflict test, ~43 per inserted point) and
/// orient3dFaces (a visibility-walk step, ~4 per point), and both at once for an insertion's walk.
///
/// Every lane performs the very operations of the scalar filters (detail::insphereDeterminant,
/// predicates::orient3dFaces), on the same operands and in the same order; the vector only runs
/// four of them side by side. So every value, and the semi-static filter's decision, is the same
/// double bit for bit, with the same guarantee, and where the filter cannot decide the same
/// out-of-line code runs. Bit-identity holds because IEEE operations round lanes exactly as
/// scalars, x - y*w equals x + y*(-w), and u - w is exactly -(w - u) (round to nearest); like the
/// scalar filters it needs the core's -ffp-contract=off. test_predicates_3d compares them bit for bit.
///
/// Written with generic vectors (vector_size, __builtin_shufflevector: GCC 12+ and Clang), so the
/// kernel's baseline and x86-64-v3 versions both compile it (as two SSE2 halves, or AVX), and so does
/// the Clang fuzzing build.
#pragma once

#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace predicates {

namespace detail {
/// insphereTail on the points converted to double; out of line, so that the inline filter keeps
/// nothing in registers for it.
[[gnu::cold]] double insphereTailOfFloats(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d,
                                          const double* e);
/// orient3d for the faces in `undecided` (bit f: face f) of orient3dFacesLanes, where its filter
/// could not decide.
[[gnu::cold]] void orient3dFacesTailOfFloats(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d,
                                             const double* p, unsigned undecided, double out[4]);
}  // namespace detail

namespace lanes {
typedef double V4d __attribute__((vector_size(32)));
typedef long long V4dMask __attribute__((vector_size(32)));

constexpr V4dMask kNoSign = {0x7FFFFFFFFFFFFFFFLL, 0x7FFFFFFFFFFFFFFFLL, 0x7FFFFFFFFFFFFFFFLL,
                             0x7FFFFFFFFFFFFFFFLL};
}  // namespace lanes

// Shuffles and |v| as macros: __builtin_shufflevector (GCC 12+ and Clang; lane i takes the i-th
// index, 4..7 naming the second operand's lanes) needs constant indices, and a function passing a
// 32-byte vector by value draws GCC's warning that the ABI changes without AVX.
#define DW_LANES_ROTATE1(v) __builtin_shufflevector(v, v, 1, 2, 3, 0)
#define DW_LANES_ROTATE2(v) __builtin_shufflevector(v, v, 2, 3, 0, 1)
#define DW_LANES_ROTATE3(v) __builtin_shufflevector(v, v, 3, 0, 1, 2)
#define DW_LANES_REVERSE(v) __builtin_shufflevector(v, v, 3, 2, 1, 0)
// Lane-wise max of two vectors of non-negative numbers (the comparison's all-ones lanes select a).
#define DW_LANES_MAX(a, b)                                                                      \
  ((::dw::predicates::lanes::V4d)(                                                              \
      ((::dw::predicates::lanes::V4dMask)((a) > (b)) & (::dw::predicates::lanes::V4dMask)(a)) | \
      (~(::dw::predicates::lanes::V4dMask)((a) > (b)) & (::dw::predicates::lanes::V4dMask)(b))))
#define DW_LANES_ABS(v) \
  ((::dw::predicates::lanes::V4d)((::dw::predicates::lanes::V4dMask)(v) & ::dw::predicates::lanes::kNoSign))

/// A query point (the one being inserted) in every lane: broadcast once, used by every test.
struct BroadcastPoint {
  lanes::V4d x, y, z;
  double p[3];
  explicit BroadcastPoint(const double* e)
      : x{e[0], e[0], e[0], e[0]},
        y{e[1], e[1], e[1], e[1]},
        z{e[2], e[2], e[2], e[2]},
        p{e[0], e[1], e[2]} {}
};

namespace lanes {
/// What both predicates start from, computed as their scalar forms compute it: the four points less
/// the query, one vector per axis, and the xy minors m_ij = x_i y_j - x_j y_i of consecutive points,
/// m1 = (m01, m12, m23, m30), and of points two apart, m2 = (m02, m13, m20, m31).
struct Differences {
  V4d x, y, z, m1, m2;
  [[gnu::always_inline]] Differences(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d,
                                     const BroadcastPoint& p)
      : x(V4d{a.x, b.x, c.x, d.x} - p.x),
        y(V4d{a.y, b.y, c.y, d.y} - p.y),
        z(V4d{a.z, b.z, c.z, d.z} - p.z),
        m1(x * DW_LANES_ROTATE1(y) - DW_LANES_ROTATE1(x) * y),
        m2(x * DW_LANES_ROTATE2(y) - DW_LANES_ROTATE2(x) * y) {}
};

/// insphere's semi-static filter on differences made already (insphereLanesFilter's body).
[[gnu::always_inline]] inline bool insphereFilterOf(const Differences& q, double& det) {
  // Minors (ab, bc, cd, da) and (ac, bd, -ac, -bd).
  const V4d &x = q.x, &y = q.y, &z = q.z, &m1 = q.m1, &m2 = q.m2;
  // (abc, bcd, cda, dab): e.g. abc = aez bc - bez ac + cez ab, and cda = cez da + dez ac + aez cd,
  // whose middle term is here dez ac = -(dez (-ac)).
  const V4d det3 = (z * DW_LANES_ROTATE1(m1) - DW_LANES_ROTATE1(z) * m2) + DW_LANES_ROTATE2(z) * m1;
  const V4d lift = (x * x + y * y) + z * z;
  // (dlift abc, alift bcd, blift cda, clift dab); the determinant is (first - last) + (third - second).
  const V4d terms = DW_LANES_ROTATE3(lift) * det3;
  const V4d pairs = terms - DW_LANES_REVERSE(terms);
  det = pairs[0] + pairs[2];
  const double l = detail::maxOf(detail::maxOf(lift[0], lift[1]), detail::maxOf(lift[2], lift[3]));
  // The scalar filter's test (predicates::insphere).
  const double l2 = l * l, l5 = l2 * l2 * l;
  return l5 > detail::kStaticMinSq && det * det > detail::kIspStaticSq * l5;
}
}  // namespace lanes

/// insphere's semi-static filter for float a..d: true when it decides, and then `det` is insphere's
/// value (non-zero). The conflict test branches on this directly: insphere's value compared with zero
/// again cost ~5 instructions a test.
[[gnu::always_inline]] inline bool insphereLanesFilter(const Vec3f& a, const Vec3f& b, const Vec3f& c,
                                                       const Vec3f& d, const BroadcastPoint& e, double& det) {
  return lanes::insphereFilterOf(lanes::Differences(a, b, c, d, e), det);
}

/// insphere(a, b, c, d, e) for float a..d: the same value, sign-exact (see the file comment).
[[gnu::always_inline]] inline double insphereLanes(const Vec3f& a, const Vec3f& b, const Vec3f& c,
                                                   const Vec3f& d, const BroadcastPoint& e) {
  double det;
  if (insphereLanesFilter(a, b, c, d, e, det)) return det;
  return detail::insphereTailOfFloats(a, b, c, d, e.p);
}

namespace lanes {
/// orient3dFacesLanes' filtered values on differences made already: out[f] as there where the filter
/// decides; returns the faces it left undecided (bit f: face f).
[[gnu::always_inline]] inline unsigned orient3dFacesOf(const Differences& q, double out[4]) {
  // The scalar form's m03, m32 and m13 are exact negations of m1's and m2's lanes.
  const V4d &x = q.x, &y = q.y, &z = q.z, &m1 = q.m1, &m2 = q.m2;
  // Lane f sums the three products of out[f] in the scalar order, out[0..2]'s leading minus
  // folded into the minors (exact):
  //   out[0] = -(z3 m12 + z1 m23 + z2 m31)   out[1] = -(z0 m32 + z3 m20 + z2 m03)
  //   out[2] = -(z0 m13 + z1 m30 + z3 m01)   out[3] = z0 m12 + z1 m20 + z2 m01
  //   minors of t1: (-m12, m23, m31, m12), of t2: (-m23, m02 = -m20, -m30 = m03, m20),
  //   of t3: (-m31, m30, -m01, m01).
  const V4d sign1 = {-1.0, 1.0, 1.0, 1.0}, sign2 = {-1.0, 1.0, -1.0, 1.0}, sign3 = {-1.0, 1.0, -1.0, 1.0};
  const V4d t1 =
      __builtin_shufflevector(z, z, 3, 0, 0, 0) * (__builtin_shufflevector(m1, m2, 1, 2, 7, 1) * sign1);
  const V4d t2 =
      __builtin_shufflevector(z, z, 1, 3, 1, 1) * (__builtin_shufflevector(m1, m2, 2, 4, 3, 6) * sign2);
  const V4d t3 =
      __builtin_shufflevector(z, z, 2, 2, 3, 2) * (__builtin_shufflevector(m1, m2, 7, 3, 0, 0) * sign3);
  const V4d o = (t1 + t2) + t3;
  // The scalar filter: with M the largest |difference|, |out[f]| > kO3dStatic M^3 decides.
  const V4d ax = DW_LANES_ABS(x), ay = DW_LANES_ABS(y), az = DW_LANES_ABS(z);
  const V4d axy = DW_LANES_MAX(ax, ay), axyz = DW_LANES_MAX(axy, az);
  const double m = detail::maxOf(detail::maxOf(axyz[0], axyz[1]), detail::maxOf(axyz[2], axyz[3]));
  const double m3 = m * m * m;
  const double bound = m3 > detail::kStaticMin ? detail::kO3dStatic * m3 : HUGE_VAL;
  const auto decided = DW_LANES_ABS(o) > V4d{bound, bound, bound, bound};
  for (int f = 0; f < 4; ++f) out[f] = o[f];
  return unsigned(decided[0] == 0) | unsigned(decided[1] == 0) << 1 | unsigned(decided[2] == 0) << 2 |
         unsigned(decided[3] == 0) << 3;
}
}  // namespace lanes

/// orient3dFaces for the tetrahedron (q0, q1, q2, q3) of float points and the query p: out[f] is
/// orient3d of the tetrahedron with p in place of q_f, sign-exact, and the same double as
/// orient3dFaces gives (see the file comment).
[[gnu::always_inline]] inline void orient3dFacesLanes(const Vec3f& q0, const Vec3f& q1, const Vec3f& q2,
                                                      const Vec3f& q3, const BroadcastPoint& p,
                                                      double out[4]) {
  const unsigned undecided = lanes::orient3dFacesOf(lanes::Differences(q0, q1, q2, q3, p), out);
  if (__builtin_expect(undecided != 0, 0))
    detail::orient3dFacesTailOfFloats(q0, q1, q2, q3, p.p, undecided, out);
}

/// A walk step that may stop in the cavity: true when insphere's filter decides that p lies strictly
/// inside the circumsphere of (q0, q1, q2, q3) (insphereLanesFilter's decision, bit for bit);
/// otherwise false, with out[] as orient3dFacesLanes gives it. Both from one set of differences.
[[gnu::always_inline]] inline bool insideSphereOrFacesLanes(const Vec3f& q0, const Vec3f& q1, const Vec3f& q2,
                                                            const Vec3f& q3, const BroadcastPoint& p,
                                                            double out[4]) {
  const lanes::Differences q(q0, q1, q2, q3, p);
  double det;
  if (lanes::insphereFilterOf(q, det) && det > 0.0) return true;
  const unsigned undecided = lanes::orient3dFacesOf(q, out);
  if (__builtin_expect(undecided != 0, 0))
    detail::orient3dFacesTailOfFloats(q0, q1, q2, q3, p.p, undecided, out);
  return false;
}

}  // namespace predicates
}  // namespace dw

#undef DW_LANES_ROTATE1
#undef DW_LANES_ROTATE2
#undef DW_LANES_ROTATE3
#undef DW_LANES_REVERSE
#undef DW_LANES_MAX
#undef DW_LANES_ABS
