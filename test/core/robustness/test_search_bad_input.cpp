// NeighbourSearch with out-of-range arguments: k, radius, max_nn, hints, non-finite and far queries.
#include <gtest/gtest.h>

#include <limits>

#include "pcl_delaunay_walk/core/search/start_strategy.h"
#include "robustness_util.h"

using namespace dw;
using namespace dw_robust;

namespace {

struct Fixture {
  std::vector<double> xyz = randomCloud(400, 11);
  DelaunayGraph::Ptr g =
      std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), 400)));
  NeighbourSearch s{g};
};

}  // namespace

TEST(SearchBadInput, NullAndEmptyGraphs) {
  EXPECT_THROW(NeighbourSearch(nullptr), Error);
  auto empty = std::make_shared<DelaunayGraph>();
  const NeighbourSearch s(empty);
  std::vector<index_t> idx{1, 2};
  std::vector<float> d2{1.f};
  const WalkResult nn = s.nearest({0, 0, 0});
  EXPECT_EQ(nn.vertex, kInvalidIndex);
  for (StartStrategy st :
       {StartStrategy::Zero, StartStrategy::KdAnn, StartStrategy::Pnn, StartStrategy::PnnOptimized})
    EXPECT_EQ(s.startVertex({1, 2, 3}, st, 5), kInvalidIndex);
  EXPECT_EQ(s.knn({0, 0, 0}, 10, nn, idx, d2), 0u);
  EXPECT_TRUE(idx.empty() && d2.empty()) << "outputs must be cleared";
  EXPECT_EQ(s.radius({0, 0, 0}, 1e30f, nn, idx, d2), 0u);
}

TEST(SearchBadInput, KOutOfRange) {
  Fixture f;
  const Vec3f q{0.1f, 0.2f, 0.3f};
  const WalkResult nn = f.s.nearest(q);
  std::vector<index_t> idx{7};
  std::vector<float> d2{7.f};
  EXPECT_EQ(f.s.knn(q, 0, nn, idx, d2), 0u);
  EXPECT_TRUE(idx.empty() && d2.empty());
  for (std::size_t k :
       {std::size_t(400), std::size_t(401), std::size_t(1) << 40, std::numeric_limits<std::size_t>::max()}) {
    EXPECT_EQ(f.s.knn(q, k, nn, idx, d2), 400u) << "k = " << k;
    EXPECT_TRUE(std::is_sorted(d2.begin(), d2.end()));
  }
  // A stale or foreign WalkResult (vertex out of range) must not be dereferenced.
  WalkResult bogus;
  bogus.vertex = 100000;
  EXPECT_EQ(f.s.knn(q, 5, bogus, idx, d2), 0u);
  EXPECT_EQ(f.s.radius(q, 1.f, bogus, idx, d2), 0u);
}

TEST(SearchBadInput, RadiusOutOfRange) {
  Fixture f;
  const Vec3f q{0.f, 0.f, 0.f};
  const WalkResult nn = f.s.nearest(q);
  std::vector<index_t> idx;
  std::vector<float> d2;
  EXPECT_EQ(f.s.radius(q, -1.f, nn, idx, d2), 0u);
  EXPECT_EQ(f.s.radius(q, -0.f, nn, idx, d2), f.s.radius(q, 0.f, nn, idx, d2));
  EXPECT_EQ(f.s.radius(q, std::numeric_limits<float>::quiet_NaN(), nn, idx, d2), 0u);
  EXPECT_EQ(f.s.radius(q, std::numeric_limits<float>::infinity(), nn, idx, d2), 400u);
  EXPECT_EQ(f.s.radius(q, std::numeric_limits<float>::max(), nn, idx, d2), 400u);
  EXPECT_EQ(f.s.radius(q, 1e30f, nn, idx, d2, 1), 1u);
  EXPECT_EQ(f.s.radius(q, 1e30f, nn, idx, d2, std::numeric_limits<std::size_t>::max()), 400u);
}

TEST(SearchBadInput, HintsOutOfRange) {
  Fixture f;
  const auto queries = mixedQueries(*f.g, f.xyz, 20, 3);
  for (const Vec3f& q : queries)
    for (index_t hint : {index_t(400), index_t(1) << 31, kInvalidIndex - 1, kInvalidIndex}) {
      const WalkResult expect = f.s.nearest(q, StartStrategy::KdAnn);
      for (StartStrategy st : {StartStrategy::Pnn, StartStrategy::PnnOptimized}) {
        const WalkResult r = f.s.nearest(q, st, hint);
        ASSERT_LT(r.vertex, f.g->numVertices());
        EXPECT_EQ(r.dist2, expect.dist2);
      }
      // walk() itself must not trust its start either.
      EXPECT_EQ(walk(*f.g, q, hint).dist2, expect.dist2);
    }
}

TEST(SearchBadInput, NonFiniteQueriesNeverCrashOrReturnGarbageIndices) {
  // A NaN query has no nearest neighbour; whatever comes back must be valid indices and the call
  // must terminate (NaN comparisons are false, so a naive walk or heap could misbehave).
  Fixture f;
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<index_t> idx;
  std::vector<float> d2;
  for (const Vec3f& q : {Vec3f{nan, 0, 0}, Vec3f{nan, nan, nan}, Vec3f{inf, 0, 0}, Vec3f{-inf, inf, 0},
                         Vec3f{inf, inf, inf}}) {
    for (StartStrategy st :
         {StartStrategy::Zero, StartStrategy::KdAnn, StartStrategy::Pnn, StartStrategy::PnnOptimized}) {
      const WalkResult nn = f.s.nearest(q, st, 3);
      ASSERT_LT(nn.vertex, f.g->numVertices());
      f.s.knn(q, 10, nn, idx, d2);
      ASSERT_LE(idx.size(), 10u);
      for (index_t i : idx) ASSERT_LT(i, 400u);
      f.s.radius(q, 0.5f, nn, idx, d2);
      for (index_t i : idx) ASSERT_LT(i, 400u);
    }
  }
}

TEST(SearchBadInput, FarQueriesStayExact) {
  // Far outside the hull the walk runs along the hull; distances are large but still finite in float.
  Fixture f;
  std::vector<Vec3f> far;
  for (float r : {1e3f, 1e6f, 1e9f, 1e15f})
    for (const Vec3f& dir : {Vec3f{1, 0, 0}, Vec3f{-0.6f, 0.8f, 0}, Vec3f{0.3f, -0.4f, -0.866f}})
      far.push_back({dir.x * r, dir.y * r, dir.z * r});
  EXPECT_EQ(checkAgainstBruteForce(f.xyz, f.g, far), "");
}

TEST(SearchBadInput, UnknownStartStrategyName) {
  EXPECT_THROW(parseStartStrategy(""), Error);
  EXPECT_THROW(parseStartStrategy("kdtree"), Error);
  EXPECT_THROW(parseStartStrategy(std::string("zero\0x", 6)), Error);
  EXPECT_EQ(parseStartStrategy("PNN-Optimized"), StartStrategy::PnnOptimized);
}
