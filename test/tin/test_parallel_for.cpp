/// \file test_parallel_for.cpp
/// \brief dw::parallelFor (static blocks) and dw::parallelForDynamic (shared counter), the core's two
/// loops used by the TIN and the registration: every index exactly once, the documented block layout
/// (which the registration's thread-count-independent results rely on), exceptions rethrown only
/// after every worker has finished.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "pcl_delaunay_walk/core/parallel_for.h"

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

}  // namespace
