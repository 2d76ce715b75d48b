// assembleEdges on several threads: the records, offsets and safe radii are the same bytes as on one
// thread, whatever the list's order, and a repeated edge is still found. The cloud is big enough
// (40k points, ~300k edges) that the list and the vertices are really split among the workers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "core/brute_force.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"

using namespace dw;

namespace {

void expectSameGraph(const DelaunayGraph& a, const DelaunayGraph& b, const std::string& what) {
  ASSERT_EQ(a.offsets, b.offsets) << what;
  ASSERT_EQ(a.edges.size(), b.edges.size()) << what;
  EXPECT_EQ(0, std::memcmp(a.edges.data(), b.edges.data(), a.edges.size() * sizeof(EdgeRecord))) << what;
  EXPECT_EQ(a.safe_radius2, b.safe_radius2) << what;
}

TEST(AssembleEdges, SameGraphOnAnyThreadCount) {
  const std::vector<double> xyz = dw_test::uniformCube(40000, 61);
  const DelaunayGraph built = buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3));
  built.validate();
  std::vector<std::pair<index_t, index_t>> distinct, repeated;
  for (index_t v = 0; v < built.numVertices(); ++v)
    for (index_t e = built.offsets[v]; e < built.offsets[v + 1]; ++e) {
      const index_t j = built.edges[e].j;
      repeated.emplace_back(j, v);  // every edge twice, once per orientation
      if (v < j) distinct.emplace_back((v + j) % 2 ? v : j, (v + j) % 2 ? j : v);
    }
  std::mt19937 rng(9);
  std::shuffle(distinct.begin(), distinct.end(), rng);
  ASSERT_GT(distinct.size(), std::size_t(4) << 16);  // several list workers

  DelaunayGraph one;
  one.points = built.points;
  assembleEdges(one, distinct, true, 1);
  expectSameGraph(built, one, "one thread");
  for (const unsigned threads : {2u, 3u, 8u}) {
    DelaunayGraph g;
    g.points = built.points;
    assembleEdges(g, distinct, true, threads);
    expectSameGraph(one, g, "distinct list, threads " + std::to_string(threads));
    DelaunayGraph r;
    r.points = built.points;
    assembleEdges(r, repeated, false, threads);
    expectSameGraph(one, r, "repeated list, threads " + std::to_string(threads));
  }

  // A broken promise of distinct edges is found by whichever worker holds the vertex.
  for (const std::size_t at : {std::size_t(0), distinct.size() / 2, distinct.size() - 1}) {
    auto bad = distinct;
    bad.push_back({bad[at].second, bad[at].first});
    DelaunayGraph c;
    c.points = built.points;
    EXPECT_THROW(assembleEdges(c, bad, true, 4), Error) << at;
  }
  // An edge to a missing vertex, in any worker's block.
  auto missing = distinct;
  missing[missing.size() - 3].second = static_cast<index_t>(built.numVertices());
  DelaunayGraph d;
  d.points = built.points;
  EXPECT_THROW(assembleEdges(d, missing, true, 4), Error);
}

// A record's fields as the assembly defines them, computed here on their own: (x_j - x_v) / |.| and
// |.| / 2 for the float difference, to the bit (zeros keep the sign the difference gives them).
void expectRecordOf(const DelaunayGraph& g, index_t v, const EdgeRecord& r) {
  const Vec3f d = g.points[r.j] - g.points[v];
  const double len = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
  const double inv = len > 0.0 ? 1.0 / len : 0.0;
  const float want[4] = {float(d.x * inv), float(d.y * inv), float(d.z * inv), float(0.5 * len)};
  const float got[4] = {r.ex, r.ey, r.ez, r.m};
  EXPECT_EQ(0, std::memcmp(want, got, sizeof want)) << "record " << v << " -> " << r.j;
}

// One vertex joined to n others, for n on both sides of each size the assembly ranks a neighbourhood
// at (16, 32, 64; a sort above), on lattice points where many edges have the same length: its records
// come out ordered by (length, neighbour id), each neighbour once, and a repeated edge is found. Every
// record is the one defined above, those towards the centre too, whose zero components are +0.
TEST(AssembleEdges, NeighbourhoodsOfEverySizeAreOrderedByLengthThenId) {
  std::vector<Vec3f> lattice;
  for (int x = -4; x <= 4; ++x)
    for (int y = -4; y <= 4; ++y)
      for (int z = -4; z <= 4; ++z)
        if (x != 0 || y != 0 || z != 0) lattice.push_back({float(x), float(y), float(z)});
  std::mt19937 rng(5);
  std::shuffle(lattice.begin(), lattice.end(), rng);
  for (const index_t n : {1u, 2u, 15u, 16u, 17u, 31u, 32u, 33u, 63u, 64u, 65u, 300u}) {
    DelaunayGraph g;
    g.points.push_back({0.f, 0.f, 0.f});
    g.points.insert(g.points.end(), lattice.begin(), lattice.begin() + n);
    std::vector<std::pair<index_t, index_t>> star;
    for (index_t j = 1; j <= n; ++j) star.emplace_back(j % 2 ? 0 : j, j % 2 ? j : 0);
    std::shuffle(star.begin(), star.end(), rng);
    assembleEdges(g, star, true, 1);
    ASSERT_EQ(g.offsets[1], n) << n;
    std::vector<char> seen(n + 1, 0);
    for (index_t e = 0; e < n; ++e) {
      const EdgeRecord& r = g.edges[e];
      ASSERT_TRUE(r.j >= 1 && r.j <= n && !seen[r.j]) << n << " neighbours: record " << e;
      seen[r.j] = 1;
      expectRecordOf(g, 0, r);
      if (e > 0) {
        const EdgeRecord& p = g.edges[e - 1];
        EXPECT_TRUE(p.m < r.m || (p.m == r.m && p.j < r.j))
            << n << " neighbours: records " << e - 1 << ", " << e;
      }
    }
    for (index_t j = 1; j <= n; ++j) {
      ASSERT_EQ(g.offsets[j + 1] - g.offsets[j], 1u);
      EXPECT_EQ(g.edges[g.offsets[j]].j, 0u);
      expectRecordOf(g, j, g.edges[g.offsets[j]]);
    }
    if (n < 2) continue;
    star.push_back({star[n / 2].second, star[n / 2].first});
    DelaunayGraph r;
    r.points = g.points;
    EXPECT_THROW(assembleEdges(r, star, true, 1), Error) << n;
  }
}

}  // namespace
