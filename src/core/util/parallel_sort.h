/// \file parallel_sort.h
/// \brief Sorting a big vector on several threads (internal; the builders' Morton and BRIO orders),
/// by buckets of a key prefix first (the graph's Morton order), and sorting one that is nearly sorted
/// already (the 3D kernel's batches of ids).
///
/// Slices are sorted at once, then merged pairwise, the merges of one level at once. Simple, and
/// enough for the few threads that an O(n log n) sort ahead of an O(n) build needs: the order must
/// be a strict weak ordering whose ties are fully broken (ids), so that the result is one and the
/// same sequence for every thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "page_memory.h"
#include "parallel_bucket.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace detail {

/// Insertion sort of [first, last) with a budget of a few moves per element, so that input in no
/// particular order gives up early: true when sorted, false when the budget ran out (the range is
/// then still a permutation of what it was, and the caller sorts it some other way).
template <class It>
bool insertionSortWithBudget(It first, It last) {
  const std::size_t n = static_cast<std::size_t>(last - first);
  std::size_t budget = n / 4 + 64;
  for (std::size_t i = 1; i < n; ++i) {
    const auto x = first[i];
    std::size_t j = i;
    for (; j > 0 && x < first[j - 1]; --j) {
      if (budget-- == 0) {
        first[j] = x;  // still a permutation
        return false;
      }
      first[j] = first[j - 1];
    }
    first[j] = x;
  }
  return true;
}

/// Sorts v ascending, in linear time when it is nearly sorted (insertionSortWithBudget, then
/// std::sort when the budget runs out). The kernel's batches are BRIO rounds in Morton order over
/// ids that follow the same curve, out of place only where the two grids round differently:
/// std::sort took ~9 ms per 750k such ids, about 1 % of a 1M-point build on one thread, which sorts
/// its last batch twice.
template <class T, class A>
void sortAdaptive(std::vector<T, A>& v) {
  if (!insertionSortWithBudget(v.begin(), v.end())) std::sort(v.begin(), v.end());
}

template <class T, class A, class Less>
void parallelSort(std::vector<T, A>& v, Less less, unsigned num_threads) {
  const std::size_t n = v.size();
  const unsigned workers = workerCount(n, num_threads, std::size_t(1) << 16);
  parallelFor(workers, workers, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t c = b; c < e; ++c)
      std::sort(v.begin() + n * c / workers, v.begin() + n * (c + 1) / workers, less);
  });
  if (workers <= 1) return;
  std::vector<T, A> tmp(n);
  for (std::size_t width = 1; width < workers; width *= 2) {
    const std::size_t pairs = (workers + 2 * width - 1) / (2 * width);
    parallelFor(pairs, static_cast<unsigned>(pairs), [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t q = b; q < e; ++q) {
        const std::size_t c0 = 2 * width * q, c1 = std::min<std::size_t>(c0 + width, workers),
                          c2 = std::min<std::size_t>(c0 + 2 * width, workers);
        const std::size_t lo = n * c0 / workers, mid = n * c1 / workers, hi = n * c2 / workers;
        std::merge(v.begin() + lo, v.begin() + mid, v.begin() + mid, v.begin() + hi, tmp.begin() + lo, less);
      }
    });
    v.swap(tmp);
  }
  freeScratch(tmp);
}

/// Sorts v by `less` (a total order, as for parallelSort), given bucket_of(x) < buckets that never
/// decreases along `less`: a prefix of the sort key. The items are counted and moved into their
/// buckets (stably, on all workers), then each bucket is sorted alone, so the comparison sort works on
/// runs of a few dozen items. 1M Morton-keyed points by their keys' top 16 bits: 0.070 s by
/// parallelSort on one thread, whose comparisons were coin flips to the branch predictor. A bucket
/// holding over a quarter of the items (a cloud with a far outlier fills few cells) would sort on one
/// thread: then parallelSort sorts the whole.
template <class T, class A, class BucketOf, class Less>
void bucketThenSort(std::vector<T, A>& v, unsigned buckets, BucketOf bucket_of, Less less,
                    unsigned num_threads) {
  const std::size_t n = v.size();
  const unsigned workers = workerCount(n, num_threads, std::size_t(1) << 16);
  std::vector<std::size_t> begin(std::size_t(buckets) + 1, 0);
  std::vector<T, A> out;
  bool skewed = false;
  parallelBucket(
      n, workers, buckets, [&](std::size_t k) { return bucket_of(v[k]); },
      [&](const std::vector<std::size_t>& sizes) {
        for (unsigned b = 0; b < buckets; ++b) {
          begin[b + 1] = begin[b] + sizes[b];
          skewed |= 4 * sizes[b] > n;
        }
        if (!skewed) out.resize(n);
        return !skewed;
      },
      [&](std::size_t k, unsigned b, std::size_t rank) { out[begin[b] + rank] = v[k]; });
  if (skewed) return parallelSort(v, less, num_threads);
  v.swap(out);
  freeScratch(out);
  parallelFor(buckets, workers, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t c = b; c < e; ++c) std::sort(v.begin() + begin[c], v.begin() + begin[c + 1], less);
  });
}

}  // namespace detail
}  // namespace dw
