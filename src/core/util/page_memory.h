/// \file page_memory.h
/// \brief Mapping and unmapping the pages of big blocks from several threads (internal; the TIN's
/// arrays, the 3D kernel's tetrahedra and big scratch buffers).
///
/// Why: at tens of millions of points, taking a block's page faults (first touch) and giving its pages
/// back (free) are each a measurable single-threaded step when one call does it for the whole block:
/// on the 16-core device, the zero fill of the 24-byte/point output array took longer than the
/// parallel scan and sort it ran beside. Both are done here one slice per task, so the tasks can run
/// on all workers. They are hints: where the kernel or platform lacks them, nothing happens and the
/// later write (or free) does the work as before.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace dw {
namespace detail {

/// Number of slices for a block of `bytes`: about 2 MiB each, at most `tasks_max`. Small enough that
/// a block of a few tens of MiB is spread over every worker (in 32 MiB slices, the 50 MiB output array
/// of 2M points was mapped by two threads while fourteen waited).
inline std::size_t pageSlices(std::size_t bytes, std::size_t tasks_max) {
  const std::size_t want = bytes / (std::size_t(2) << 20) + 1;
  return want < tasks_max ? want : tasks_max;
}

namespace page_detail {
/// The whole pages inside slice k of `slices` of [p, p + bytes): [*begin, *begin + *len).
inline bool slicePages(void* p, std::size_t bytes, std::size_t k, std::size_t slices, char** begin,
                       std::size_t* len) {
#if defined(__linux__)
  const long ps = sysconf(_SC_PAGESIZE);
  if (ps <= 0 || !p || slices == 0) return false;
  const std::uintptr_t page = static_cast<std::uintptr_t>(ps);
  const std::uintptr_t lo = reinterpret_cast<std::uintptr_t>(p), hi = lo + bytes;
  const std::uintptr_t first = (lo + page - 1) / page * page, last = hi / page * page;
  if (last <= first) return false;
  const std::uintptr_t pages = (last - first) / page;
  const std::uintptr_t b = first + pages * k / slices * page, e = first + pages * (k + 1) / slices * page;
  if (e <= b) return false;
  *begin = reinterpret_cast<char*>(b);
  *len = static_cast<std::size_t>(e - b);
  return true;
#else
  (void)p, (void)bytes, (void)k, (void)slices, (void)begin, (void)len;
  return false;
#endif
}
}  // namespace page_detail

/// Maps (prefaults, writable) the whole pages of slice k of the block, without changing its contents.
inline void prefaultSlice(void* p, std::size_t bytes, std::size_t k, std::size_t slices) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  char* b = nullptr;
  std::size_t len = 0;
  if (page_detail::slicePages(p, bytes, k, slices, &b, &len)) madvise(b, len, MADV_POPULATE_WRITE);
#else
  (void)p, (void)bytes, (void)k, (void)slices;
#endif
}

/// Gives the whole pages of slice k of a block that is about to be freed back to the system; the block
/// stays valid (those pages read as zero) until it is freed.
inline void releaseSlice(void* p, std::size_t bytes, std::size_t k, std::size_t slices) {
#if defined(__linux__) && defined(MADV_DONTNEED)
  char* b = nullptr;
  std::size_t len = 0;
  if (page_detail::slicePages(p, bytes, k, slices, &b, &len)) madvise(b, len, MADV_DONTNEED);
#else
  (void)p, (void)bytes, (void)k, (void)slices;
#endif
}

/// Gives the whole pages of a vector's unused capacity (beyond its size) back to the system; growing
/// into them later maps them again.
template <class T, class A>
void releaseUnused(std::vector<T, A>& v) {
  releaseSlice(v.data() + v.size(), (v.capacity() - v.size()) * sizeof(T), 0, 1);
}

/// Frees a big scratch vector and makes sure its pages leave the process: glibc raises its mmap
/// threshold after freeing a big block, so later scratch of tens of MiB comes from the heap and stays
/// resident after free (measured: the 2-thread insertion order's two 16 MiB sort buffers stayed in
/// the 1M-point build's peak as 16 bytes per point).
template <class T, class A>
void freeScratch(std::vector<T, A>& v) {
  releaseSlice(v.data(), v.capacity() * sizeof(T), 0, 1);
  std::vector<T, A>().swap(v);
}

}  // namespace detail
}  // namespace dw
