/// \file reference_nearest.h
/// \brief The batch of nearest-neighbour queries as a C++ user of the core writes it, so that the
/// binding's nearest() can be timed against it: dw_py_reference runs it in its own process,
/// _native._cpp_nearest_seconds in the binding's (the same graph and the same queries in memory,
/// which makes the two times comparable on one machine).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <ctime>
#include <vector>

#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw_py {

/// Fastest of `repeats` batches, by wall clock and by process CPU time.
struct ReferenceTiming {
  double seconds = 1e300;
  double cpu_seconds = 1e300;
  unsigned long long index_sum = 0;  ///< sum of the answers' input indices, to compare answers
};

inline double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Times `repeats` batches of the exact nearest neighbour (KD-ANN start) of the float xyz triples
/// `qs` (n of them) on `threads` workers (0: all), answers as input indices and squared distances.
inline ReferenceTiming timeNearestBatch(const dw::NeighbourSearch& search, const float* qs, std::size_t n,
                                        unsigned threads, int repeats) {
  const dw::DelaunayGraph& graph = search.graph();
  std::vector<dw::index_t> out(n);
  std::vector<float> d2(n);
  ReferenceTiming t;
  for (int r = 0; r < repeats; ++r) {
    const double c0 = processCpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    // flatten: in a program of its own GCC inlines the walk into this loop; in the module, where the
    // walk is called from many loops, it would keep it out of line unless told.
    auto block = [&](std::size_t b, std::size_t e, unsigned) __attribute__((flatten)) {
      for (std::size_t i = b; i < e; ++i) {
        const dw::WalkResult w = search.nearest(graph.toLocal(qs[3 * i], qs[3 * i + 1], qs[3 * i + 2]));
        out[i] = graph.representative(w.vertex);
        d2[i] = w.dist2;
      }
    };
    dw::parallelFor(n, dw::workerCount(n, threads, 1024), block);
    const auto wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t.seconds = std::min(t.seconds, wall);
    t.cpu_seconds = std::min(t.cpu_seconds, processCpuSeconds() - c0);
  }
  for (dw::index_t i : out) t.index_sum += i;
  return t;
}

}  // namespace dw_py
