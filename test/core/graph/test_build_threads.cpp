// buildDelaunayGraph on several threads: every array of the graph (vertices, duplicates' originals,
// the input map, records, safe radii) is the same as on one thread. The cloud is big enough (200k
// inputs) for the preparation's blocks to be split among workers, and holds non-finite points and
// exact repeats scattered through the input, so that runs of repeats cross the blocks' borders.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"

using namespace dw;

namespace {

TEST(BuildThreads, SameGraphForAnyThreadCount) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  std::uniform_int_distribution<int> pick(0, 99);
  std::vector<float> xyz;
  const std::size_t n = 200000;
  xyz.reserve(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const int kind = pick(rng);
    if (kind < 5 && i > 0) {  // an exact repeat of an earlier input
      const std::size_t j = std::uniform_int_distribution<std::size_t>(0, i - 1)(rng);
      for (int a = 0; a < 3; ++a) xyz.push_back(xyz[3 * j + a]);
    } else if (kind < 7) {  // non-finite
      xyz.insert(xyz.end(), {u(rng), kind == 5 ? NAN : INFINITY, u(rng)});
    } else {
      xyz.insert(xyz.end(), {u(rng), u(rng), u(rng)});
    }
  }
  const PointView view = PointView::fromFloat(xyz.data(), n);
  BuildOptions one;
  one.num_threads = 1;
  const DelaunayGraph a = buildDelaunayGraph(view, one);
  a.validate();
  ASSERT_LT(a.numVertices() + 9000, n);  // repeats collapsed and non-finite points skipped
  for (const unsigned threads : {2u, 3u}) {
    BuildOptions options;
    options.num_threads = threads;
    const DelaunayGraph b = buildDelaunayGraph(view, options);
    ASSERT_EQ(a.points.size(), b.points.size()) << threads;
    EXPECT_EQ(0, std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(Vec3f))) << threads;
    EXPECT_EQ(a.originals, b.originals) << threads;
    EXPECT_EQ(a.originals_offsets, b.originals_offsets) << threads;
    EXPECT_EQ(a.input_to_vertex, b.input_to_vertex) << threads;
    EXPECT_EQ(a.offsets, b.offsets) << threads;
    ASSERT_EQ(a.edges.size(), b.edges.size()) << threads;
    EXPECT_EQ(0, std::memcmp(a.edges.data(), b.edges.data(), a.edges.size() * sizeof(EdgeRecord))) << threads;
    EXPECT_EQ(a.safe_radius2, b.safe_radius2) << threads;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a.origin[k], b.origin[k]) << threads;
  }
}

}  // namespace
