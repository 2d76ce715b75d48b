// Many threads querying one NeighbourSearch give exactly the single-threaded answers.
#include <gtest/gtest.h>

#include <thread>

#include "core/brute_force.h"

using namespace dw;

TEST(Concurrency, ManyThreadsShareOneSearch) {
  const auto xyz = dw_test::uniformCube(5000, 41);
  auto g = std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), 5000)));
  const NeighbourSearch s(g);
  const auto queries = dw_test::uniformCube(4000, 42, -1.2, 1.2);
  const std::size_t nq = queries.size() / 3;
  auto answer = [&](std::size_t i, std::vector<index_t>& idx, std::vector<float>& d2) {
    const Vec3f q = g->toLocal(queries[3 * i], queries[3 * i + 1], queries[3 * i + 2]);
    const WalkResult nn = s.nearest(q, i % 2 ? StartStrategy::KdAnn : StartStrategy::Zero);
    if (i % 3 == 0)
      s.radius(q, 0.04f, nn, idx, d2);
    else
      s.knn(q, 1 + i % 17, nn, idx, d2);
  };
  std::vector<std::vector<index_t>> expect(nq);
  std::vector<float> d2;
  for (std::size_t i = 0; i < nq; ++i) answer(i, expect[i], d2);

  const unsigned threads = 8;
  std::vector<int> mismatches(threads, 0);
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      std::vector<index_t> idx;
      std::vector<float> dd;
      for (int rep = 0; rep < 3; ++rep)
        for (std::size_t i = t; i < nq; i += threads / 2) {  // overlapping shares: same queries raced
          answer(i, idx, dd);
          mismatches[t] += idx != expect[i];
        }
    });
  for (auto& th : pool) th.join();
  for (unsigned t = 0; t < threads; ++t) EXPECT_EQ(mismatches[t], 0) << "thread " << t;
}
