/// \file query_order.h
/// \brief The order in which a batch of walks is best run: grouped by start vertex.
#pragma once

#include <cstddef>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

/// A permutation of the batch positions 0..n-1, grouped by start vertex in the graph's (Morton) order,
/// stable within a group. Queries with no valid start (>= num_vertices) come first.
///
/// Why: ICP sends its queries in source order, while the graph is stored along a space-filling curve,
/// so each walk's first reads (the start vertex and its edges) are cache misses: measured on the
/// dragon 100k, walking a PNN batch in this order cut the time per query by ~15% on top of prefetching.
/// Each query's answer is independent of the order, so results (stored by position) do not change.
/// A counting sort on start / 64 (vertices sharing cache lines of the graph arrays) costs O(n + V/64).
inline std::vector<index_t> orderByStartVertex(const index_t* start, std::size_t n,
                                               std::size_t num_vertices) {
  constexpr std::size_t kGroup = 64;
  const std::size_t buckets = num_vertices / kGroup + 2;  // bucket 0: no valid start
  std::vector<std::size_t> first(buckets + 1, 0);
  auto bucket = [&](std::size_t i) { return start[i] < num_vertices ? start[i] / kGroup + 1 : 0; };
  for (std::size_t i = 0; i < n; ++i) ++first[bucket(i) + 1];
  for (std::size_t b = 1; b <= buckets; ++b) first[b] += first[b - 1];
  std::vector<index_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[first[bucket(i)]++] = static_cast<index_t>(i);
  return order;
}

}  // namespace dw
