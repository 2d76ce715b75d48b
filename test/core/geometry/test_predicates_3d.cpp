// orient3d / insphere against an exact integer reference, on random, nearly degenerate and exactly
// degenerate inputs; insphereSoS: agrees with the exact sign, alternates under permutations, never
// answers 0 for a proper tetrahedron.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#include "core/geometry/predicates_3d_simd.h"
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"

namespace {

using dw::predicates::insphere;
using dw::predicates::insphereSoS;
using dw::predicates::orient3d;
using dw::predicates::signOf;
using I128 = __int128;
using P = std::array<double, 3>;

int sign128(I128 v) {
  return (v > 0) - (v < 0);
}

I128 det3(I128 a, I128 b, I128 c, I128 d, I128 e, I128 f, I128 g, I128 h, I128 i) {
  return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
}

// Exact reference on integer coordinates (|coordinate| < 2^20 keeps insphere inside 127 bits).
int orientRef(const P& a, const P& b, const P& c, const P& d) {
  auto v = [&](const P& p, int k) { return I128(static_cast<std::int64_t>(p[k] - d[k])); };
  return sign128(det3(v(a, 0), v(a, 1), v(a, 2), v(b, 0), v(b, 1), v(b, 2), v(c, 0), v(c, 1), v(c, 2)));
}

int insphereRef(const P& a, const P& b, const P& c, const P& d, const P& e) {
  const P* p[4] = {&a, &b, &c, &d};
  I128 m[4][4];
  for (int r = 0; r < 4; ++r) {
    I128 lift = 0;
    for (int k = 0; k < 3; ++k) {
      m[r][k] = static_cast<std::int64_t>((*p[r])[k] - e[k]);
      lift += m[r][k] * m[r][k];
    }
    m[r][3] = lift;
  }
  // Laplace along the lifted column, signs matching Shewchuk's insphere.
  I128 det = 0;
  for (int r = 0; r < 4; ++r) {
    I128 minor[9];
    int k = 0;
    for (int rr = 0; rr < 4; ++rr)
      if (rr != r)
        for (int c = 0; c < 3; ++c) minor[k++] = m[rr][c];
    const I128 md =
        det3(minor[0], minor[1], minor[2], minor[3], minor[4], minor[5], minor[6], minor[7], minor[8]);
    det += ((r % 2 == 0) ? -1 : 1) * m[r][3] * md;
  }
  return sign128(det);
}

P randomInt(std::mt19937_64& rng, std::int64_t range) {
  std::uniform_int_distribution<std::int64_t> u(-range, range);
  return {double(u(rng)), double(u(rng)), double(u(rng))};
}

// Four float points and a query with a full mantissa (so that differences and lifts round; float
// differences would not), at a magnitude from 2^-40 to 2^60 chosen by the iteration.
void randomFloatTetrahedron(std::mt19937_64& rng, int it, dw::Vec3f v[4], double query[3]) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_real_distribution<double> unit_double(-1.0, 1.0);
  const float scale = std::ldexp(1.0f, std::array<int, 4>{-40, 0, 20, 60}[it % 8 / 2]);
  for (int k = 0; k < 4; ++k) v[k] = {scale * unit(rng), scale * unit(rng), scale * unit(rng)};
  for (int c = 0; c < 3; ++c) query[c] = double(scale) * unit_double(rng);
}

// Permutations and sign flips of one (p, q, r) on a sphere of radius < 2^21, exact in float, and a
// query on the same sphere nudged by the iteration: insphere is 0 or nearly, so the filter hands over.
void nearlyCosphericalTetrahedron(std::mt19937_64& rng, int it, dw::Vec3f v[4], double query[3]) {
  std::uniform_int_distribution<std::int64_t> u(1 << 15, (1 << 20) - 1);
  const float p = float(u(rng)), q = float(u(rng)), r = float(u(rng));
  v[0] = {p, q, r};
  v[1] = {q, r, p};
  v[2] = {r, p, q};
  v[3] = {-p, q, r};
  query[0] = -q;
  query[1] = -r;
  query[2] = p;
  query[it % 3] += static_cast<int>((it / 3) % 3) - 1;
}

