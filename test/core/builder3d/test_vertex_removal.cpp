// Triangulation3D::remove: after removals (interior and hull vertices, general position and
// degenerate input, a real scan) the structure validates and its edge set equals a fresh build of the
// remaining vertices with the same ids (the perturbed triangulation is unique, so equality is exact even
// on cospherical grids). Errors leave the structure as it was.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "builder3d_test_util.h"
#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "core/geometry/affine_span.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

using b3d_test::Edges;
using dw::index_t;
using dw::builder3d::Triangulation3D;

Edges edgesOf(const Triangulation3D& k) {
  return b3d_test::kernelEdges(k);
}

// A fresh kernel over the same array holding exactly `ids` (inserted in a shuffled order: the result
// does not depend on it).
Edges freshEdges(const std::vector<dw::Vec3f>& pts, std::vector<index_t> ids, unsigned seed) {
  std::shuffle(ids.begin(), ids.end(), std::mt19937(seed));
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  k.build(ids.data(), ids.size());
  return edgesOf(k);
}

Triangulation3D buildAll(const std::vector<dw::Vec3f>& pts) {
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  const auto order = dw::builder3d::brioOrder(pts);
  k.build(order.data(), order.size());
  return k;
}

std::vector<index_t> identity(std::size_t n) {
  std::vector<index_t> o(n);
  std::iota(o.begin(), o.end(), 0u);
  return o;
}

