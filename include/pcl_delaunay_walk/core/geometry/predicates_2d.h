/// \file predicates_2d.h
/// \brief Robust 2D predicates: orient2d and incircle with a floating-point filter (Shewchuk's static
/// error bounds) and an exact fallback in expansion arithmetic (dw::exact), plus a symbolic
/// perturbation of the lifting map that breaks cocircular ties consistently.
///
/// Why the perturbation: quantised LiDAR coordinates put many quadruples of points exactly on one
/// circle, where the Delaunay triangulation is not unique. Lifting every point to z = x^2 + y^2 + eps_i
/// with an infinitesimal eps_i that grows with a global rank (the caller's point index) makes the lower
/// hull unique, so every builder (sequential, strips, any thread count) that uses the same ranks
/// produces the very same triangles.
#pragma once

#include <cstdint>

namespace dw {
namespace pred {

/// Coordinates for which the exact stages are exact: 0 or 2^-150 <= |v| <= 2^200. Every such double is
/// a multiple of 2^-202, so every expansion component of incircle (a degree-4 polynomial in coordinate
/// differences) is a multiple of 2^-808 (never subnormal) and below 2^810 (never infinite). Outside this
/// range products underflow or overflow and expansion arithmetic loses its guarantee.
constexpr double kMinExactMagnitude = 7.0064923216240862e-46;  // 2^-150
constexpr double kMaxExactMagnitude = 1.6069380442589903e+60;  // 2^200
inline bool inExactRange(double v) {
  const double a = v < 0 ? -v : v;
  return a == 0.0 || (a >= kMinExactMagnitude && a <= kMaxExactMagnitude);
}

/// The exact evaluations (no filter), out of line: they run only when the filter cannot decide.
int orient2dExact(double ax, double ay, double bx, double by, double cx, double cy);
int incircleExact(double ax, double ay, double bx, double by, double cx, double cy, double dx, double dy);

/// Sign of the determinant | ax-cx  ay-cy ; bx-cx  by-cy |: +1 if a, b, c turn counter-clockwise,
/// -1 clockwise, 0 collinear. Exact for all finite doubles. Inline because the kernels call it in
/// their innermost loops; the bound is Shewchuk's ccwerrboundA = (3 + 16 eps) eps, eps = 2^-53.
inline int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  const double detleft = (ax - cx) * (by - cy);
  const double detright = (ay - cy) * (bx - cx);
  const double det = detleft - detright;
  double detsum;
  if (detleft > 0.0) {
    if (detright <= 0.0) return det > 0.0 ? 1 : (det < 0.0 ? -1 : 0);
    detsum = detleft + detright;
  } else if (detleft < 0.0) {
    if (detright >= 0.0) return det > 0.0 ? 1 : (det < 0.0 ? -1 : 0);
    detsum = -detleft - detright;
  } else {
    return det > 0.0 ? 1 : (det < 0.0 ? -1 : 0);  // detleft is exactly 0: det = -detright exactly
  }
  constexpr double kEps = 1.1102230246251565e-16;  // 2^-53
  constexpr double kBound = (3.0 + 16.0 * kEps) * kEps;
  const double errbound = kBound * detsum;
  if (__builtin_fabs(det) >= errbound) return det > 0.0 ? 1 : -1;  // one branch, not one on the sign
  return orient2dExact(ax, ay, bx, by, cx, cy);
}

/// Sign of the incircle determinant: +1 if d lies strictly inside the circle through a, b, c (given
/// counter-clockwise), -1 strictly outside, 0 on it. Exact for all finite doubles. Filter bound:
/// Shewchuk's iccerrboundA = (10 + 96 eps) eps times the permanent.
inline int incircle(double ax, double ay, double bx, double by, double cx, double cy, double dx, double dy) {
  const double adx = ax - dx, bdx = bx - dx, cdx = cx - dx;
  const double ady = ay - dy, bdy = by - dy, cdy = cy - dy;
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double alift = adx * adx + ady * ady;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double blift = bdx * bdx + bdy * bdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double clift = cdx * cdx + cdy * cdy;
  const double det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) + clift * (adxbdy - bdxady);
  const double permanent = (__builtin_fabs(bdxcdy) + __builtin_fabs(cdxbdy)) * alift +
                           (__builtin_fabs(cdxady) + __builtin_fabs(adxcdy)) * blift +
                           (__builtin_fabs(adxbdy) + __builtin_fabs(bdxady)) * clift;
  constexpr double kEps = 1.1102230246251565e-16;
  constexpr double kBound = (10.0 + 96.0 * kEps) * kEps;
  const double errbound = kBound * permanent;
  if (__builtin_fabs(det) > errbound) return det > 0.0 ? 1 : -1;  // one branch, not one on the sign
  return incircleExact(ax, ay, bx, by, cx, cy, dx, dy);
}

/// incircle under the perturbed lifting z_i = x_i^2 + y_i^2 + eps^(R - rank_i) (a larger rank means a
/// larger, dominant perturbation). Never 0 unless all four points are collinear. (a, b, c) must be
/// counter-clockwise; ranks must be distinct.
int incirclePerturbed(const double* a, std::uint32_t ra, const double* b, std::uint32_t rb, const double* c,
                      std::uint32_t rc, const double* d, std::uint32_t rd);

/// Counters of how often the exact stage ran (for benchmarks and tests; relaxed, thread-safe enough
/// for statistics, not for synchronisation).
struct PredicateStats {
  std::uint64_t orient_exact = 0;
  std::uint64_t incircle_exact = 0;
  std::uint64_t perturbed_ties = 0;
};
PredicateStats predicateStats();
void resetPredicateStats();

}  // namespace pred
}  // namespace dw
