/// \file search_scratch.h
/// \brief Per-thread working memory of kNN/radius expansion, so steady-state queries allocate nothing.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

/// Visited marks are epoch stamps: a new query bumps the epoch instead of clearing n flags, and marks
/// left by any earlier query (on any graph) read as unvisited. One scratch serves every graph.
struct SearchScratch {
  std::vector<std::uint32_t> stamp;
  std::uint32_t epoch = 0;
  std::vector<std::pair<double, index_t>>
      heap;  ///< min-heap of (dist2, vertex); double orders far queries exactly

  /// Starts a query over a graph of n vertices.
  void begin(std::size_t n) {
    if (stamp.size() < n) stamp.resize(n, 0);
    if (++epoch == 0) {  // wrapped: old stamps could collide with new epochs
      std::fill(stamp.begin(), stamp.end(), 0);
      epoch = 1;
    }
    heap.clear();
  }
  bool visit(index_t v) {
    if (stamp[v] == epoch) return false;
    stamp[v] = epoch;
    return true;
  }

  /// The calling thread's scratch.
  static SearchScratch& threadLocal() {
    thread_local SearchScratch s;
    return s;
  }
};

}  // namespace dw
