/// \file test_reduce_schedule.cpp
/// \brief The greedy merge scheduler (only adjacent complete groups are ever merged, and
/// in any completion order, sequential or concurrent, the strips end as one group); the triangles of
/// the greedy reduce equal the sequential kernel's for many strips on many threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/tin/merge_scheduler.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "tin_test_util.h"

namespace {

using dw::tin::detail::MergeScheduler;

TEST(MergeScheduler, ConcurrentWorkersEndInOneGroup) {
  for (int trial = 0; trial < 20; ++trial) {
    const std::size_t strips = 37;
    MergeScheduler sched(strips);
    std::vector<std::size_t> end_of(strips, 0);
    std::atomic<std::size_t> merges{0};
    dw::ThreadTeam team(4);
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