void toDoubles(const dw::Vec3f v[4], double d[4][3]) {
  for (int k = 0; k < 4; ++k) {
    d[k][0] = v[k].x;
    d[k][1] = v[k].y;
    d[k][2] = v[k].z;
  }
}

TEST(Predicates3D, ReferenceSignConventions) {
  const P a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0}, below{0, 0, -1};
  // Shewchuk: positive when d lies below the plane of counter-clockwise a, b, c.
  EXPECT_GT(orient3d(a.data(), b.data(), c.data(), below.data()), 0.0);
  EXPECT_EQ(orientRef(a, b, c, below), 1);
  const P centre{0.25, 0.25, -0.25}, far{5, 5, 5};
  EXPECT_GT(insphere(a.data(), b.data(), c.data(), below.data(), centre.data()), 0.0);
  EXPECT_LT(insphere(a.data(), b.data(), c.data(), below.data(), far.data()), 0.0);
  EXPECT_EQ(insphereRef(a, b, c, below, P{0.0, 0.0, 0.0}), 0);  // a vertex lies on its sphere
  EXPECT_EQ(signOf(insphere(a.data(), b.data(), c.data(), below.data(), a.data())), 0);
}

TEST(Predicates3D, RandomIntegerInputMatchesExactReference) {
  std::mt19937_64 rng(7);
  for (int it = 0; it < 20000; ++it) {
    const std::int64_t range = it % 2 ? (1 << 19) : 8;  // small range: many exact zeros
    const P a = randomInt(rng, range), b = randomInt(rng, range), c = randomInt(rng, range),
            d = randomInt(rng, range), e = randomInt(rng, range);
    ASSERT_EQ(signOf(orient3d(a.data(), b.data(), c.data(), d.data())), orientRef(a, b, c, d));
    ASSERT_EQ(signOf(insphere(a.data(), b.data(), c.data(), d.data(), e.data())), insphereRef(a, b, c, d, e));
  }
}

TEST(Predicates3D, NearlyDegenerateInputNeedsTheExactPath) {
  // Exactly coplanar / cospherical configurations with large coordinates, nudged by one unit: the
  // rounded determinant is dominated by error there, so only the exact fallback gets these right.
  std::mt19937_64 rng(11);
  int zero_orient = 0, zero_sphere = 0;
  for (int it = 0; it < 5000; ++it) {
    const std::int64_t big = 1 << 19;
    const P a = randomInt(rng, big), b = randomInt(rng, big), c = randomInt(rng, big);
    P d{a[0] + b[0] - c[0], a[1] + b[1] - c[1], a[2] + b[2] - c[2]};  // parallelogram: coplanar
    const int nudge = static_cast<int>(it % 3) - 1;
    d[it % 3 == 0 ? 2 : 0] += nudge;
    if (std::max({std::fabs(d[0]), std::fabs(d[1]), std::fabs(d[2])}) >= (1 << 20)) continue;
    const int ref = orientRef(a, b, c, d);
    ASSERT_EQ(signOf(orient3d(a.data(), b.data(), c.data(), d.data())), ref);
    zero_orient += ref == 0;
  }
  // Integer points on the sphere x^2 + y^2 + z^2 = 101^2 (many lattice points), plus one unit nudges.
  std::vector<P> sphere;
  for (int x = -101; x <= 101; ++x)
    for (int y = -101; y <= 101; ++y) {
      const int z2 = 101 * 101 - x * x - y * y;
      if (z2 < 0) continue;
      const int z = static_cast<int>(std::lround(std::sqrt(double(z2))));
      if (z * z == z2) sphere.push_back({double(x), double(y), double(z)});
    }
  ASSERT_GT(sphere.size(), 50u);
  std::uniform_int_distribution<std::size_t> pick(0, sphere.size() - 1);
  for (int it = 0; it < 5000; ++it) {
    const P a = sphere[pick(rng)], b = sphere[pick(rng)], c = sphere[pick(rng)], d = sphere[pick(rng)];
    P e = sphere[pick(rng)];
    e[it % 3] += static_cast<int>(it % 3) - 1;
    const int ref = insphereRef(a, b, c, d, e);
    ASSERT_EQ(signOf(insphere(a.data(), b.data(), c.data(), d.data(), e.data())), ref);
    zero_sphere += ref == 0;
  }
  EXPECT_GT(zero_orient, 100);  // the suite really exercised exact zeros
  EXPECT_GT(zero_sphere, 100);
}

