// Concurrency: many threads query one graph while other threads build, load and query different
// graphs. Every answer must equal the single-threaded answer, which itself equals brute force.
// Run under ThreadSanitizer by scripts/sanitize.sh.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "robustness_util.h"

using namespace dw;
using namespace dw_robust;

namespace {

struct Answer {
  index_t nn = kInvalidIndex;
  std::vector<index_t> idx;
  bool operator==(const Answer& o) const { return nn == o.nn && idx == o.idx; }
};

Answer ask(const NeighbourSearch& s, const Vec3f& q, std::size_t i) {
  static const StartStrategy kStrategies[] = {StartStrategy::Zero, StartStrategy::KdAnn, StartStrategy::Pnn,
                                              StartStrategy::PnnOptimized};
  Answer a;
  const WalkResult nn = s.nearest(q, kStrategies[i % 4], index_t(i));
  a.nn = nn.vertex;
  std::vector<float> d2;
  if (i % 3 == 0)
    s.radius(q, 0.02f, nn, a.idx, d2);
  else
    s.knn(q, 1 + i % 23, nn, a.idx, d2);
  return a;
}

/// A cloud of a different size and shape per round, including degenerate ones.
std::vector<double> roundCloud(unsigned round) {
  auto xyz = randomCloud(150 + 170 * (round % 7), 1000 + round);
  if (round % 4 == 1)
    for (std::size_t i = 2; i < xyz.size(); i += 3) xyz[i] = 0.0;  // coplanar
  if (round % 4 == 2)
    for (std::size_t i = 0; i < xyz.size() / 2; ++i) xyz[xyz.size() / 2 + i] = xyz[i];  // duplicates
  return xyz;
}

}  // namespace

TEST(ConcurrencyRebuild, QueriesStayExactWhileOtherGraphsAreBuilt) {
  const auto xyz = randomCloud(3000, 77);
  auto g = std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(xyz.data(), 3000)));
  const NeighbourSearch search(g);
  const auto queries = mixedQueries(*g, xyz, 900, 78);
  ASSERT_EQ(checkAgainstBruteForce(xyz, g, std::vector<Vec3f>(queries.begin(), queries.begin() + 40)), "");
  std::vector<Answer> expect(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) expect[i] = ask(search, queries[i], i);

  std::atomic<bool> stop{false};
  std::atomic<int> rebuild_failures{0}, rounds{0};
  std::string first_failure;
  // The rebuilder: builds, validates, saves/loads and queries other graphs while the readers run.
  std::thread rebuilder([&] {
    for (unsigned round = 0; !stop.load() || round < 3; ++round) {
      const auto other = roundCloud(round);
      try {
        auto h = std::make_shared<DelaunayGraph>(
            buildDelaunayGraph(PointView::fromDouble(other.data(), other.size() / 3)));
        const auto bytes = serializeGraph(*h);
        auto loaded = std::make_shared<DelaunayGraph>(deserializeGraph(bytes.data(), bytes.size()));
        const std::string why =
            checkAgainstBruteForce(other, loaded, mixedQueries(*loaded, other, 15, round));
        if (!why.empty()) {
          if (rebuild_failures++ == 0) first_failure = "round " + std::to_string(round) + ": " + why;
        }
      } catch (const std::exception& e) {
        if (rebuild_failures++ == 0) first_failure = "round " + std::to_string(round) + " threw: " + e.what();
      }
      ++rounds;
    }
  });
  const unsigned readers = 6;
  std::vector<int> mismatches(readers, 0);
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < readers; ++t)
    pool.emplace_back([&, t] {
      for (int rep = 0; rep < 2; ++rep)
        for (std::size_t i = t; i < queries.size(); i += readers / 2)  // overlapping shares
          mismatches[t] += !(ask(search, queries[i], i) == expect[i]);
    });
  for (auto& th : pool) th.join();
  stop = true;
  rebuilder.join();
  for (unsigned t = 0; t < readers; ++t) EXPECT_EQ(mismatches[t], 0) << "reader " << t;
  EXPECT_EQ(rebuild_failures.load(), 0) << first_failure;
  EXPECT_GE(rounds.load(), 3);
}

TEST(ConcurrencyRebuild, ParallelBuildsAndLoadsAreIndependent) {
  // Several threads build at once (each its own cloud) and load one shared file image at once.
  const auto shared_xyz = randomCloud(800, 5);
  const auto bytes = serializeGraph(buildDelaunayGraph(PointView::fromDouble(shared_xyz.data(), 800)));
  const unsigned threads = 4;
  std::vector<std::string> failures(threads);
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      try {
        for (unsigned round = t; round < t + 3; ++round) {
          const auto xyz = roundCloud(round);
          auto g = std::make_shared<DelaunayGraph>(
              buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3)));
          const std::string why = checkAgainstBruteForce(xyz, g, mixedQueries(*g, xyz, 10, t));
          if (!why.empty() && failures[t].empty()) failures[t] = why;
          auto loaded = std::make_shared<DelaunayGraph>(deserializeGraph(bytes.data(), bytes.size()));
          if (serializeGraph(*loaded) != bytes && failures[t].empty()) failures[t] = "loaded graph differs";
        }
      } catch (const std::exception& e) {
        failures[t] = e.what();
      }
    });
  for (auto& th : pool) th.join();
  for (unsigned t = 0; t < threads; ++t) EXPECT_EQ(failures[t], "") << "thread " << t;
}

TEST(ConcurrencyRebuild, OneThreadAlternatingBetweenGraphsOfDifferentSizes) {
  // The per-thread scratch is shared by every graph a thread queries: a big graph's visit marks must
  // not leak into a small graph's query, nor the reverse.
  const auto big_xyz = randomCloud(2500, 90), small_xyz = randomCloud(30, 91);
  auto big = std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(big_xyz.data(), 2500)));
  auto small =
      std::make_shared<DelaunayGraph>(buildDelaunayGraph(PointView::fromDouble(small_xyz.data(), 30)));
  const NeighbourSearch sb(big), ss(small);
  const auto qb = mixedQueries(*big, big_xyz, 60, 1), qs = mixedQueries(*small, small_xyz, 60, 2);
  std::vector<Answer> eb, es;
  for (std::size_t i = 0; i < 60; ++i) eb.push_back(ask(sb, qb[i], i));
  for (std::size_t i = 0; i < 60; ++i) es.push_back(ask(ss, qs[i], i));
  for (int rep = 0; rep < 3; ++rep)
    for (std::size_t i = 0; i < 60; ++i) {
      ASSERT_EQ(ask(ss, qs[i], i), es[i]) << "small graph query " << i;
      ASSERT_EQ(ask(sb, qb[i], i), eb[i]) << "big graph query " << i;
    }
  EXPECT_EQ(checkAgainstBruteForce(big_xyz, big, qb), "");
  EXPECT_EQ(checkAgainstBruteForce(small_xyz, small, qs), "");
}
