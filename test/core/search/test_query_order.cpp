// dw::orderByStartVertex: a stable grouping permutation of a walk batch.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "pcl_delaunay_walk/core/search/query_order.h"

using namespace dw;

TEST(QueryOrder, IsAStableGroupingPermutation) {
  std::mt19937 rng(5);
  const std::size_t nv = 10000, n = 5000;
  std::uniform_int_distribution<index_t> vertex(0, nv + 100);  // some invalid (>= nv) starts too
  std::vector<index_t> start(n);
  for (auto& s : start) s = rng() % 7 == 0 ? kInvalidIndex : vertex(rng);
  const std::vector<index_t> order = orderByStartVertex(start.data(), n, nv);
  ASSERT_EQ(order.size(), n);
  std::vector<index_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i);  // a permutation
  auto group = [&](index_t i) -> long { return start[i] < nv ? long(start[i] / 64) : -1L; };
  for (std::size_t k = 1; k < n; ++k) {
    ASSERT_LE(group(order[k - 1]), group(order[k])) << k;  // grouped, ascending
    if (group(order[k - 1]) == group(order[k])) {
      ASSERT_LT(order[k - 1], order[k]) << k;  // stable within a group
    }
  }
  EXPECT_TRUE(orderByStartVertex(start.data(), 0, nv).empty());
}