TEST(Predicates3D, NearlyCosphericalLargeCoordinates) {
  // Five points on one sphere of radius ~2^19 about the origin (permutations and sign flips of one
  // (p, q, r)), the fifth nudged by -1, 0 or +1 along an axis: the products are far beyond 2^53, so the
  // rounded insphere is unreliable here and every filter (semi-static, then stage A) must hand over.
  std::mt19937_64 rng(13);
  std::uniform_int_distribution<std::int64_t> u(1 << 17, (1 << 19) - 1);
  int zeros = 0, nonzeros = 0;
  for (int it = 0; it < 20000; ++it) {
    const double p = double(u(rng)), q = double(u(rng)), r = double(u(rng));
    const P a{p, q, r}, b{q, r, p}, c{r, p, q}, d{-p, q, r};
    const int which = it % 4;
    P e = which == 0 ? P{p, -q, r} : which == 1 ? P{-q, -r, p} : which == 2 ? P{r, -p, -q} : P{q, r, -p};
    e[it % 3] += static_cast<int>((it / 3) % 3) - 1;
    if (orientRef(a, b, c, d) == 0) continue;
    const int ref = insphereRef(a, b, c, d, e);
    ASSERT_EQ(signOf(insphere(a.data(), b.data(), c.data(), d.data(), e.data())), ref) << "iteration " << it;
    (ref == 0 ? zeros : nonzeros) += 1;
  }
  EXPECT_GT(zeros, 1000);
  EXPECT_GT(nonzeros, 1000);
}

TEST(Predicates3D, Orient3dFacesEqualsFourOrient3d) {
  // The walk's shared-difference form: out[f] must have the sign of orient3d with p in slot f, on
  // random, nearly coplanar (p on or next to a face's plane) and exactly degenerate input.
  std::mt19937_64 rng(5);
  int zeros = 0;
  for (int it = 0; it < 20000; ++it) {
    const std::int64_t range = it % 3 == 0 ? 4 : (1 << 19);
    double q[4][3];
    P qp[4];
    for (int k = 0; k < 4; ++k) {
      qp[k] = randomInt(rng, range);
      for (int c = 0; c < 3; ++c) q[k][c] = qp[k][c];
    }
    P p = randomInt(rng, range);
    if (it % 3 == 1) {  // on the plane of face (0, 1, 2) (parallelogram), then maybe nudged
      for (int c = 0; c < 3; ++c) p[c] = qp[0][c] + qp[1][c] - qp[2][c];
      p[it % 2] += static_cast<int>(it % 5) - 2;
      if (std::max({std::fabs(p[0]), std::fabs(p[1]), std::fabs(p[2])}) >= (1 << 20)) continue;
    }
    double out[4];
    dw::predicates::orient3dFaces(q, p.data(), out);
    for (int f = 0; f < 4; ++f) {
      P t[4] = {qp[0], qp[1], qp[2], qp[3]};
      t[f] = p;
      const int ref = orientRef(t[0], t[1], t[2], t[3]);
      ASSERT_EQ(signOf(out[f]), ref) << "iteration " << it << ", face " << f;
      zeros += ref == 0;
    }
  }
  EXPECT_GT(zeros, 1000);  // exact zeros were exercised
}

