// The walk's two shortcuts: the per-vertex safe ball (DelaunayGraph::safe_radius2) and the four-wide
// stopping test (edge_scan.h). Both must leave every answer exact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "core/brute_force.h"
#include "pcl_delaunay_walk/core/search/edge_scan.h"

using namespace dw;

namespace {

std::shared_ptr<DelaunayGraph> graphOf(const std::vector<double>& xyz) {
  return std::make_shared<DelaunayGraph>(
      buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3)));
}

/// Squared distance from vertex v to its nearest other vertex, by brute force in double.
double nearestOtherD2(const DelaunayGraph& g, index_t v) {
  double best = INFINITY;
  for (index_t w = 0; w < g.numVertices(); ++w)
    if (w != v) best = std::min(best, squaredDistanceD(g.points[v], g.points[w]));
  return best;
}

}  // namespace

TEST(SafeRadius, IsHalfTheNearestNeighbourDistanceShrunk) {
  const auto g = graphOf(dw_test::uniformCube(2000, 41));
  ASSERT_EQ(g->safe_radius2.size(), g->numVertices());
  for (index_t v = 0; v < g->numVertices(); ++v) {
    const double half2 = nearestOtherD2(*g, v) / 4.0;
    EXPECT_LT(double(g->safe_radius2[v]), half2) << v;  // strictly inside: ties stay with the scan
    EXPECT_GT(double(g->safe_radius2[v]), half2 * (1.0 - 5e-5)) << v;  // and not needlessly small
  }
}

TEST(Graph, NeighbourhoodsAreShortestFirstAndOldOrderIsRepaired) {
  auto g = graphOf(dw_test::uniformCube(500, 47));
  for (index_t v = 0; v < g->numVertices(); ++v)
    for (index_t e = g->offsets[v]; e + 1 < g->offsets[v + 1]; ++e)
      ASSERT_LE(g->edges[e].m, g->edges[e + 1].m);
  // A graph in the previous order (ascending j, as files of earlier versions hold) fails validation
  // and is put back in order by sortNeighbourhoods (what loading does).
  DelaunayGraph old = *g;
  for (index_t v = 0; v < old.numVertices(); ++v)
    std::sort(old.edges.begin() + old.offsets[v], old.edges.begin() + old.offsets[v + 1],
              [](const EdgeRecord& a, const EdgeRecord& b) { return a.j < b.j; });
  EXPECT_THROW(old.validate(), Error);
  sortNeighbourhoods(old);
  EXPECT_NO_THROW(old.validate());
  EXPECT_EQ(0, std::memcmp(old.edges.data(), g->edges.data(), g->edges.size() * sizeof(EdgeRecord)));
}

TEST(Graph, DistinctEdgeListsSkipTheSortButAreChecked) {
  // The same edges, once listed with repeats and reversed pairs (any builder may) and once distinct
  // and shuffled (the incremental builder's promise): the same records either way.
  const auto g = graphOf(dw_test::uniformCube(400, 53));
  std::vector<std::pair<index_t, index_t>> distinct, repeated;
  for (index_t v = 0; v < g->numVertices(); ++v)
    for (index_t e = g->offsets[v]; e < g->offsets[v + 1]; ++e) {
      const index_t j = g->edges[e].j;
      repeated.emplace_back(v, j);  // every edge twice, once per orientation
      if (v < j) distinct.emplace_back((v + j) % 2 ? v : j, (v + j) % 2 ? j : v);
    }
  std::mt19937 rng(5);
  std::shuffle(distinct.begin(), distinct.end(), rng);
  DelaunayGraph a, b;
  a.points = b.points = g->points;
  assembleEdges(a, repeated);
  assembleEdges(b, distinct, true);
  ASSERT_EQ(a.offsets, b.offsets);
  ASSERT_EQ(a.edges.size(), g->edges.size());
  EXPECT_EQ(0, std::memcmp(a.edges.data(), b.edges.data(), a.edges.size() * sizeof(EdgeRecord)));
  EXPECT_EQ(a.safe_radius2, b.safe_radius2);
  // A broken promise is an error, not a graph with a doubled edge: repeated as is, and reversed.
  for (const bool reversed : {false, true}) {
    auto bad = distinct;
    const auto e = bad[bad.size() / 2];
    bad.push_back(reversed ? std::make_pair(e.second, e.first) : e);
    DelaunayGraph c;
    c.points = g->points;
    EXPECT_THROW(assembleEdges(c, bad, true), Error) << reversed;
  }
}

