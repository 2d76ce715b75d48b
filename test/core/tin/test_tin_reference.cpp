/// \file test_tin_reference.cpp
/// \brief The TIN against Qhull's 2D Delaunay on general-position input, and on the real airborne
/// tiles (LAS integer coordinates): certified, and identical for the sequential and strip builds.
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <utility>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "tin_test_util.h"

namespace {

using dw::index_t;

template <typename Container>
std::set<std::pair<index_t, index_t>> edgesOf(const Container& t) {
  std::set<std::pair<index_t, index_t>> e;
  for (std::size_t i = 0; i < t.size(); i += 3)
    for (int k = 0; k < 3; ++k) {
      index_t a = t[i + k], b = t[i + (k + 1) % 3];
      e.emplace(std::min(a, b), std::max(a, b));
    }
  return e;
}

TEST(TinReference, SameEdgesAsQhullOnRandomPoints) {
  if (!dw::haveQhullBuilder()) GTEST_SKIP() << "this build has no Qhull";
  for (unsigned seed : {1u, 2u}) {
    // Float-representable coordinates so Qhull (which takes Vec3f) sees exactly the same points.
    const auto c0 = dw_test::randomCloud(4000, seed, 50.0, 30.0);
    dw_test::Cloud c;
    std::vector<dw::Vec3f> pts;
    for (std::size_t i = 0; i < c0.size(); ++i) {
      const float x = float(c0.x[i]), y = float(c0.y[i]);
      c.add(x, y);
      pts.push_back({x, y, 0.0f});
    }
    const double basis[6] = {1, 0, 0, 0, 1, 0};
    const auto qe = dw::qhullDelaunayEdges(pts, 2, basis);
    std::set<std::pair<index_t, index_t>> want;
    for (const auto& e : qe) want.emplace(std::min(e.first, e.second), std::max(e.first, e.second));
    dw::tin::TinOptions o;
    o.num_strips = 4;
    o.num_threads = 2;
    const auto r = dw::tin::triangulate(c.x.data(), c.y.data(), c.size(), o);
    EXPECT_EQ(edgesOf(r.triangles), want);
  }
}

std::string shared(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}

/// LAS integer units are an exact similarity of the world frame when the x and y scales agree.
dw_test::Cloud lasCloud(const dw::las::LasCloud& las) {
  EXPECT_EQ(las.header.scale[0], las.header.scale[1]);
  dw_test::Cloud c;
  for (std::size_t i = 0; i < las.size(); ++i) c.add(las.X[i], las.Y[i]);
  return c;
}

void checkTile(const std::string& rel, int cls, bool compare_sequential) {
  if (!std::ifstream(shared(rel)).good()) GTEST_SKIP() << "shared data not present: " << shared(rel);
  dw::las::LasReadOptions lo;
  lo.classification = cls;
  const auto c = lasCloud(dw::las::readLasFile(shared(rel), lo));
  ASSERT_GT(c.size(), 1000u);
  dw::tin::TinOptions o;
  o.num_strips = 5;
  o.num_threads = 2;
  const auto r = dw::tin::triangulate(c.x.data(), c.y.data(), c.size(), o);
  EXPECT_EQ(r.num_vertices + r.duplicates.size(), c.size());
  const auto cert = dw::tin::certifyDelaunay(c.x.data(), c.y.data(), c.size(), r.triangles, r.num_vertices);
  EXPECT_TRUE(cert.ok) << rel << ": " << cert.message;
  if (compare_sequential) {
    o.num_strips = 1;
    o.num_threads = 1;
    const auto s = dw::tin::triangulate(c.x.data(), c.y.data(), c.size(), o);
    EXPECT_EQ(dw_test::canonical(s.triangles), dw_test::canonical(r.triangles)) << rel;
  }
}

TEST(TinReference, AutzenTile) {
  checkTile("airborne/autzen_trim.las", -1, true);
}
TEST(TinReference, AutzenGroundOnly) {
  checkTile("airborne/autzen_trim.las", 2, true);
}
TEST(TinReference, HexbinTile) {
  checkTile("airborne/hexbin-crop.las", -1, true);
}
TEST(TinReference, ExtraBytesTileGround) {
  checkTile("airborne/las_with_several_extra_byte_bloc.las", 2, false);
}

}  // namespace