TEST(Predicates3D, InsphereLanesIsBitIdenticalToInsphere) {
  // The kernel's lane form must return the very double of the scalar insphere (filter and tail), on
  // random float points at several magnitudes and on nearly cospherical integer points (exact in
  // float below 2^24) where the filter hands over; the signs are also checked against the reference.
  std::mt19937_64 rng(21);
  int undecided = 0;
  for (int it = 0; it < 40000; ++it) {
    dw::Vec3f v[4];
    double e[3];
    const bool cospherical = it % 2 == 1;
    if (!cospherical)
      randomFloatTetrahedron(rng, it, v, e);
    else
      nearlyCosphericalTetrahedron(rng, it, v, e);
    double d[4][3];
    toDoubles(v, d);
    const double scalar = insphere(d[0], d[1], d[2], d[3], e);
    const double lanes =
        dw::predicates::insphereLanes(v[0], v[1], v[2], v[3], dw::predicates::BroadcastPoint(e));
    ASSERT_EQ(std::memcmp(&scalar, &lanes, sizeof(double)), 0)
        << "iteration " << it << ": " << scalar << " against " << lanes;
    if (cospherical) {
      const P a{d[0][0], d[0][1], d[0][2]}, b{d[1][0], d[1][1], d[1][2]}, c{d[2][0], d[2][1], d[2][2]},
          dd{d[3][0], d[3][1], d[3][2]}, pe{e[0], e[1], e[2]};
      ASSERT_EQ(signOf(lanes), insphereRef(a, b, c, dd, pe)) << "iteration " << it;
      undecided += lanes == 0.0;
    }
  }
  EXPECT_GT(undecided, 1000);  // exact zeros, so the tail ran
}

TEST(Predicates3D, Orient3dFacesLanesIsBitIdenticalToOrient3dFaces) {
  // The walk's lane form against the scalar orient3dFaces, value for value: random float points at
  // several magnitudes with a full-mantissa query, and small integer points with the query on or next
  // to a face's plane, where the filter hands faces to orient3d (checked against the reference).
  std::mt19937_64 rng(22);
  int zeros = 0;
  for (int it = 0; it < 40000; ++it) {
    dw::Vec3f v[4];
    double p[3];
    const bool degenerate = it % 2 == 1;
    if (!degenerate) {
      randomFloatTetrahedron(rng, it, v, p);
    } else {
      for (auto& q : v) {
        const P r = randomInt(rng, 6);
        q = {float(r[0]), float(r[1]), float(r[2])};
      }
      const int f = it % 4;  // p on the plane of the face opposite f (parallelogram), maybe nudged
      const dw::Vec3f& a = v[(f + 1) % 4];
      const dw::Vec3f& b = v[(f + 2) % 4];
      const dw::Vec3f& c = v[(f + 3) % 4];
      p[0] = a.x + b.x - c.x;
      p[1] = a.y + b.y - c.y;
      p[2] = a.z + b.z - c.z;
      p[it % 3] += static_cast<int>(it / 4 % 3) - 1;
    }
    double q[4][3];
    toDoubles(v, q);
    double scalar[4], lanes[4];
    dw::predicates::orient3dFaces(q, p, scalar);
    dw::predicates::orient3dFacesLanes(v[0], v[1], v[2], v[3], dw::predicates::BroadcastPoint(p), lanes);
    for (int f = 0; f < 4; ++f) {
      ASSERT_EQ(std::memcmp(&scalar[f], &lanes[f], sizeof(double)), 0)
          << "iteration " << it << ", face " << f << ": " << scalar[f] << " against " << lanes[f];
      if (degenerate) {
        P t[4] = {{q[0][0], q[0][1], q[0][2]},
                  {q[1][0], q[1][1], q[1][2]},
                  {q[2][0], q[2][1], q[2][2]},
                  {q[3][0], q[3][1], q[3][2]}};
        t[f] = {p[0], p[1], p[2]};
        ASSERT_EQ(signOf(lanes[f]), orientRef(t[0], t[1], t[2], t[3]))
            << "iteration " << it << ", face " << f;
        zeros += lanes[f] == 0.0;
      }
    }
  }
  EXPECT_GT(zeros, 1000);  // exact zeros, so the tail ran
}

