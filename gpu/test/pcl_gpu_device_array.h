// PCL's own pcl::gpu::DeviceArray where PCL's GPU module is installed, else a stand-in of that name,
// so the tests that include it prove that the GPU module's headers and PCL's GPU containers can share
// one translation unit: any pcl::gpu::DeviceArray of ours would be a redefinition error here.
#pragma once

#if __has_include(<pcl/gpu/containers/device_array.h>)
#include <pcl/gpu/containers/device_array.h>
#define DW_TEST_HAVE_PCL_GPU_CONTAINERS 1
#else
#define DW_TEST_HAVE_PCL_GPU_CONTAINERS 0
namespace pcl {
namespace gpu {
/// Stand-in with the name and template shape of PCL's class (pcl/gpu/containers/device_array.h).
template <class T>
class DeviceArray {
 public:
  T* ptr() { return nullptr; }
};
}  // namespace gpu
}  // namespace pcl
#endif
