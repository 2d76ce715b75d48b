/// \file test_parallel_for.cpp
/// \brief dw::parallelFor (static blocks) and dw::parallelForDynamic (shared counter), the core's two
/// loops used by the TIN, the 3D builder and the registration: every index exactly once, the documented
/// block layout (which the registration's thread-count-independent results rely on), exceptions
/// rethrown only after every worker has finished. dw::ThreadTeam: every task once per pass, passes
/// reusable, and the loops in its scope run on its threads with the same blocks, nested loops and
/// loops wider than the team included.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace {

TEST(ParallelFor, WorkerCountHonoursRequestAndBlockSize) {
  EXPECT_GE(dw::resolveThreads(0), 1u);
  EXPECT_EQ(dw::resolveThreads(7), 7u);
  EXPECT_EQ(dw::workerCount(100000, 4), 4u);
  EXPECT_EQ(dw::workerCount(10000, 8), 2u);  // one worker per 4096 items at most
  EXPECT_EQ(dw::workerCount(10, 8), 1u);
  EXPECT_EQ(dw::workerCount(0, 8), 1u);
  EXPECT_EQ(dw::workerCount(100, 8, 10), 8u);
}

TEST(ParallelFor, StaticBlocksCoverTheRangeOnceInTheDocumentedLayout) {
  for (std::size_t n : {0u, 1u, 2u, 7u, 1000u, 1001u})
    for (unsigned workers = 1; workers <= 6; ++workers) {
      std::vector<std::atomic<int>> hits(n);
      std::vector<std::size_t> begin(workers, ~std::size_t{0}), end(workers, ~std::size_t{0});
      dw::parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned w) {
        begin[w] = b;
        end[w] = e;
        for (std::size_t i = b; i < e; ++i) ++hits[i];
      });
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(hits[i].load(), 1) << n << " " << workers;
      if (workers == 1 || n < 2) {
        EXPECT_EQ(begin[0], 0u);
        EXPECT_EQ(end[0], n);
        continue;
      }
      const std::size_t chunk = (n + workers - 1) / workers;
      for (unsigned w = 0; w < workers; ++w) {
        EXPECT_EQ(begin[w], std::min(n, w * chunk)) << n << " " << workers << " " << w;
        EXPECT_EQ(end[w], std::min(n, begin[w] + chunk)) << n << " " << workers << " " << w;
      }
    }
}

TEST(ParallelFor, StaticRethrowsAfterAllWorkersFinished) {
  std::atomic<int> finished{0};
  EXPECT_THROW(dw::parallelFor(4000, 4,
                               [&](std::size_t b, std::size_t, unsigned w) {
                                 if (w == 2) throw std::runtime_error("block " + std::to_string(b));
                                 ++finished;
                               }),
               std::runtime_error);
  EXPECT_EQ(finished.load(), 3);
}

TEST(ParallelFor, DynamicRunsEveryIndexOnce) {
  for (std::size_t count : {0u, 1u, 3u, 100u, 5000u})
    for (unsigned threads : {0u, 1u, 2u, 3u, 8u}) {
      std::vector<std::atomic<int>> hits(count);
      dw::parallelForDynamic(count, threads, [&](std::size_t i) { ++hits[i]; });
      for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(hits[i].load(), 1) << count << " " << threads;
    }
}

TEST(ParallelFor, DynamicRethrowsTheFirstErrorAndStillRunsTheRest) {
  for (unsigned threads : {1u, 4u}) {
    std::atomic<int> ran{0};
    try {
      dw::parallelForDynamic(50, threads, [&](std::size_t i) {
        ++ran;
        if (i == 10) throw std::invalid_argument("task 10");
      });
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), "task 10");
    }
    EXPECT_EQ(ran.load(), 50) << threads;
  }
}