TEST(Predicates3D, WalkStepStopsOnlyWhereTheSphereHoldsThePointStrictly) {
  // An insertion's walk stops where insideSphereOrFacesLanes says p lies strictly inside the
  // circumsphere: that must be insphere's exact sign, never a guess, and where it goes on its
  // orientations must be orient3dFacesLanes', bit for bit. Random float tetrahedra at several
  // magnitudes, and nearly cospherical integer ones, where the filter often cannot decide (no stop)
  // and every stop is checked against the exact sign.
  std::mt19937_64 rng(23);
  int stops = 0, on = 0;
  for (int it = 0; it < 40000; ++it) {
    dw::Vec3f v[4];
    double e[3];
    if (it % 2 == 0)
      randomFloatTetrahedron(rng, it, v, e);
    else
      nearlyCosphericalTetrahedron(rng, it, v, e);
    const dw::predicates::BroadcastPoint query(e);
    double faces[4], walked[4] = {0.0, 0.0, 0.0, 0.0};
    dw::predicates::orient3dFacesLanes(v[0], v[1], v[2], v[3], query, faces);
    double det = 0.0;
    const bool decided = dw::predicates::insphereLanesFilter(v[0], v[1], v[2], v[3], query, det);
    const bool stop = dw::predicates::insideSphereOrFacesLanes(v[0], v[1], v[2], v[3], query, walked);
    ASSERT_EQ(stop, decided && det > 0.0) << "iteration " << it;
    if (stop) {
      double d[4][3];
      toDoubles(v, d);
      const P a{d[0][0], d[0][1], d[0][2]}, b{d[1][0], d[1][1], d[1][2]}, c{d[2][0], d[2][1], d[2][2]},
          dd{d[3][0], d[3][1], d[3][2]}, pe{e[0], e[1], e[2]};
      if (it % 2 == 1) {
        ASSERT_EQ(insphereRef(a, b, c, dd, pe), 1) << "iteration " << it;
      }
      ++stops;
      continue;
    }
    ++on;
    for (int f = 0; f < 4; ++f)
      ASSERT_EQ(std::memcmp(&faces[f], &walked[f], sizeof(double)), 0)
          << "iteration " << it << ", face " << f;
  }
  EXPECT_GT(stops, 1000);
  EXPECT_GT(on, 1000);
}

TEST(Predicates3D, FractionalAndHugeMagnitudes) {
  // Scaling by a power of two is exact, so signs must be invariant under it: covers tiny and huge
  // magnitudes (short of underflow/overflow of the degree-5 products) where a fixed-epsilon filter fails.
  std::mt19937_64 rng(3);
  for (int it = 0; it < 3000; ++it) {
    P p[5];
    for (auto& q : p) q = randomInt(rng, 4);
    const int o = orientRef(p[0], p[1], p[2], p[3]);
    const int s = insphereRef(p[0], p[1], p[2], p[3], p[4]);
    for (double scale : {std::ldexp(1.0, -150), std::ldexp(1.0, -40), std::ldexp(1.0, 150)}) {
      P q[5];
      for (int i = 0; i < 5; ++i)
        for (int k = 0; k < 3; ++k) q[i][k] = p[i][k] * scale;
      ASSERT_EQ(signOf(orient3d(q[0].data(), q[1].data(), q[2].data(), q[3].data())), o);
      ASSERT_EQ(signOf(insphere(q[0].data(), q[1].data(), q[2].data(), q[3].data(), q[4].data())), s);
    }
  }
}

