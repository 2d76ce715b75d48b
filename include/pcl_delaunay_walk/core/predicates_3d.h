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

// Shewchuk's stage-A error bound coefficients with eps = 2^-53.
constexpr double kEps = 1.1102230246251565e-16;
constexpr double kO3dBoundA = (7.0 + 56.0 * kEps) * kEps;
constexpr double kIspBoundA = (16.0 + 224.0 * kEps) * kEps;
constexpr double kO2dBoundA = (3.0 + 16.0 * kEps) * kEps;
}  // namespace detail

/// Sign-exact orient2d on (x, y): positive when a, b, c turn counter-clockwise. The returned value has
/// the correct sign; its magnitude is approximate.
inline double orient2d(const double* a, const double* b, const double* c) {
  const double detleft = (a[0] - c[0]) * (b[1] - c[1]);
  const double detright = (a[1] - c[1]) * (b[0] - c[0]);
  const double det = detleft - detright;
  const double bound = detail::kO2dBoundA * (std::fabs(detleft) + std::fabs(detright));
  if (det > bound || -det > bound) return det;
  return detail::orient2dExact(a, b, c);
}

/// Sign-exact orient3d (see the file comment for the convention).
inline double orient3d(const double* a, const double* b, const double* c, const double* d) {
  const double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
  const double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
  const double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * std::fabs(adz) +
                           (std::fabs(cdxady) + std::fabs(adxcdy)) * std::fabs(bdz) +
                           (std::fabs(adxbdy) + std::fabs(bdxady)) * std::fabs(cdz);
  const double bound = detail::kO3dBoundA * permanent;
  if (det > bound || -det > bound) return det;
  return detail::orient3dExact(a, b, c, d);
}

/// Sign-exact insphere (see the file comment for the convention). Zero when the five points are
/// cospherical, or when a, b, c, d are coplanar and e lies on their common circle (or all are coplanar).
inline double insphere(const double* a, const double* b, const double* c, const double* d, const double* e) {
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
  const double det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);

  const double aezp = std::fabs(aez), bezp = std::fabs(bez), cezp = std::fabs(cez), dezp = std::fabs(dez);
  const double aexbeyp = std::fabs(aexbey) + std::fabs(bexaey);
  const double bexceyp = std::fabs(bexcey) + std::fabs(cexbey);
  const double cexdeyp = std::fabs(cexdey) + std::fabs(dexcey);
  const double dexaeyp = std::fabs(dexaey) + std::fabs(aexdey);
  const double aexceyp = std::fabs(aexcey) + std::fabs(cexaey);
  const double bexdeyp = std::fabs(bexdey) + std::fabs(dexbey);
  const double permanent = ((cexdeyp * bezp + bexdeyp * cezp + bexceyp * dezp) * alift +
                            (dexaeyp * cezp + aexceyp * dezp + cexdeyp * aezp) * blift) +
                           ((aexbeyp * dezp + bexdeyp * aezp + dexaeyp * bezp) * clift +
                            (bexceyp * aezp + aexceyp * bezp + aexbeyp * cezp) * dlift);
  const double bound = detail::kIspBoundA * permanent;
  if (det > bound || -det > bound) return det;
  return detail::insphereExact(a, b, c, d, e);
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
