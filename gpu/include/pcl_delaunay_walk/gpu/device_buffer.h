/// \file device_buffer.h
/// \brief dw::gpu::DeviceBuffer: owning device buffer in the manner of pcl_gpu's DeviceArray (a class of
/// its own, so both can be included together): plain cudaMalloc (never managed memory), move-only,
/// grows only when asked for more than it holds, so steady-state batch calls allocate nothing.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <utility>
#include <vector>

#include "pcl_delaunay_walk/gpu/cuda_check.h"

namespace dw {
namespace gpu {

template <typename T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t n) { create(n); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept { swap(o); }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      release();
      swap(o);
    }
    return *this;
  }
  void swap(DeviceBuffer& o) noexcept {
    std::swap(ptr_, o.ptr_);
    std::swap(size_, o.size_);
    std::swap(capacity_, o.capacity_);
  }

  /// Makes the array hold n elements (contents undefined); reallocates only when n exceeds the capacity.
  void create(std::size_t n) {
    if (n > capacity_) {
      release();
      void* p = nullptr;
      checkCuda(cudaMalloc(&p, n * sizeof(T)), "cudaMalloc");
      ptr_ = static_cast<T*>(p);
      capacity_ = n;
    }
    size_ = n;
  }
  void release() noexcept {
    if (ptr_) cudaFree(ptr_);  // no throw from a destructor path; a failing free leaves nothing to fix
    ptr_ = nullptr;
    size_ = capacity_ = 0;
  }

  /// Copies n host elements in (synchronous unless a stream is given and `host` is pinned).
  void upload(const T* host, std::size_t n, cudaStream_t stream = nullptr) {
    create(n);
    if (n) checkCuda(cudaMemcpyAsync(ptr_, host, n * sizeof(T), cudaMemcpyHostToDevice, stream), "upload");
    if (!stream) checkCuda(cudaStreamSynchronize(nullptr), "upload");
  }
  void upload(const std::vector<T>& host, cudaStream_t stream = nullptr) {
    upload(host.data(), host.size(), stream);
  }

  /// Copies the first n elements out (waits for `stream`).
  void download(T* host, std::size_t n, cudaStream_t stream = nullptr) const {
    if (n > size_)
      throw dw::Error("dw::gpu::DeviceBuffer::download: asked for more elements than the buffer holds");
    if (n) checkCuda(cudaMemcpyAsync(host, ptr_, n * sizeof(T), cudaMemcpyDeviceToHost, stream), "download");
    checkCuda(cudaStreamSynchronize(stream), "download");
  }
  void download(std::vector<T>& host, cudaStream_t stream = nullptr) const {
    host.resize(size_);
    download(host.data(), size_, stream);
  }

  T* ptr() { return ptr_; }
  const T* ptr() const { return ptr_; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

 private:
  T* ptr_ = nullptr;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

}  // namespace gpu
}  // namespace dw
