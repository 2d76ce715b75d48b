/// \file search_scratch.h
/// \brief Per-thread working memory of kNN/radius expansion, so steady-state queries allocate nothing.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/uninitialised_allocator.h"

namespace dw {

/// One vertex the expansion has measured: its squared distance (double orders far queries exactly),
/// the number of inputs collapsed onto it, and whether its neighbours have been measured.
struct SearchCandidate {
  double d2;
  index_t v;
  index_t count;  ///< inputs on v; the top bit marks an expanded vertex
  static constexpr index_t kExpanded = index_t(1) << 31;
  index_t inputs() const { return count & ~kExpanded; }
  bool expanded() const { return (count & kExpanded) != 0; }
};

/// Visited marks are epoch stamps: a new query bumps the epoch instead of clearing n flags, and marks
/// left by any earlier query (on any graph) read as unvisited. One scratch serves every graph.
struct SearchScratch {
  std::vector<std::uint32_t> stamp;
  std::uint32_t epoch = 0;
  /// kNN: the bounded list of the best vertices so far, ascending (d2, v); radius: every vertex found
  /// inside, in the order found. Resizing it leaves the entries unwritten: the kNN list sizes it to
  /// its bound once per query and writes entries through a pointer.
  std::vector<SearchCandidate, UninitialisedAllocator<SearchCandidate>> list;

  /// Starts a query over a graph of n vertices.
  void begin(std::size_t n) {
    if (stamp.size() < n) stamp.resize(n, 0);
    if (++epoch == 0) {  // wrapped: old stamps could collide with new epochs
      std::fill(stamp.begin(), stamp.end(), 0);
      epoch = 1;
    }
    list.clear();
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
