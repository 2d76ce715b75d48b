/// \file test_predicates_2d.cpp
/// \brief orient2d / incircle against exact 128-bit integer arithmetic, near-degenerate inputs where
/// the filter must hand over to the exact stage, and the consistency of the perturbed tie-break.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"

namespace {

using i128 = __int128;
int sgn(i128 v) {
  return v > 0 ? 1 : (v < 0 ? -1 : 0);
}

int orientInt(i128 ax, i128 ay, i128 bx, i128 by, i128 cx, i128 cy) {
  return sgn((ax - cx) * (by - cy) - (ay - cy) * (bx - cx));
}

int incircleInt(i128 ax, i128 ay, i128 bx, i128 by, i128 cx, i128 cy, i128 dx, i128 dy) {
  const i128 adx = ax - dx, ady = ay - dy, bdx = bx - dx, bdy = by - dy, cdx = cx - dx, cdy = cy - dy;
  const i128 al = adx * adx + ady * ady, bl = bdx * bdx + bdy * bdy, cl = cdx * cdx + cdy * cdy;
  return sgn(al * (bdx * cdy - cdx * bdy) + bl * (cdx * ady - adx * cdy) + cl * (adx * bdy - bdx * ady));
}

TEST(Predicates2d, OrientMatchesIntegerArithmeticOnScaledIntegers) {
  // Doubles k * 2^-20 with |k| < 2^40: the exact sign is the integer sign of the scaled determinant.
  std::mt19937_64 rng(1);
  std::uniform_int_distribution<long long> u(-(1LL << 40), 1LL << 40);
  const double s = std::ldexp(1.0, -20);
  for (int it = 0; it < 20000; ++it) {
    long long v[6];
    for (auto& k : v) k = u(rng);
    if (it % 3 == 0) {  // force exact collinearity: c = a + t (b - a)
      const long long t = (it % 7) - 3;
      v[4] = v[0] + t * (v[2] - v[0]);
      v[5] = v[1] + t * (v[3] - v[1]);
      if (std::llabs(v[4]) >= (1LL << 50) || std::llabs(v[5]) >= (1LL << 50)) continue;
    }
    const int want = orientInt(v[0], v[1], v[2], v[3], v[4], v[5]);
    EXPECT_EQ(dw::pred::orient2d(v[0] * s, v[1] * s, v[2] * s, v[3] * s, v[4] * s, v[5] * s), want);
    EXPECT_EQ(dw::pred::orient2dExact(v[0] * s, v[1] * s, v[2] * s, v[3] * s, v[4] * s, v[5] * s), want);
  }
}

TEST(Predicates2d, OrientNearDegenerateUlpGrid) {
  // Shewchuk's classic failure case for naive arithmetic: points a few ulps off the line y = x.
  const double ulp = std::ldexp(1.0, -53);
  const long long S = 1LL << 53;  // scale making every coordinate an integer
  int exact_zero = 0;
  for (int i = 0; i < 64; ++i)
    for (int j = 0; j < 64; ++j) {
      const double px = 0.5 + i * ulp, py = 0.5 + j * ulp;
      const int got = dw::pred::orient2d(px, py, 12.0, 12.0, 24.0, 24.0);
      const int want =
          orientInt(i128(S / 2 + i), i128(S / 2 + j), i128(12) * S, i128(12) * S, i128(24) * S, i128(24) * S);
      ASSERT_EQ(got, want) << i << "," << j;
      exact_zero += want == 0;
    }
  EXPECT_EQ(exact_zero, 64);  // exactly the diagonal i == j is collinear
}

TEST(Predicates2d, IncircleMatchesIntegerArithmetic) {
  std::mt19937_64 rng(2);
  std::uniform_int_distribution<long long> u(-(1LL << 22), 1LL << 22);
  const double s = std::ldexp(1.0, -10);
  int zeros = 0;
  for (int it = 0; it < 20000; ++it) {
    long long v[8];
    for (auto& k : v) k = u(rng);
    if (it % 2 == 0) {
      // Cocircular by construction: four points of the circle centred (cx, cy) through Pythagorean
      // offsets (3,4) scaled: (+-3k, +-4k) and (+-5k, 0), (0, +-5k).
      const long long cx = u(rng) / 4, cy = u(rng) / 4, k = 1 + (it % 1000);
      const long long pts[8][2] = {{3 * k, 4 * k}, {-3 * k, 4 * k}, {-4 * k, -3 * k}, {4 * k, -3 * k},
                                   {5 * k, 0},     {0, 5 * k},      {-5 * k, 0},      {0, -5 * k}};
      for (int q = 0; q < 4; ++q) {
        const int pick = (it / 2 + 3 * q) % 8;
        v[2 * q] = cx + pts[pick][0];
        v[2 * q + 1] = cy + pts[pick][1];
      }
    }
    const int want = incircleInt(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]);
    zeros += want == 0;
    const int got =
        dw::pred::incircle(v[0] * s, v[1] * s, v[2] * s, v[3] * s, v[4] * s, v[5] * s, v[6] * s, v[7] * s);
    ASSERT_EQ(got, want) << "iteration " << it;
    ASSERT_EQ(dw::pred::incircleExact(v[0] * s, v[1] * s, v[2] * s, v[3] * s, v[4] * s, v[5] * s, v[6] * s,
                                      v[7] * s),
              want);
  }
  EXPECT_GT(zeros, 1000);  // the cocircular half really exercised the exact zero
}

