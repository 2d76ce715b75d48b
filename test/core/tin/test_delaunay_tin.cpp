/// \file test_delaunay_tin.cpp
/// \brief The TIN builder: certified Delaunay on random, quantised, cocircular, duplicated, collinear
/// and tiny inputs; identical triangles for every strip and thread count.
#include <gtest/gtest.h>

#include <limits>
#include <set>

#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "tin_test_util.h"

namespace {

using dw::index_t;
using dw::tin::TinOptions;
using dw_test::canonical;
using dw_test::Cloud;

dw::tin::TinResult run(const Cloud& c, unsigned strips, unsigned threads = 1) {
  TinOptions o;
  o.num_strips = strips;
  o.num_threads = threads;
  return dw::tin::triangulate(c.x.data(), c.y.data(), c.size(), o);
}

void expectCertified(const Cloud& c, const dw::tin::TinResult& r) {
  const auto cert = dw::tin::certifyDelaunay(c.x.data(), c.y.data(), c.size(), r.triangles, r.num_vertices);
  EXPECT_TRUE(cert.ok) << cert.message;
}

/// Every strip count 1..max_strips and threads 1..3 must give the very same triangles, certified.
void expectStripInvariant(const Cloud& c, unsigned max_strips) {
  const auto ref = run(c, 1);
  expectCertified(c, ref);
  const auto want = canonical(ref.triangles);
  for (unsigned s = 2; s <= max_strips; ++s)
    for (unsigned t : {1u, 2u, 3u}) {
      const auto r = run(c, s, t);
      ASSERT_EQ(canonical(r.triangles), want) << s << " strips, " << t << " threads";
      EXPECT_EQ(r.duplicates, ref.duplicates);
      EXPECT_EQ(r.num_vertices, ref.num_vertices);
    }
}

TEST(DelaunayTin, RandomPointsCertifiedAndStripInvariant) {
  const Cloud c = dw_test::randomCloud(3000, 7);
  const auto r = run(c, 1);
  EXPECT_EQ(r.num_vertices, c.size());
  EXPECT_FALSE(r.degenerate);
  expectStripInvariant(c, 9);
}

TEST(DelaunayTin, ElongatedAlongYUsesYStrips) {
  const Cloud c = dw_test::randomCloud(2000, 8, 10.0, 400.0);
  expectStripInvariant(c, 6);
}

TEST(DelaunayTin, CocircularGridCertifiedAndStripInvariant) {
  // Every unit square is cocircular: only the perturbation makes the answer unique.
  const Cloud c = dw_test::gridCloud(40, 30, 3);
  const auto r = run(c, 1);
  EXPECT_EQ(r.numTriangles(), std::size_t(2 * 39 * 29));
  expectStripInvariant(c, 8);
}

TEST(DelaunayTin, QuantisedLasLikeCoordinates) {
  const Cloud c = dw_test::quantisedCloud(6000, 11, 4.0);  // 401 x 401 lattice: ties and duplicates
  const auto r = run(c, 1);
  EXPECT_FALSE(r.duplicates.empty());
  EXPECT_EQ(r.num_vertices + r.duplicates.size(), c.size());
  expectStripInvariant(c, 7);
}

TEST(DelaunayTin, DuplicatesCollapseOntoSmallestIndex) {
  Cloud c = dw_test::randomCloud(500, 5);
  for (int k = 0; k < 200; ++k) c.add(c.x[k * 2], c.y[k * 2]);  // copies of earlier points
  c.add(c.x[0], c.y[0]);
  const auto r = run(c, 1);
  EXPECT_EQ(r.num_vertices, 500u);
  ASSERT_EQ(r.duplicates.size(), 201u);
  for (const auto& d : r.duplicates) {
    EXPECT_LT(d.second, d.first);
    EXPECT_EQ(c.x[d.first], c.x[d.second]);
    EXPECT_EQ(c.y[d.first], c.y[d.second]);
  }
  std::set<index_t> used(r.triangles.begin(), r.triangles.end());
  EXPECT_EQ(used.size(), 500u);
  EXPECT_EQ(*used.rbegin(), 499u);  // no copy is a vertex
  expectStripInvariant(c, 5);
}

TEST(DelaunayTin, AutomaticStripsSameTrianglesForEveryThreadCount) {
  // Above 200k points the default splits into several strips per thread and fills the output array on
  // a helper thread; the triangles must not depend on either. LAS-like quantisation: ties and copies.
  const Cloud c = dw_test::quantisedCloud(260000, 41, 30.0);
  const auto ref = run(c, 1);
  expectCertified(c, ref);
  const auto want = canonical(ref.triangles);
  for (unsigned t : {1u, 2u, 4u}) {
    const auto r = run(c, 0, t);
    EXPECT_GE(r.stats.strips, t > 1 ? 2u * t : 1u) << t << " threads";
    ASSERT_EQ(canonical(r.triangles), want) << t << " threads";
    EXPECT_EQ(r.duplicates, ref.duplicates);
    EXPECT_EQ(r.num_vertices, ref.num_vertices);
    EXPECT_LE(r.triangles.capacity(), 2 * r.triangles.size()) << "output storage not trimmed";
  }
}

TEST(DelaunayTin, CollinearInputIsDegenerate) {
  Cloud c;
  for (int i = 0; i < 100; ++i) c.add(3.0 + 0.5 * (i % 37), 1.0 + 0.25 * (i % 37));  // 37 distinct, copies
  for (unsigned s : {1u, 4u}) {
    const auto r = run(c, s, 2);
    EXPECT_TRUE(r.degenerate);
    EXPECT_TRUE(r.triangles.empty());
    EXPECT_EQ(r.num_vertices, 37u);
    EXPECT_EQ(r.duplicates.size(), 63u);
  }
}

TEST(DelaunayTin, TinyInputs) {
  for (std::size_t n = 0; n <= 3; ++n) {
    Cloud c;
    const double px[3] = {0, 1, 0}, py[3] = {0, 0, 1};
    for (std::size_t i = 0; i < n; ++i) c.add(px[i], py[i]);
    const auto r = run(c, 1);
    EXPECT_EQ(r.num_vertices, n);
    EXPECT_EQ(r.numTriangles(), n == 3 ? 1u : 0u);
    EXPECT_EQ(r.degenerate, n < 3);
    if (n == 3) {
      expectCertified(c, r);
    }
  }
  Cloud line;
  line.add(0, 0);
  line.add(1, 1);
  line.add(2, 2);
  EXPECT_TRUE(run(line, 1).degenerate);
  line.add(1, 0);  // three collinear + one off the line: 2 triangles, the middle point on the hull
  const auto r = run(line, 1);
  EXPECT_EQ(r.numTriangles(), 2u);
  expectCertified(line, r);
}

TEST(DelaunayTin, CollinearColumnsMakeDegenerateStrips) {
  // Points on 8 vertical lines: with 8 strips each strip is collinear, so merges start from
  // triangle-less groups.
  Cloud c;
  for (int col = 0; col < 8; ++col)
    for (int k = 0; k < 25; ++k) c.add(col * 3.0, k * 0.7 + (col % 2) * 0.35);
  expectStripInvariant(c, 8);
}

TEST(DelaunayTin, NonFiniteCoordinatesAreSkipped) {
  Cloud c = dw_test::randomCloud(300, 9);
  c.add(std::numeric_limits<double>::quiet_NaN(), 1.0);
  c.add(1.0, std::numeric_limits<double>::infinity());
  const auto r = run(c, 3, 2);
  EXPECT_EQ(r.skipped, (std::vector<index_t>{300, 301}));
  EXPECT_EQ(r.num_vertices, 300u);
  expectCertified(c, r);
}

TEST(DelaunayTin, CertificateRejectsANonDelaunayMesh) {
  Cloud c;
  c.add(0, 0);
  c.add(2, 0);
  c.add(2, 1);
  c.add(0, 1.2);  // not cocircular: exactly one diagonal is Delaunay
  const auto r = run(c, 1);
  ASSERT_TRUE(dw::tin::certifyDelaunay(c.x.data(), c.y.data(), 4, r.triangles, 4).ok);
  // Flip the diagonal by hand: the certificate must refuse it.
  const auto t = canonical(r.triangles);
  std::vector<index_t> flipped;
  const bool ac = std::set<index_t>{t[0][0], t[0][1], t[0][2]}.count(1) == 0 ||
                  std::set<index_t>{t[1][0], t[1][1], t[1][2]}.count(1) == 0;
  if (ac)
    flipped = {0, 1, 3, 1, 2, 3};  // diagonal 1-3
  else
    flipped = {0, 1, 2, 0, 2, 3};  // diagonal 0-2
  EXPECT_FALSE(dw::tin::certifyDelaunay(c.x.data(), c.y.data(), 4, flipped, 4).ok);
  // Missing triangle, wrong orientation.
  EXPECT_FALSE(dw::tin::certifyDelaunay(c.x.data(), c.y.data(), 4,
                                        std::vector<index_t>(r.triangles.begin(), r.triangles.begin() + 3), 4)
                   .ok);
  std::vector<index_t> cw(r.triangles.begin(), r.triangles.end());
  std::swap(cw[1], cw[2]);
  EXPECT_FALSE(dw::tin::certifyDelaunay(c.x.data(), c.y.data(), 4, cw, 4).ok);
}

TEST(DelaunayTin, RawUtmCoordinatesStayExact) {
  // Georeferenced doubles (~6e6 m) on a 1 cm lattice: the filter fails often and the exact stage and
  // the tie-break carry the result; it must still be certified and strip-invariant.
  dw_test::Cloud c;
  const dw_test::Cloud q = dw_test::quantisedCloud(4000, 31, 3.0);
  for (std::size_t i = 0; i < q.size(); ++i) c.add(512345.67 + q.x[i], 6012345.89 + q.y[i]);
  expectStripInvariant(c, 6);
}

TEST(DelaunayTin, ClusteredAndMixedScalesManyStrips) {
  // Dense clusters plus sparse outliers: long skinny band triangles cross several seams.
  Cloud c = dw_test::randomCloud(1500, 21, 1.0, 1.0);
  Cloud far = dw_test::randomCloud(60, 22, 1000.0, 3.0);
  for (std::size_t i = 0; i < far.size(); ++i) c.add(far.x[i] - 500.0, far.y[i] * 100.0);
  expectStripInvariant(c, 12);
}

}  // namespace

namespace {

TEST(DelaunayTin, CoordinatesOutsideTheExactRangeAreRefused) {
  for (double v : {1e61, -1e200, 1e-46, -4.9e-324}) {
    Cloud c = dw_test::randomCloud(50, 12);
    c.add(v, 1.0);
    try {
      run(c, 1);
      ADD_FAILURE() << "accepted " << v;
    } catch (const dw::Error& e) {
      EXPECT_NE(std::string(e.what()).find("outside the range"), std::string::npos) << e.what();
    }
  }
  // The edges of the range and exact zeros are accepted and certified.
  Cloud c = dw_test::randomCloud(50, 13);
  c.add(1.6e60, 0.0);
  c.add(-1.6e60, 1e-45);
  c.add(0.0, -1.6e60);
  expectCertified(c, run(c, 2, 2));
}

}  // namespace
