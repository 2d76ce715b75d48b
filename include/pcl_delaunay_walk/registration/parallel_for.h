/// \file parallel_for.h
/// \brief A static-partition parallel loop on std::thread: each worker gets one contiguous block, so
/// the work done per index, and therefore every result, is the same for any number of threads.
#pragma once

#include <algorithm>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace pcl {
namespace registration {
namespace detail {

/// Number of workers for n items: `requested` (0 = hardware threads), but no more than one per
/// `min_block` items, since starting a thread costs about as much as a few thousand walks.
inline unsigned workerCount(std::size_t n, unsigned requested, std::size_t min_block = 4096) {
  unsigned t = requested ? requested : std::max(1u, std::thread::hardware_concurrency());
  const std::size_t by_size = std::max<std::size_t>(1, n / std::max<std::size_t>(1, min_block));
  return static_cast<unsigned>(std::min<std::size_t>(t, by_size));
}

/// Calls body(begin, end, worker) for `workers` contiguous blocks of [0, n); rethrows the first
/// exception of any worker after all have finished.
template <typename Body>
void parallelFor(std::size_t n, unsigned workers, Body body) {
  if (workers <= 1 || n < 2) {
    body(std::size_t(0), n, 0u);
    return;
  }
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(workers);
  const std::size_t chunk = (n + workers - 1) / workers;
  for (unsigned w = 1; w < workers; ++w) {
    const std::size_t b = std::min(n, w * chunk), e = std::min(n, b + chunk);
    pool.emplace_back([&, b, e, w] {
      try {
        body(b, e, w);
      } catch (...) {
        errors[w] = std::current_exception();
      }
    });
  }
  try {
    body(std::size_t(0), std::min(n, chunk), 0u);
  } catch (...) {
    errors[0] = std::current_exception();
  }
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace detail
}  // namespace registration
}  // namespace pcl
