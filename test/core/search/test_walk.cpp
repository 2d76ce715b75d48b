// Walk details: step counts by strategy, termination on rounding ties, start strategies and helpers.
#include <gtest/gtest.h>

#include "core/brute_force.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"

using namespace dw;

TEST(Walk, PnnHintFromPreviousIterationTakesFewSteps) {
  // ICP-like: queries move a little between rounds; walking from the previous answer takes ~1-2 steps,
  // far fewer than from the Zero vertex.
  const auto xyz = dw_test::uniformCube(20000, 31);
  auto g =
      std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3)));
  NeighbourSearch s(g);
  std::mt19937 rng(2);
  std::normal_distribution<float> jitter(0.f, 0.005f);
  double steps_zero = 0, steps_kd = 0, steps_pnn = 0;
  const int nq = 2000;
  for (int i = 0; i < nq; ++i) {
    const Vec3f q = g->toLocal(xyz[3 * i] + 0.01, xyz[3 * i + 1], xyz[3 * i + 2]);
    const WalkResult prev = s.nearest(q, StartStrategy::KdAnn);
    const Vec3f q2{q.x + jitter(rng), q.y + jitter(rng), q.z + jitter(rng)};
    const WalkResult a = s.nearest(q2, StartStrategy::Zero);
    const WalkResult b = s.nearest(q2, StartStrategy::KdAnn);
    const WalkResult c = s.nearest(q2, StartStrategy::Pnn, prev.vertex);
    EXPECT_FLOAT_EQ(a.dist2, c.dist2);
    EXPECT_FLOAT_EQ(b.dist2, c.dist2);
    steps_zero += a.steps, steps_kd += b.steps, steps_pnn += c.steps;
  }
  steps_zero /= nq, steps_kd /= nq, steps_pnn /= nq;
  EXPECT_LT(steps_pnn, 2.0);
  EXPECT_LT(steps_pnn, steps_kd);
  EXPECT_LT(steps_kd, steps_zero);
  EXPECT_GT(steps_zero, 5.0);
}

TEST(Walk, OutOfRangeHintsAndEmptyGraph) {
  const auto xyz = dw_test::uniformCube(100, 32);
  auto g = std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), 100)));
  NeighbourSearch s(g);
  const Vec3f q{0.1f, 0.2f, 0.3f};
  const float d = s.nearest(q, StartStrategy::KdAnn).dist2;
  EXPECT_FLOAT_EQ(s.nearest(q, StartStrategy::Pnn, 1000000).dist2, d);
  EXPECT_FLOAT_EQ(s.nearest(q, StartStrategy::PnnOptimized, kInvalidIndex).dist2, d);
  EXPECT_FLOAT_EQ(walk(*g, q, 999999).dist2, d);  // out-of-range start is clamped

  auto empty = std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(nullptr, 0)));
  NeighbourSearch e(empty);
  EXPECT_EQ(e.nearest(q).vertex, kInvalidIndex);
  std::vector<index_t> idx;
  std::vector<float> d2;
  EXPECT_EQ(e.knn(q, 5, e.nearest(q), idx, d2), 0u);
  EXPECT_EQ(e.radius(q, 1.f, e.nearest(q), idx, d2), 0u);
}

TEST(Walk, TerminatesOnEquidistantTies) {
  // A query at the centre of a cube of 8 corners + a grid: every corner ties.
  std::vector<double> xyz;
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 6; ++y)
      for (int z = 0; z < 6; ++z) xyz.insert(xyz.end(), {double(x), double(y), double(z)});
  auto g =
      std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3)));
  NeighbourSearch s(g);
  const Vec3f q = g->toLocal(2.5, 2.5, 2.5);
  for (StartStrategy st : {StartStrategy::Zero, StartStrategy::KdAnn})
    EXPECT_FLOAT_EQ(s.nearest(q, st).dist2, 0.75f);
}

TEST(StartStrategy, ParseAndPrint) {
  for (StartStrategy s :
       {StartStrategy::Zero, StartStrategy::KdAnn, StartStrategy::Pnn, StartStrategy::PnnOptimized})
    EXPECT_EQ(parseStartStrategy(toString(s)), s);
  EXPECT_EQ(parseStartStrategy("KD_ANN"), StartStrategy::KdAnn);
  EXPECT_THROW(parseStartStrategy("nearest"), Error);
}

TEST(Graph, LayoutInvariants) {
  const auto xyz = dw_test::uniformCube(3000, 33);
  const auto g = buildDelaunayGraph(PointView::fromDouble(xyz.data(), 3000));
  ASSERT_NO_THROW(g.validate());
  EXPECT_EQ(g.dimension, 3);
  // Every edge is stored both ways, with a unit vector and half its length.
  for (index_t v = 0; v < g.numVertices(); ++v)
    for (index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const EdgeRecord& e = g.edges[k];
      const Vec3f d = g.points[e.j] - g.points[v];
      EXPECT_NEAR(std::sqrt(dot(d, d)) / 2, e.m, 1e-5);
      EXPECT_NEAR(e.ex * e.ex + e.ey * e.ey + e.ez * e.ez, 1.0, 1e-5);
      bool back = false;
      for (index_t b = g.offsets[e.j]; b < g.offsets[e.j + 1]; ++b) back |= g.edges[b].j == v;
      EXPECT_TRUE(back);
    }
  // Mean degree of a 3D Delaunay graph of uniform points is ~15.5 (docs/architecture.md, "The walk graph").
  const double mean = double(g.numDirectedEdges()) / g.numVertices();
  EXPECT_GT(mean, 13.0);
  EXPECT_LT(mean, 17.0);
}

TEST(Graph, ProgressIsReported) {
  const auto xyz = dw_test::uniformCube(200, 34);
  std::vector<std::string> stages;
  BuildOptions o;
  o.progress = [&](const std::string& s, double) { stages.push_back(s); };
  buildDelaunayGraph(PointView::fromDouble(xyz.data(), 200), o);
  EXPECT_FALSE(stages.empty());
  EXPECT_EQ(stages.front(), "prepare");
}

TEST(Graph, BadPointViewIsAnError) {
  EXPECT_THROW(buildDelaunayGraph(PointView::fromDouble(nullptr, 5)), Error);
}