TEST(ThreadTeam, ThreadsRunEveryTaskOncePerPass) {
  for (unsigned threads : {1u, 2u, 5u}) {
    dw::ThreadTeam team(threads);
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

TEST(ThreadTeam, ThreadsRethrowAfterEveryTaskRan) {
  dw::ThreadTeam team(4);
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

// The threads a loop ran on, and its blocks.
struct LoopRecord {
  std::mutex mutex;
  std::set<std::thread::id> threads;
  std::vector<std::pair<std::size_t, std::size_t>> blocks;
  void add(std::size_t b, std::size_t e, unsigned w) {
    std::lock_guard<std::mutex> lock(mutex);
    threads.insert(std::this_thread::get_id());
    if (blocks.size() <= w) blocks.resize(w + 1);
    blocks[w] = {b, e};
  }
};

TEST(ThreadTeam, LoopsInItsScopeRunOnItsThreadsWithTheSameBlocks) {
  dw::ThreadTeam team(4);
  ASSERT_EQ(team.size(), 4u) << "could not start the team's threads";
  std::set<std::thread::id> team_threads;
  std::mutex mutex;
  team.everyWorker([&](unsigned) {
    std::lock_guard<std::mutex> lock(mutex);
    team_threads.insert(std::this_thread::get_id());
  });
  ASSERT_EQ(team_threads.size(), 4u);

  LoopRecord outside;
  dw::parallelFor(1001, 3, [&](std::size_t b, std::size_t e, unsigned w) { outside.add(b, e, w); });
  std::set<std::thread::id> seen;
  {
    dw::ThreadTeam::Scope scope(team);
    EXPECT_EQ(dw::detail::loopRunnerOfThisThread(), &team);
    for (int pass = 0; pass < 3; ++pass) {
      LoopRecord inside;
      std::vector<std::atomic<int>> hits(1001);
      dw::parallelFor(1001, 3, [&](std::size_t b, std::size_t e, unsigned w) {
        inside.add(b, e, w);
        for (std::size_t i = b; i < e; ++i) ++hits[i];
      });
      for (auto& h : hits) ASSERT_EQ(h.load(), 1);
      EXPECT_EQ(inside.blocks, outside.blocks);
      seen.insert(inside.threads.begin(), inside.threads.end());
      std::vector<std::atomic<int>> dynamic_hits(500);
      LoopRecord dynamic;
      dw::parallelForDynamic(500, 4, [&](std::size_t i) {
        ++dynamic_hits[i];
        dynamic.add(0, 0, 0);
      });
      for (auto& h : dynamic_hits) ASSERT_EQ(h.load(), 1);
      seen.insert(dynamic.threads.begin(), dynamic.threads.end());
    }
  }
  EXPECT_EQ(dw::detail::loopRunnerOfThisThread(), nullptr);
  // No loop in the scope started a thread of its own.
  for (const auto& id : seen) EXPECT_EQ(team_threads.count(id), 1u);
}

TEST(ThreadTeam, NestedWiderAndFailingLoopsInItsScope) {
  dw::ThreadTeam team(3);
  dw::ThreadTeam::Scope scope(team);
  // A loop inside a loop's body (on the caller, which owns the team, and on its helpers) and a loop
  // wider than the team start threads as before: every index still runs once.
  std::vector<std::atomic<int>> hits(4 * 300);
  dw::parallelFor(4, 3, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t k = b; k < e; ++k)
      dw::parallelFor(300, 2, [&](std::size_t ib, std::size_t ie, unsigned) {
        for (std::size_t i = ib; i < ie; ++i) ++hits[300 * k + i];
      });
  });
  for (auto& h : hits) ASSERT_EQ(h.load(), 1);
  std::vector<std::atomic<int>> wide(1000);
  dw::parallelFor(1000, 8, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t i = b; i < e; ++i) ++wide[i];
  });
  for (auto& h : wide) ASSERT_EQ(h.load(), 1);
  // A failing block: rethrown after the others finished, and the team still runs the next loop.
  std::atomic<int> finished{0};
  EXPECT_THROW(dw::parallelFor(3000, 3,
                               [&](std::size_t, std::size_t, unsigned w) {
                                 if (w == 1) throw std::runtime_error("block failed");
                                 ++finished;
                               }),
               std::runtime_error);
  EXPECT_EQ(finished.load(), 2);
  std::atomic<int> after{0};
  dw::parallelForDynamic(50, 3, [&](std::size_t) { ++after; });
  EXPECT_EQ(after.load(), 50);
}

}  // namespace
