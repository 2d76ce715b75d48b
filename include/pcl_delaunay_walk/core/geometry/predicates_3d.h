/// \file predicates_3d.h
/// \brief Robust 3D predicates for the Delaunay kernels: orient3d and insphere with a floating-point
/// filter (Shewchuk 1997, stage A error bounds) and an exact fallback in expansion arithmetic
/// (dw::exact), plus insphere under symbolic perturbation (simulation of simplicity) keyed on the
/// points' global ids, so that cospherical ties get one consistent answer everywhere.
///
/// Sign conventions follow Shewchuk:
///  - orient3d(a, b, c, d) > 0 when d lies below the plane through a, b, c (a, b, c counter-clockwise
///    seen from above), i.e. det[a-d; b-d; c-d] > 0;
///  - insphere(a, b, c, d, e) > 0 when e lies inside the sphere through a, b, c, d, provided
///    orient3d(a, b, c, d) > 0 (the sign flips with the orientation).
/// The exact results are exact for any finite double input (no overflow/underflow assumed).
#pragma once

#include <cmath>
#include <cstdint>

namespace dw {
namespace predicates {

namespace detail {
/// Exact fallbacks (expansion arithmetic); called only when the filter cannot decide.
double orient3dExact(const double* a, const double* b, const double* c, const double* d);
double insphereExact(const double* a, const double* b, const double* c, const double* d, const double* e);
double orient2dExact(const double* a, const double* b, const double* c);
/// What the inline filters leave: Shewchuk's stage-A bound on the permanent, then the exact value.
/// They recompute the determinant through the same function as the inline part
/// (orient3dDeterminant, insphereDeterminant), so the value returned when the bound decides is the
/// very same double.
double orient3dTail(const double* a, const double* b, const double* c, const double* d);
double insphereTail(const double* a, const double* b, const double* c, const double* d, const double* e);

// Shewchuk's stage-A error bound coefficients with eps = 2^-53.
constexpr double kEps = 1.1102230246251565e-16;
constexpr double kO3dBoundA = (7.0 + 56.0 * kEps) * kEps;
constexpr double kIspBoundA = (16.0 + 224.0 * kEps) * kEps;
constexpr double kO2dBoundA = (3.0 + 16.0 * kEps) * kEps;

// Semi-static filters: before the permanent is formed, the same stage-A bound is tried with the
// permanent replaced by an upper bound from M, the largest |coordinate difference| (orient3d: at most
// 6 M^3, insphere: 72 M^5, from the numbers of products; the factors add room for rounding). insphere
// uses L, the largest lift (|difference|^2, already computed; M^2 <= L) and compares squares:
// det^2 > C^2 L^5. Cheaper than the permanent; valid whenever the powers neither overflow (the bound
// is then inf and the test fails) nor underflow (guarded: below kStaticMin the permanent is formed).
constexpr double kO3dStatic = kO3dBoundA * 6.0 * (1.0 + 16.0 * kEps);
constexpr double kIspStaticSq =
    (kIspBoundA * 72.0 * (1.0 + 64.0 * kEps)) * (kIspBoundA * 72.0 * (1.0 + 64.0 * kEps));
constexpr double kStaticMin = 1e-250;
constexpr double kStaticMinSq = 1e-280;
/// max for the filters (maxsd; std::fmax's NaN rules cost a call or a blend).
inline double maxOf(double a, double b) {
  return a > b ? a : b;
}
inline double maxAbs(double a, double b, double c, double d) {
  return maxOf(maxOf(std::fabs(a), std::fabs(b)), maxOf(std::fabs(c), std::fabs(d)));
}

/// orient3d's determinant (see the convention below), the largest |coordinate difference| (for the
/// semi-static filter) and, with kPermanent, Shewchuk's permanent of the same products (for stage A).
/// One definition for the inline filter and the out-of-line tail: inlined with kPermanent false, the
/// permanent's terms are never formed, so the fast path keeps everything in registers.
template <bool kPermanent>
[[gnu::always_inline]] inline double orient3dDeterminant(const double* a, const double* b, const double* c,
                                                         const double* d, double& max_diff,
                                                         double& permanent) {
  const double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
  const double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
  const double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  max_diff = maxOf(maxOf(maxAbs(adx, ady, adz, bdx), maxAbs(bdy, bdz, cdx, cdy)), std::fabs(cdz));
  if constexpr (kPermanent)
    permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * std::fabs(adz) +
                (std::fabs(cdxady) + std::fabs(adxcdy)) * std::fabs(bdz) +
                (std::fabs(adxbdy) + std::fabs(bdxady)) * std::fabs(cdz);
  return adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
}

/// insphere's determinant, the largest lift |p - e|^2 (for the semi-static filter) and, with
/// kPermanent, Shewchuk's permanent (for stage A); as orient3dDeterminant, one definition for both.
template <bool kPermanent>
[[gnu::always_inline]] inline double insphereDeterminant(const double* a, const double* b, const double* c,
                                                         const double* d, const double* e, double& max_lift,
                                                         double& permanent) {
  const double aex = a[0] - e[0], aey = a[1] - e[1], aez = a[2] - e[2];
  const double bex = b[0] - e[0], bey = b[1] - e[1], bez = b[2] - e[2];
  const double cex = c[0] - e[0], cey = c[1] - e[1], cez = c[2] - e[2];
  const double dex = d[0] - e[0], dey = d[1] - e[1], dez = d[2] - e[2];
  const double aexbey = aex * bey, bexaey = bex * aey, ab = aexbey - bexaey;
  const double bexcey = bex * cey, cexbey = cex * bey, bc = bexcey - cexbey;
  const double cexdey = cex * dey, dexcey = dex * cey, cd = cexdey - dexcey;
  const double dexaey = dex * aey, aexdey = aex * dey, da = dexaey - aexdey;
  const double aexcey = aex * cey, cexaey = cex * aey, ac = aexcey - cexaey;
  const double bexdey = bex * dey, dexbey = dex * bey, bd = bexdey - dexbey;
  const double abc = aez * bc - bez * ac + cez * ab;
  const double bcd = bez * cd - cez * bd + dez * bc;
  const double cda = cez * da + dez * ac + aez * cd;
  const double dab = dez * ab + aez * bd + bez * da;
  const double alift = aex * aex + aey * aey + aez * aez;
  const double blift = bex * bex + bey * bey + bez * bez;
  const double clift = cex * cex + cey * cey + cez * cez;
  const double dlift = dex * dex + dey * dey + dez * dez;
  max_lift = maxOf(maxOf(alift, blift), maxOf(clift, dlift));
  if constexpr (kPermanent) {
    const double aezp = std::fabs(aez), bezp = std::fabs(bez), cezp = std::fabs(cez), dezp = std::fabs(dez);
    const double aexbeyp = std::fabs(aexbey) + std::fabs(bexaey);
    const double bexceyp = std::fabs(bexcey) + std::fabs(cexbey);
    const double cexdeyp = std::fabs(cexdey) + std::fabs(dexcey);
    const double dexaeyp = std::fabs(dexaey) + std::fabs(aexdey);
    const double aexceyp = std::fabs(aexcey) + std::fabs(cexaey);
    const double bexdeyp = std::fabs(bexdey) + std::fabs(dexbey);
    permanent = ((cexdeyp * bezp + bexdeyp * cezp + bexceyp * dezp) * alift +
                 (dexaeyp * cezp + aexceyp * dezp + cexdeyp * aezp) * blift) +
                ((aexbeyp * dezp + bexdeyp * aezp + dexaeyp * bezp) * clift +
                 (bexceyp * aezp + aexceyp * bezp + aexbeyp * cezp) * dlift);
  }
  return (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
}
}  // namespace detail

/// Sign-exact orient2d on (x, y): positive when a, b, c turn counter-clockwise. The returned value has
/// the correct sign; its magnitude is approximate.
inline double orient2d(const double* a, const double* b, const double* c) {
  const double detleft = (a[0] - c[0]) * (b[1] - c[1]);
  const double detright = (a[1] - c[1]) * (b[0] - c[0]);
  const double det = detleft - detright;
  const double bound = detail::kO2dBoundA * (std::fabs(detleft) + std::fabs(detright));
  if (std::fabs(det) > bound) return det;
  return detail::orient2dExact(a, b, c);
}

/// Sign-exact orient3d (see the file comment for the convention). The inline part is what almost
/// every call needs (the semi-static filter); the rest is out of line (detail::orient3dTail), so the
/// fast path keeps its values in registers instead of spilling the permanent's terms.
inline double orient3d(const double* a, const double* b, const double* c, const double* d) {
  double m, unused;
  const double det = detail::orient3dDeterminant<false>(a, b, c, d, m, unused);
  const double m3 = m * m * m;
  if (m3 > detail::kStaticMin && std::fabs(det) > detail::kO3dStatic * m3) return det;
  return detail::orient3dTail(a, b, c, d);
}

/// The four orient3d of tetrahedron q with p in place of vertex f: out[f] = orient3d(q with q[f] := p),
/// each with the exact sign. What a visibility walk asks at every step; sharing the differences q[k] - p
/// and their xy minors costs about half of four separate calls. Each value is the very arithmetic of
/// orient3d(., ., ., p) on three of the q's (so its filter applies), negated where moving p to the last
/// slot is an odd permutation; an undecided one is recomputed by orient3d.
[[gnu::always_inline]] inline void orient3dFaces(const double q[4][3], const double* p, double out[4]) {
  double d[4][3];
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) d[k][c] = q[k][c] - p[c];
  // m(i, j) = d_i.x d_j.y - d_j.x d_i.y; det(i, j, k) = d_i.z m(j, k) + d_j.z m(k, i) + d_k.z m(i, j).
  auto minor = [&](int i, int j) { return d[i][0] * d[j][1] - d[j][0] * d[i][1]; };
  const double m01 = minor(0, 1), m12 = minor(1, 2), m20 = minor(2, 0);
  const double m31 = minor(3, 1), m23 = minor(2, 3), m03 = minor(0, 3), m30 = -m03, m13 = -m31, m32 = -m23;
  out[3] = d[0][2] * m12 + d[1][2] * m20 + d[2][2] * m01;     // det(0, 1, 2)
  out[0] = -(d[3][2] * m12 + d[1][2] * m23 + d[2][2] * m31);  // -det(3, 1, 2)
  out[1] = -(d[0][2] * m32 + d[3][2] * m20 + d[2][2] * m03);  // -det(0, 3, 2)
  out[2] = -(d[0][2] * m13 + d[1][2] * m30 + d[3][2] * m01);  // -det(0, 1, 3)
  double m = 0.0;
  for (int k = 0; k < 4; ++k) m = detail::maxOf(m, detail::maxAbs(d[k][0], d[k][1], d[k][2], 0.0));
  const double m3 = m * m * m;
  const double bound = m3 > detail::kStaticMin ? detail::kO3dStatic * m3 : HUGE_VAL;
  for (int f = 0; f < 4; ++f) {
    if (std::fabs(out[f]) > bound) continue;  // one predictable branch: the sign is a coin flip
    const double* a = f == 0 ? p : q[0];
    const double* b = f == 1 ? p : q[1];
    const double* c = f == 2 ? p : q[2];
    const double* e = f == 3 ? p : q[3];
    out[f] = orient3d(a, b, c, e);
  }
}

/// Sign-exact insphere (see the file comment for the convention). Zero when the five points are
/// cospherical, or when a, b, c, d are coplanar and e lies on their common circle (or all are coplanar).
/// Inline: the semi-static filter, which decides almost every call; out of line (detail::insphereTail):
/// the permanent's bound, then the exact value. Split so that the fast path spills nothing (the
/// Delaunay kernel runs ~43 of these per inserted point).
inline double insphere(const double* a, const double* b, const double* c, const double* d, const double* e) {
  double l, unused;
  const double det = detail::insphereDeterminant<false>(a, b, c, d, e, l, unused);
  // M^2 <= the largest lift (a sum of three squares), so det^2 > C^2 L^5 implies |det| > C M^5.
  const double l2 = l * l, l5 = l2 * l2 * l;
  if (l5 > detail::kStaticMinSq && det * det > detail::kIspStaticSq * l5) return det;
  return detail::insphereTail(a, b, c, d, e);
}

/// Sign of x as -1, 0, +1.
inline int signOf(double x) {
  return (x > 0.0) - (x < 0.0);
}

/// insphere under simulation of simplicity: every point's lifted coordinate |p|^2 is raised by an
/// infinitesimal that is larger (by an unbounded factor) the larger the point's id. The determinant is
/// linear in the lifted column, so the perturbed sign is the sign of the first non-zero cofactor taken
/// in decreasing id order; each cofactor is an orient3d of the other four points. Returns +1 (inside),
/// -1 (outside) or 0 only when all five points are coplanar. Ids must be distinct.
/// Because the answer depends only on the points and their ids, every thread, block and rank that
/// sees the same five points agrees, which is what makes seams between blocks consistent.
int insphereSoS(const double* a, const double* b, const double* c, const double* d, const double* e,
                std::uint64_t ia, std::uint64_t ib, std::uint64_t ic, std::uint64_t id, std::uint64_t ie);

}  // namespace predicates
}  // namespace dw
