/// \file pinned_buffer.h
/// \brief dw::gpu::PinnedBuffer: owning page-locked host buffer (cudaHostAlloc), the staging area of
/// host-to-device copies that must be asynchronous on a stream (a copy from pageable memory is staged
/// by the driver and returns only when done). Move-only; grows only when asked for more than it holds.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <utility>

#include "pcl_delaunay_walk/gpu/cuda_check.h"

namespace dw {
namespace gpu {

template <typename T>
class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  ~PinnedBuffer() { release(); }
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  PinnedBuffer(PinnedBuffer&& o) noexcept { swap(o); }
  PinnedBuffer& operator=(PinnedBuffer&& o) noexcept {
    if (this != &o) {
      release();
      swap(o);
    }
    return *this;
  }
  void swap(PinnedBuffer& o) noexcept {
    std::swap(ptr_, o.ptr_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
  }

  /// Makes the buffer hold n elements (contents undefined after a growth). The caller must know that
  /// no copy still reads the old contents: a growth frees them.
  void create(std::size_t n) {
    if (n > capacity_) {
      release();
      void* p = nullptr;
      checkCuda(cudaHostAlloc(&p, n * sizeof(T), cudaHostAllocDefault), "cudaHostAlloc");
      ptr_ = static_cast<T*>(p);
      capacity_ = n;
    }
    size_ = n;
  }
  void release() noexcept {
    if (ptr_) cudaFreeHost(ptr_);
    ptr_ = nullptr;
    size_ = capacity_ = 0;
  }

  T* data() { return ptr_; }
  const T* data() const { return ptr_; }
  T& operator[](std::size_t i) { return ptr_[i]; }
  std::size_t size() const { return size_; }

 private:
  T* ptr_ = nullptr;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

}  // namespace gpu
}  // namespace dw
