/// \file cuda_check.h
/// \brief CUDA errors as exceptions: every runtime call of the GPU module goes through checkCuda, so a
/// failure surfaces as dw::gpu::CudaError (a dw::Error) naming the call, never as a silent bad result.
#pragma once

#include <cuda_runtime_api.h>

#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace gpu {

/// A failed CUDA runtime call or kernel launch; what() names the operation and CUDA's message.
class CudaError : public dw::Error {
 public:
  CudaError(cudaError_t code, const std::string& what)
      : dw::Error("dw::gpu: " + what + ": " + cudaGetErrorName(code) + " (" + cudaGetErrorString(code) + ")"),
        code_(code) {}
  cudaError_t code() const { return code_; }

 private:
  cudaError_t code_;
};

/// Throws CudaError when `code` is not cudaSuccess.
inline void checkCuda(cudaError_t code, const char* what) {
  if (code != cudaSuccess) throw CudaError(code, what);
}

/// Number of CUDA devices usable by this process (0 when there is no driver or no device).
inline int cudaDeviceCount() {
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    (void)cudaGetLastError();  // clear the sticky "no device" error for later callers
    return 0;
  }
  return n;
}

}  // namespace gpu
}  // namespace dw
