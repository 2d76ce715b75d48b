/// \file test_reduce_schedule.cpp
/// \brief The TIN's own thread team (every task once per pass, passes reusable, exceptions rethrown after
/// every task ran) and the greedy merge scheduler (only adjacent complete groups are ever merged, and
/// in any completion order, sequential or concurrent, the strips end as one group); the triangles of
/// the greedy reduce equal the sequential kernel's for many strips on many threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "../../src/core/tin/merge_scheduler.h"
#include "../../src/core/tin/worker_team.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "tin_test_util.h"

namespace {

using dw::tin::detail::MergeScheduler;
using dw::tin::detail::WorkerTeam;

TEST(WorkerTeam, ThreadsRunEveryTaskOncePerPass) {
  for (unsigned threads : {1u, 2u, 5u}) {
    WorkerTeam team(threads);
    EXPECT_GE(team.size(), 1u);
    EXPECT_LE(team.size(), threads);
    for (std::size_t count : {0u, 1u, 3u, 64u, 1000u}) {
      std::vector<std::atomic<int>> hits(count);
      team.forEach(count, [&](std::size_t i) { ++hits[i]; });
      for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(hits[i].load(), 1) << threads << " " << count;
    }
    std::vector<std::atomic<int>> per_worker(team.size());
    team.everyWorker([&](unsigned w) { ++per_worker[w]; });
    for (auto& c : per_worker) EXPECT_EQ(c.load(), 1);
  }
}

TEST(WorkerTeam, ThreadsRethrowAfterEveryTaskRan) {
  WorkerTeam team(4);
  std::atomic<int> ran{0};
  EXPECT_THROW(team.forEach(100,
                            [&](std::size_t i) {
                              ++ran;
                              if (i % 7 == 3) throw std::runtime_error("task failed");
                            }),
               std::runtime_error);
  EXPECT_EQ(ran.load(), 100);
  // The team is still usable after a failed pass.
  std::atomic<int> again{0};
  team.forEach(10, [&](std::size_t) { ++again; });
  EXPECT_EQ(again.load(), 10);
  EXPECT_THROW(team.everyWorker([](unsigned w) {
    if (w == 0) throw std::logic_error("caller failed");
  }),
               std::logic_error);
}

/// Completes strips in a random order; claimed merges are held back and performed in a random order
/// too (as concurrent workers would), each checked to join two adjacent complete groups.
TEST(MergeScheduler, AnyCompletionOrderEndsInOneGroup) {
  std::mt19937 rng(7);
  for (std::size_t strips : {1u, 2u, 3u, 8u, 33u}) {
    for (int trial = 0; trial < 50; ++trial) {
      MergeScheduler sched(strips);
      std::vector<std::size_t> order(strips);
      std::iota(order.begin(), order.end(), 0);
      std::shuffle(order.begin(), order.end(), rng);
      std::vector<std::size_t> end_of(strips, 0);  // complete groups known to the test: begin -> end
      std::vector<MergeScheduler::Claim> pending;
      std::size_t merges = 0;
      auto take = [&](const MergeScheduler::Claim& c) {
        if (!c.valid) return;
        ASSERT_LT(c.left, c.right);
        ASSERT_EQ(end_of[c.left], c.right) << "left group must end where the right one begins";
        ASSERT_NE(end_of[c.right], 0u) << "right group must be complete";
        pending.push_back(c);
      };
      std::size_t next = 0;
      while (next < strips || !pending.empty()) {
        if (next < strips && (pending.empty() || rng() % 2)) {
          const std::size_t s = order[next++];
          end_of[s] = s + 1;
          take(sched.complete(s, s + 1));
        } else {
          const std::size_t k = rng() % pending.size();
          const MergeScheduler::Claim c = pending[k];
          pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(k));
          const std::size_t e = end_of[c.right];
          end_of[c.right] = 0;
          end_of[c.left] = e;
          ++merges;
          take(sched.complete(c.left, e));
        }
      }
      EXPECT_EQ(sched.endOf(0), strips);
      EXPECT_EQ(end_of[0], strips);
      EXPECT_EQ(merges, strips - 1);
    }
  }
}

TEST(MergeScheduler, ConcurrentWorkersEndInOneGroup) {
  for (int trial = 0; trial < 20; ++trial) {
    const std::size_t strips = 37;
    MergeScheduler sched(strips);
    std::vector<std::size_t> end_of(strips, 0);
    std::atomic<std::size_t> merges{0};
    WorkerTeam team(4);
    team.forEach(strips, [&](std::size_t s) {
      end_of[s] = s + 1;
      for (MergeScheduler::Claim c = sched.complete(s, s + 1); c.valid;) {
        if (end_of[c.left] != c.right || end_of[c.right] == 0) throw std::logic_error("bad claim");
        const std::size_t e = end_of[c.right];
        end_of[c.right] = 0;
        end_of[c.left] = e;
        ++merges;
        c = sched.complete(c.left, e);
      }
    });
    EXPECT_EQ(sched.endOf(0), strips);
    EXPECT_EQ(merges.load(), strips - 1);
  }
}

TEST(GreedyReduce, ManyStripsOnManyThreadsGiveTheSequentialTriangles) {
  // A LAS-like lattice with duplicates and cocircular squares: the hardest case for tie-breaking.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> cell(0, 399);
  std::vector<double> x, y;
  for (int i = 0; i < 40000; ++i) {
    x.push_back(cell(rng));
    y.push_back(cell(rng) * 0.5);
  }
  dw::tin::TinOptions seq;
  seq.num_threads = 1;
  seq.num_strips = 1;
  const dw::tin::TinResult ref = dw::tin::triangulate(x.data(), y.data(), x.size(), seq);
  const auto want = dw_test::canonical(ref.triangles);
  for (unsigned threads : {3u, 8u})
    for (unsigned strips : {0u, 29u, 64u}) {
      dw::tin::TinOptions o;
      o.num_threads = threads;
      o.num_strips = strips;
      const dw::tin::TinResult r = dw::tin::triangulate(x.data(), y.data(), x.size(), o);
      ASSERT_EQ(dw_test::canonical(r.triangles), want) << threads << " threads, " << strips << " strips";
      EXPECT_EQ(r.duplicates, ref.duplicates);
      EXPECT_EQ(r.num_vertices, ref.num_vertices);
    }
}

}  // namespace