// Removes `count` vertices: first up to `hull_first` hull vertices, then random ones; checks validity
// and equality with a fresh build after every `check_every` removals and at the end.
void removeAndCompare(const std::vector<dw::Vec3f>& pts, std::size_t count, std::size_t hull_first,
                      std::size_t check_every, const char* what) {
  SCOPED_TRACE(what);
  Triangulation3D k = buildAll(pts);
  std::vector<char> live(pts.size(), 1);
  std::mt19937 rng(42);
  std::size_t removed = 0, hull_removed = 0;
  auto check = [&] {
    k.validate();
    std::vector<index_t> ids;
    for (index_t i = 0; i < pts.size(); ++i)
      if (live[i]) ids.push_back(i);
    ASSERT_EQ(k.numVertices(), ids.size());
    ASSERT_EQ(edgesOf(k), freshEdges(pts, ids, static_cast<unsigned>(removed)));
  };
  while (removed < count) {
    index_t v;
    if (hull_removed < hull_first) {
      const auto hull = k.hullVertices();
      v = hull[rng() % hull.size()];
      ++hull_removed;
    } else {
      do v = static_cast<index_t>(rng() % pts.size());
      while (!live[v]);
    }
    k.remove(v);
    live[v] = 0;
    ++removed;
    if (removed % check_every == 0) {
      check();
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  check();
  EXPECT_EQ(k.numRemoved(), count);
}

TEST(VertexRemoval, UniformInteriorAndHull) {
  removeAndCompare(b3d_test::uniformCube(2000, 11), 600, 60, 150, "uniform 2000");
}

TEST(VertexRemoval, GridWithCosphericalCells) {
  // Every cell's 8 corners are cospherical and every face's 4 coplanar; hull facets are coplanar too.
  removeAndCompare(b3d_test::grid(9, 8, 7), 250, 40, 50, "grid 9x8x7");
}

TEST(VertexRemoval, LatticeSphereEveryVertexOnTheHull) {
  removeAndCompare(b3d_test::latticeSphere(11 * 11 * 9), 200, 200, 20, "lattice sphere");
}

TEST(VertexRemoval, QuantisedPoints) {
  removeAndCompare(b3d_test::quantised(3000, 12, 0.1f), 800, 50, 200, "quantised");
}

TEST(VertexRemoval, BunnyScan) {
  const std::string path = std::string(DW_TEST_DATA_DIR) + "/bun000.ply";
  if (!b3d_test::exists(path)) GTEST_SKIP() << "data/bun000.ply not found";
  removeAndCompare(b3d_test::toVec3f(dw::readPointsXyz(path)), 2000, 100, 2000, "bun000");
}

TEST(VertexRemoval, DownToFourVertices) {
  // The last removals empty most of the hull; every intermediate structure must stay valid.
  const auto pts = b3d_test::uniformCube(40, 13);
  Triangulation3D k = buildAll(pts);
  std::vector<index_t> ids = identity(pts.size());
  std::shuffle(ids.begin(), ids.end(), std::mt19937(5));
  while (k.numVertices() > 4) {
    k.remove(ids.back());
    ids.pop_back();
    k.validate();
    ASSERT_EQ(edgesOf(k), freshEdges(pts, ids, 1));
  }
  EXPECT_EQ(edgesOf(k).size(), 6u);  // one tetrahedron
  EXPECT_THROW(k.remove(ids[0]), dw::Error);
  k.validate();
}

TEST(VertexRemoval, FlatLinkOfAHullVertex) {
  // A point above a flat roof: its finite link is coplanar, so DT(link) does not exist; the roof's
  // triangles become hull facets again.
  auto pts = b3d_test::grid(5, 5, 3);
  pts.push_back({2.f, 2.f, 2.5f});
  const index_t apex = static_cast<index_t>(pts.size() - 1);
  Triangulation3D k = buildAll(pts);
  k.remove(apex);
  k.validate();
  EXPECT_EQ(edgesOf(k), freshEdges(pts, identity(pts.size() - 1), 2));
  k.insert(apex);  // and back: the same triangulation as before
  k.validate();
  EXPECT_EQ(edgesOf(k), freshEdges(pts, identity(pts.size()), 3));
}

TEST(VertexRemoval, SlidingWindowEqualsFreshBuildEveryRound) {
  // Drop the oldest 10 %, add the next 10 %, five rounds; the array grows before each insertion.
  const std::size_t window = 1500, step = window / 10, rounds = 5;
  const auto all = b3d_test::uniformCube(window + rounds * step + 50, 14);
  for (const bool degenerate : {false, true}) {
    SCOPED_TRACE(degenerate ? "quantised" : "uniform");
    std::vector<dw::Vec3f> pts =
        degenerate ? b3d_test::quantised(window + rounds * step + 400, 15, 0.08f) : all;
    ASSERT_GE(pts.size(), window + rounds * step);
    std::vector<dw::Vec3f> arr(pts.begin(), pts.begin() + window);
    Triangulation3D k;
    k.setPoints(arr.data(), arr.size());
    const auto order = dw::builder3d::brioOrder(arr);
    k.build(order.data(), order.size());
    for (std::size_t r = 0; r < rounds; ++r) {
      for (std::size_t i = r * step; i < (r + 1) * step; ++i) k.remove(static_cast<index_t>(i));
      arr.insert(arr.end(), pts.begin() + window + r * step, pts.begin() + window + (r + 1) * step);
      k.setPoints(arr.data(), arr.size());
      for (std::size_t i = window + r * step; i < window + (r + 1) * step; ++i)
        k.insert(static_cast<index_t>(i));
      k.validate();
      std::vector<index_t> ids(window);
      std::iota(ids.begin(), ids.end(), static_cast<index_t>((r + 1) * step));
      ASSERT_EQ(edgesOf(k), freshEdges(arr, ids, static_cast<unsigned>(r))) << "round " << r;
    }
  }
}

TEST(VertexRemoval, RandomInsertRemoveOnSmallDegenerateSets) {
  // Tiny sets are where the special cases live: flat links, hulls made of coplanar facets, removals
  // that would leave a flat set. Every step must equal a fresh build, and a removal must be refused
  // exactly when the rest does not span 3D, without changing anything.
  std::vector<std::vector<dw::Vec3f>> sets = {b3d_test::grid(3, 3, 3)};
  {
    auto roof = b3d_test::grid(4, 4, 1);
    roof.insert(roof.end(), {{1.5f, 1.5f, 1.f}, {1.5f, 1.5f, -1.f}, {0.5f, 2.5f, 2.f}});
    sets.push_back(roof);
    sets.push_back(b3d_test::quantised(40, 17, 0.5f));
    sets.push_back(b3d_test::latticeSphere(9));
  }
  std::size_t refusals = 0;
  for (std::size_t si = 0; si < sets.size(); ++si) {
    auto pts = sets[si];
    for (unsigned seed = 0; seed < 10; ++seed) {
      SCOPED_TRACE("set " + std::to_string(si) + " seed " + std::to_string(seed));
      std::mt19937 rng(seed);
      std::shuffle(pts.begin(), pts.end(), rng);
      std::vector<char> live(pts.size(), 0);
      std::vector<index_t> ids;
      for (index_t i = 0;
           i < pts.size() && (ids.size() < 6 || !dw::builder3d::spans3D(pts.data(), ids.data(), ids.size()));
           ++i)
        ids.push_back(i);
      Triangulation3D k;
      k.setPoints(pts.data(), pts.size());
      k.build(ids.data(), ids.size());
      for (index_t i : ids) live[i] = 1;
      for (int op = 0; op < 60; ++op) {
        const index_t v = static_cast<index_t>(rng() % pts.size());
        if (live[v]) {
          std::vector<index_t> rest;
          for (index_t i = 0; i < pts.size(); ++i)
            if (live[i] && i != v) rest.push_back(i);
          if (dw::builder3d::spans3D(pts.data(), rest.data(), rest.size())) {
            k.remove(v);
            live[v] = 0;
          } else {
            const Edges before = edgesOf(k);
            ASSERT_THROW(k.remove(v), dw::Error);
            ASSERT_EQ(edgesOf(k), before);
            ++refusals;
          }
        } else {
          k.insert(v);
          live[v] = 1;
        }
        ASSERT_NO_THROW(k.validate());
        std::vector<index_t> now;
        for (index_t i = 0; i < pts.size(); ++i)
          if (live[i]) now.push_back(i);
        ASSERT_EQ(edgesOf(k), freshEdges(pts, now, static_cast<unsigned>(op))) << "op " << op;
      }
    }
  }
  EXPECT_GT(refusals, 0u);  // the refusal path was exercised
}

TEST(VertexRemoval, ErrorsLeaveTheStructureUnchanged) {
  Triangulation3D empty;
  EXPECT_THROW(empty.remove(0), dw::Error);  // not built

  auto pts = b3d_test::uniformCube(300, 16);
  pts.push_back(pts[7]);                     // a duplicate of vertex 7, never inserted
  pts.push_back({0.123f, -0.456f, 0.789f});  // never inserted
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  std::vector<index_t> order = identity(pts.size() - 2);
  k.build(order.data(), order.size());
  const Edges before = edgesOf(k);
  EXPECT_THROW(k.remove(static_cast<index_t>(pts.size())), dw::Error);      // out of range
  EXPECT_THROW(k.remove(static_cast<index_t>(pts.size() - 2)), dw::Error);  // same point as vertex 7
  EXPECT_THROW(k.remove(static_cast<index_t>(pts.size() - 1)), dw::Error);  // not inserted
  k.remove(5);
  EXPECT_THROW(k.remove(5), dw::Error);  // removed twice
  k.insert(5);
  k.validate();
  EXPECT_EQ(edgesOf(k), before);
  EXPECT_EQ(k.numVertices(), pts.size() - 2);

  // Four coplanar points and an apex: without the apex no 3D triangulation exists.
  const std::vector<dw::Vec3f> pyramid = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.4f, 0.3f, 1}};
  Triangulation3D p;
  p.setPoints(pyramid.data(), pyramid.size());
  order = identity(pyramid.size());
  p.build(order.data(), order.size());
  const Edges pyramid_edges = edgesOf(p);
  EXPECT_THROW(p.remove(4), dw::Error);
  p.validate();
  EXPECT_EQ(edgesOf(p), pyramid_edges);
  EXPECT_EQ(p.numVertices(), 5u);
  p.remove(3);  // a base corner can go: four non-coplanar points remain
  p.validate();
  EXPECT_EQ(edgesOf(p).size(), 6u);
}

}  // namespace