TEST(Predicates2d, IncircleExactOnNonIntegerDoubles) {
  // Random doubles with full 53-bit mantissas: the filter's answer must equal the exact stage's.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int it = 0; it < 20000; ++it) {
    double v[8];
    for (auto& k : v) k = u(rng);
    if (it % 2) {  // push d onto (nearly) the circle through a, b, c
      const double ax = v[0], ay = v[1], bx = v[2], by = v[3], cx = v[4], cy = v[5];
      const double d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
      if (std::fabs(d) < 1e-3) continue;
      const double ux = ((ax * ax + ay * ay) * (by - cy) + (bx * bx + by * by) * (cy - ay) +
                         (cx * cx + cy * cy) * (ay - by)) /
                        d;
      const double uy = ((ax * ax + ay * ay) * (cx - bx) + (bx * bx + by * by) * (ax - cx) +
                         (cx * cx + cy * cy) * (bx - ax)) /
                        d;
      const double r = std::hypot(ax - ux, ay - uy), t = u(rng) * 3.14159;
      v[6] = ux + r * std::cos(t);
      v[7] = uy + r * std::sin(t);
    }
    EXPECT_EQ(dw::pred::incircle(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]),
              dw::pred::incircleExact(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]));
  }
}

TEST(Predicates2d, IncircleSignConvention) {
  EXPECT_EQ(dw::pred::incircle(0, 0, 1, 0, 0, 1, 0.3, 0.3), 1);
  EXPECT_EQ(dw::pred::incircle(0, 0, 1, 0, 0, 1, 2, 2), -1);
  EXPECT_EQ(dw::pred::incircle(0, 0, 1, 0, 0, 1, 1, 1), 0);
  EXPECT_EQ(dw::pred::orient2d(0, 0, 1, 0, 0, 1), 1);
  EXPECT_EQ(dw::pred::orient2d(0, 0, 0, 1, 1, 0), -1);
}

TEST(Predicates2d, PerturbationPicksExactlyOneDiagonal) {
  // A cocircular quadrilateral a, b, c, d (counter-clockwise): exactly one of the two diagonals must be
  // locally Delaunay under the perturbation, for every assignment of ranks.
  const double q[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  const unsigned perms[24][4] = {{0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 1, 3}, {0, 2, 3, 1}, {0, 3, 1, 2},
                                 {0, 3, 2, 1}, {1, 0, 2, 3}, {1, 0, 3, 2}, {1, 2, 0, 3}, {1, 2, 3, 0},
                                 {1, 3, 0, 2}, {1, 3, 2, 0}, {2, 0, 1, 3}, {2, 0, 3, 1}, {2, 1, 0, 3},
                                 {2, 1, 3, 0}, {2, 3, 0, 1}, {2, 3, 1, 0}, {3, 0, 1, 2}, {3, 0, 2, 1},
                                 {3, 1, 0, 2}, {3, 1, 2, 0}, {3, 2, 0, 1}, {3, 2, 1, 0}};
  using dw::pred::incirclePerturbed;
  for (const auto& r : perms) {
    const double *a = q[0], *b = q[1], *c = q[2], *d = q[3];
    const bool ac = incirclePerturbed(a, r[0], b, r[1], c, r[2], d, r[3]) < 0 &&
                    incirclePerturbed(a, r[0], c, r[2], d, r[3], b, r[1]) < 0;
    const bool bd = incirclePerturbed(a, r[0], b, r[1], d, r[3], c, r[2]) < 0 &&
                    incirclePerturbed(b, r[1], c, r[2], d, r[3], a, r[0]) < 0;
    EXPECT_NE(ac, bd);
    // Invariant under rotation of the triangle.
    EXPECT_EQ(incirclePerturbed(a, r[0], b, r[1], c, r[2], d, r[3]),
              incirclePerturbed(b, r[1], c, r[2], a, r[0], d, r[3]));
    EXPECT_NE(incirclePerturbed(a, r[0], b, r[1], c, r[2], d, r[3]), 0);
  }
}

}  // namespace