TEST(Predicates3D, OffsetCoordinatesUseTwoComponentDifferences) {
  // 2^30 + small fractions: differences are not exact in one double; the exact path must see the tails.
  const double base = std::ldexp(1.0, 30);
  const double tiny = std::ldexp(1.0, -22);
  const P a{base, base, base}, b{base + 1, base, base}, c{base, base + 1, base};
  const P on{base + 1, base + 1, base};         // coplanar with a, b, c
  const P up{base + 1, base + 1, base + tiny};  // just above
  EXPECT_EQ(signOf(orient3d(a.data(), b.data(), c.data(), on.data())), 0);
  EXPECT_EQ(signOf(orient3d(a.data(), b.data(), c.data(), up.data())), -1);
  const P d{base, base, base + 1};
  const P corner{base + 1, base + 1, base + 1};  // the cube's corners are cospherical
  EXPECT_EQ(signOf(insphere(a.data(), b.data(), c.data(), d.data(), corner.data())), 0);
  const P inside{base + 1 - tiny, base + 1, base + 1};
  EXPECT_EQ(signOf(insphere(a.data(), c.data(), b.data(), d.data(), inside.data())), 1);
}

TEST(Predicates3D, SoSAgreesWithExactSignWhenNonZero) {
  std::mt19937_64 rng(5);
  for (int it = 0; it < 5000; ++it) {
    P p[5];
    for (auto& q : p) q = randomInt(rng, 3);
    if (orientRef(p[0], p[1], p[2], p[3]) == 0) continue;
    const int s = insphereRef(p[0], p[1], p[2], p[3], p[4]);
    const int sos =
        insphereSoS(p[0].data(), p[1].data(), p[2].data(), p[3].data(), p[4].data(), 10, 20, 30, 40, 50);
    if (s != 0) {
      ASSERT_EQ(sos, s);
    } else {
      ASSERT_NE(sos, 0);
    }
  }
}

TEST(Predicates3D, SoSIsAlternatingUnderPermutations) {
  // The perturbed determinant is a function of the (point, id) pairs that changes sign with every
  // transposition: this is what makes all tetrahedra sharing a face agree on a tie.
  std::mt19937_64 rng(9);
  std::vector<P> cube;
  for (int x = 0; x < 2; ++x)
    for (int y = 0; y < 2; ++y)
      for (int z = 0; z < 2; ++z) cube.push_back({double(x), double(y), double(z)});
  int checked = 0;
  for (int it = 0; it < 3000; ++it) {
    std::array<int, 8> idx{0, 1, 2, 3, 4, 5, 6, 7};
    std::shuffle(idx.begin(), idx.end(), rng);
    const P* p[5];
    std::uint64_t id[5];
    for (int k = 0; k < 5; ++k) {
      p[k] = &cube[idx[k]];
      id[k] = static_cast<std::uint64_t>(idx[k]) * 7 + 3;
    }
    if (orientRef(*p[0], *p[1], *p[2], *p[3]) == 0) continue;
    const int base = insphereSoS(p[0]->data(), p[1]->data(), p[2]->data(), p[3]->data(), p[4]->data(), id[0],
                                 id[1], id[2], id[3], id[4]);
    ASSERT_NE(base, 0);
    std::array<int, 5> perm{0, 1, 2, 3, 4};
    for (int rep = 0; rep < 10; ++rep) {
      std::shuffle(perm.begin(), perm.end(), rng);
      int parity = 1;
      for (int i = 0; i < 5; ++i)
        for (int j = i + 1; j < 5; ++j)
          if (perm[i] > perm[j]) parity = -parity;
      const int s =
          insphereSoS(p[perm[0]]->data(), p[perm[1]]->data(), p[perm[2]]->data(), p[perm[3]]->data(),
                      p[perm[4]]->data(), id[perm[0]], id[perm[1]], id[perm[2]], id[perm[3]], id[perm[4]]);
      // Zero is allowed only when the permutation puts four coplanar points in front.
      if (s == 0) continue;
      ASSERT_EQ(s, parity * base);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(Predicates3D, SoSAllCoplanarIsZero) {
  const P a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0}, d{1, 1, 0}, e{2, 3, 0};
  EXPECT_EQ(insphereSoS(a.data(), b.data(), c.data(), d.data(), e.data(), 0, 1, 2, 3, 4), 0);
}

}  // namespace