TEST(SafeRadius, TooLargeARadiusFailsValidation) {
  auto g = graphOf(dw_test::uniformCube(200, 42));
  g->validate();
  g->safe_radius2[17] = 1e3f;
  EXPECT_THROW(g->validate(), Error);
  g->safe_radius2.resize(3);
  EXPECT_THROW(g->validate(), Error);
  g->safe_radius2.clear();  // empty disables the shortcut and is valid
  EXPECT_NO_THROW(g->validate());
}

TEST(SafeRadius, EdgeLengthsBeyondFloatSquaresGiveNoBall) {
  // Found by fuzz_graph_file: a file whose (finite) half-lengths square past FLT_MAX made the stored
  // radius inf, which validate() then rejected. Such vertices get no ball (0), and the graph is valid.
  auto g = graphOf(dw_test::uniformCube(50, 48));
  for (auto& e : g->edges) e.m *= 1e30f;
  computeSafeRadii(*g);
  EXPECT_NO_THROW(g->validate());
  for (float r2 : g->safe_radius2) EXPECT_EQ(r2, 0.f);
}

TEST(SafeRadius, QueriesAroundTheBallBoundaryStayExact) {
  // Queries at 0.9, 0.99999, 1, 1.00001 and 1.1 safe radii from a vertex, towards its nearest
  // neighbour (where the ball touches the Voronoi face: the hardest direction) and in random ones.
  const auto xyz = dw_test::uniformCube(3000, 43);
  const auto g = graphOf(xyz);
  NeighbourSearch s(g);
  std::mt19937 rng(44);
  std::normal_distribution<float> n01;
  int checked = 0;
  for (index_t v = 0; v < g->numVertices(); v += 7) {
    const Vec3f x = g->points[v];
    index_t nn = kInvalidIndex;
    float min_m = INFINITY;
    for (index_t e = g->offsets[v]; e < g->offsets[v + 1]; ++e)
      if (g->edges[e].m < min_m) min_m = g->edges[e].m, nn = g->edges[e].j;
    const Vec3f to_nn = g->points[nn] - x;
    const float len = std::sqrt(dot(to_nn, to_nn));
    const Vec3f random_dir{n01(rng), n01(rng), n01(rng)};
    const float rlen = std::sqrt(dot(random_dir, random_dir));
    const float r = std::sqrt(g->safe_radius2[v]);
    for (float f : {0.9f, 0.99999f, 1.f, 1.00001f, 1.1f}) {
      for (int dir = 0; dir < 2; ++dir) {
        const Vec3f d = dir == 0 ? to_nn : random_dir;
        const float step = f * r / (dir == 0 ? len : rlen);
        const Vec3f q{x.x + d.x * step, x.y + d.y * step, x.z + d.z * step};
        const float expected = dw_test::allDistances(*g, xyz, q).front();
        const WalkResult from_v = walk(*g, q, v);
        const WalkResult from_kd = s.nearest(q, StartStrategy::KdAnn);
        EXPECT_NEAR(from_v.dist2, expected, dw_test::tol(expected, 4.f)) << v << " f=" << f;
        EXPECT_NEAR(from_kd.dist2, expected, dw_test::tol(expected, 4.f)) << v << " f=" << f;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 4000);
}

TEST(EdgeScan, FourWideMatchesTheScalarLoopBitForBit) {
  std::mt19937 rng(45);
  std::uniform_real_distribution<float> u(-2.f, 2.f);
  std::uniform_int_distribution<int> small(0, 3);
  int moves = 0;
  for (int degree = 0; degree <= 13; ++degree) {
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<EdgeRecord> e(degree);
      index_t j = 0;
      for (auto& r : e) r = {u(rng), u(rng), u(rng), std::abs(u(rng)), j++};
      // Every third trial: equal records, so that gains tie across lanes and the first edge must win.
      if (trial % 3 == 0 && degree > 4)
        for (auto& r : e) {
          const int k = small(rng);
          r = {float(k) * 0.5f, 0.25f, -0.5f, 0.1f, r.j};
        }
      const Vec3f q{u(rng), u(rng), u(rng)};
      const EdgeScan ref = scanEdgesScalar(e.data(), e.data() + e.size(), q);
      const EdgeScan fast = scanEdges(e.data(), e.data() + e.size(), q);
      EXPECT_EQ(fast.best, ref.best) << degree << "/" << trial;
      moves += ref.best != kInvalidIndex;
#if defined(__FMA__)  // the scalar loop may be contracted into FMAs, the intrinsics are not
      EXPECT_NEAR(fast.max_margin, ref.max_margin, 1e-5f) << degree;
#else
      EXPECT_EQ(0, std::memcmp(&fast.max_margin, &ref.max_margin, sizeof(float))) << degree << "/" << trial;
      EXPECT_EQ(0, std::memcmp(&fast.best_gain, &ref.best_gain, sizeof(float))) << degree << "/" << trial;
#endif
    }
  }
  EXPECT_GT(moves, 1000);  // the move-choosing path was exercised, not only the stopping test
}

TEST(EdgeScan, ShortestFirstEarlyStopKeepsTheWalksDecision) {
  // Neighbourhoods sorted by m (the graph's order): stopping at the first edge longer than |u| must
  // give the same move and the same stop / undecided verdict as reading every edge.
  std::mt19937 rng(46);
  std::uniform_real_distribution<float> u(-1.f, 1.f), len(0.01f, 1.f), scale(0.f, 1.5f);
  int stopped_early = 0, total = 0;
  for (int degree = 1; degree <= 40; ++degree) {
    for (int trial = 0; trial < 100; ++trial) {
      std::vector<EdgeRecord> e(degree);
      index_t j = 0;
      for (auto& r : e) {
        const Vec3f d{u(rng), u(rng), u(rng)};
        const float n = std::sqrt(dot(d, d));
        r = {d.x / n, d.y / n, d.z / n, len(rng), j++};
      }
      std::sort(e.begin(), e.end(), [](const EdgeRecord& a, const EdgeRecord& b) { return a.m < b.m; });
      const Vec3f dir{u(rng), u(rng), u(rng)};
      const float s = scale(rng) * e.back().m / std::sqrt(dot(dir, dir));
      const Vec3f q{dir.x * s, dir.y * s, dir.z * s};
      const float dist = std::sqrt(dot(q, q));
      const float tolerance = 2e-6f * dist + 1e-30f;
      const float stop_m = dist * 1.0001f + 2.f * tolerance;  // as walk.h
      const EdgeScan full = scanEdgesScalar(e.data(), e.data() + e.size(), q);
      for (const EdgeScan& fast : {scanEdges(e.data(), e.data() + e.size(), q, stop_m),
                                   scanEdgesScalar(e.data(), e.data() + e.size(), q, stop_m)}) {
        EXPECT_EQ(fast.best, full.best) << degree << "/" << trial;
        EXPECT_EQ(fast.max_margin > -tolerance, full.max_margin > -tolerance) << degree << "/" << trial;
      }
      stopped_early += e.back().m > stop_m;
      ++total;
    }
  }
  EXPECT_GT(stopped_early, total / 4);  // the early stop was exercised
}
