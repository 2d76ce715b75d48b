// The GPU module's PCL-free types live in dw::gpu: every public header of the engine compiles next to
// PCL's pcl::gpu::DeviceArray (or its stand-in, where PCL's GPU module is not installed). A compile
// check first; the assertions need no device.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <type_traits>

#include "pcl_delaunay_walk/gpu/cuda_check.h"
#include "pcl_delaunay_walk/gpu/delaunay_walk.h"
#include "pcl_delaunay_walk/gpu/device_buffer.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"
#include "pcl_delaunay_walk/gpu/rigid_transform.h"
#include "pcl_gpu_device_array.h"  // before ours: PCL's class must not be redeclared by what follows

namespace {

TEST(GpuNames, DeviceBufferAndPclDeviceArrayShareOneTranslationUnit) {
  static_assert(!std::is_same<dw::gpu::DeviceBuffer<float>, pcl::gpu::DeviceArray<float>>::value,
                "two distinct classes");
  dw::gpu::DeviceBuffer<float> ours;  // no allocation until create(): runs without a device
  EXPECT_TRUE(ours.empty());
  EXPECT_EQ(ours.ptr(), nullptr);
  if (!DW_TEST_HAVE_PCL_GPU_CONTAINERS)
    std::printf("PCL's GPU containers not installed: checked against a stand-in\n");
}

TEST(GpuNames, CudaErrorIsTheProjectsError) {
  static_assert(std::is_base_of<dw::Error, dw::gpu::CudaError>::value, "callers catch dw::Error");
  try {
    dw::gpu::checkCuda(cudaErrorInvalidValue, "probe");
    FAIL() << "checkCuda returned on an error code";
  } catch (const dw::gpu::CudaError& e) {
    EXPECT_EQ(e.code(), cudaErrorInvalidValue);
    EXPECT_NE(std::string(e.what()).find("dw::gpu: probe"), std::string::npos) << e.what();
  }
}

}  // namespace
