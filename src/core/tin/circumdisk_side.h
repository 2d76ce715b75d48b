/// \file circumdisk_side.h
/// \brief Whether a triangle's closed circumdisk provably lies strictly on one side of an axis-parallel
/// line (internal). The strip merge calls such a triangle "sure" (no point beyond the seam can be in
/// its circle, so it is a triangle of the merged triangulation); the streaming DEM calls it "final".
/// Conservative: a nearly flat (ill-conditioned) triangle, or one within the rounding margin, is
/// reported as not provably on the side, which only costs time, never exactness.
#pragma once

#include <algorithm>
#include <cmath>

namespace dw {
namespace tin {
namespace detail {

/// The circumcircle of triangle (a, b, c) (either orientation): centre (ox, oy), radius r, and a bound
/// `margin` on the rounding of every quantity derived from them below (distances of the centre to
/// lines and points of magnitude up to |a| + r, to which 16 eps of that magnitude must be added).
/// False for a nearly flat triangle, whose huge circle is badly determined.
inline bool circumcircleWithMargin(double ax, double ay, double bx_, double by_, double cx_, double cy_,
                                   double& ox, double& oy, double& r, double& margin) {
  const double bx = bx_ - ax, by = by_ - ay, cx = cx_ - ax, cy = cy_ - ay;
  const double p = bx * cy, q = by * cx;
  const double d = 2.0 * (p - q);
  const double mag = std::fabs(p) + std::fabs(q);
  if (!(std::fabs(d) > 1e-6 * mag)) return false;
  const double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  const double ux = (cy * b2 - by * c2) / d;
  const double uy = (bx * c2 - cx * b2) / d;
  r = std::sqrt(ux * ux + uy * uy);
  const double l = std::max(std::sqrt(b2), std::sqrt(c2));
  // Rounding of the differences, the 2x2 determinant (relative error <= ~1e-9 after the check above),
  // the numerators (<= ~12 eps l^3 / |d|), the square root and the final sums, with a factor > 4 spare.
  constexpr double kEps = 1.1102230246251565e-16;
  margin = 64.0 * kEps * l * l * l / std::fabs(d) + 4e-9 * (std::fabs(ux) + std::fabs(uy) + r) +
           16.0 * kEps * (std::fabs(ax) + std::fabs(ay) + r + std::fabs(ux) + std::fabs(uy));
  ox = ax + ux;
  oy = ay + uy;
  return true;
}

/// Whether the closed circumdisk provably lies strictly on one side of an axis-parallel line: axis 0:
/// the line u = x = seam, axis 1: u = y = seam; below: in u < seam, else in u > seam.
inline bool circumdiskProvablyOnSide(double ax, double ay, double bx, double by, double cx, double cy,
                                     int axis, double seam, bool below) {
  double ox, oy, r, margin;
  if (!circumcircleWithMargin(ax, ay, bx, by, cx, cy, ox, oy, r, margin)) return false;
  constexpr double kEps = 1.1102230246251565e-16;
  margin += 16.0 * kEps * std::fabs(seam);
  const double centre = axis == 0 ? ox : oy;
  if (below) return centre + r + margin < seam;
  return centre - r - margin > seam;
}

}  // namespace detail
}  // namespace tin
}  // namespace dw
