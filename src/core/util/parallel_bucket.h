/// \file parallel_bucket.h
/// \brief Stable bucketing of n items on several threads (internal; the BRIO order's rounds and a
/// parallel pass's to-do lists).
///
/// Each worker counts the buckets of its own block of items, then places them: item k goes to rank r
/// of its bucket, r being its position among that bucket's items in index order. The ranks are thus
/// the same for every worker count, and each worker writes only where its own items go.
#pragma once

#include <algorithm>
#include <cstddef>
#include <type_traits>
#include <vector>

#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace detail {

/// bucket_of(k) < buckets for k in [0, n) (called twice per item); sized(sizes) once, with every
/// bucket's size, before place(k, bucket, rank) is called for every item. A sized() that returns bool
/// may return false to skip the placing (the caller has seen enough in the sizes).
template <class BucketOf, class Sized, class Place>
void parallelBucket(std::size_t n, unsigned workers, unsigned buckets, BucketOf&& bucket_of, Sized&& sized,
                    Place&& place) {
  std::vector<std::size_t> at(std::size_t(workers) * buckets, 0);  // block w, bucket b: at[w * buckets + b]
  // Each worker counts and places through its own copy of its row: with few buckets, the rows of
  // several workers share a cache line, and incrementing them there made the workers take that line
  // from each other at every item (two workers, two buckets: all four counters in one line).
  parallelFor(n, workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    std::vector<std::size_t> count(buckets, 0);
    for (std::size_t k = begin; k < end; ++k) ++count[bucket_of(k)];
    std::copy(count.begin(), count.end(), at.begin() + std::size_t(w) * buckets);
  });
  std::vector<std::size_t> sizes(buckets, 0);
  for (unsigned b = 0; b < buckets; ++b)
    for (unsigned w = 0; w < workers; ++w) {
      const std::size_t c = at[std::size_t(w) * buckets + b];
      at[std::size_t(w) * buckets + b] = sizes[b];  // the block's first rank in the bucket
      sizes[b] += c;
    }
  const std::vector<std::size_t>& all = sizes;
  if constexpr (std::is_same_v<decltype(sized(all)), bool>) {
    if (!sized(all)) return;
  } else {
    sized(all);
  }
  parallelFor(n, workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    std::vector<std::size_t> next(at.begin() + std::size_t(w) * buckets,
                                  at.begin() + std::size_t(w + 1) * buckets);
    for (std::size_t k = begin; k < end; ++k) {
      const unsigned b = bucket_of(k);
      place(k, b, next[b]++);
    }
  });
}

}  // namespace detail
}  // namespace dw
