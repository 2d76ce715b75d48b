// The PCL adapters (compiled only where PCL exists): cloud views, transforms, settings taken from a
// pcl::IterativeClosestPoint, and, where a GPU exists too, a registration through them.
#include <gtest/gtest.h>
#include <pcl/point_types.h>

#include <cmath>
#include <limits>
#include <type_traits>

#include "../pcl_gpu_device_array.h"  // PCL's pcl::gpu::DeviceArray (or a stand-in) beside our PCL face
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/gpu/pcl_adapters.h"

namespace {

TEST(GpuPclAdapters, CloudViewSeesEveryPointWithoutCopy) {
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (int i = 0; i < 5; ++i) {
    pcl::PointXYZI p;
    p.x = float(i);
    p.y = float(2 * i);
    p.z = -float(i);
    p.intensity = 100.f;
    cloud.push_back(p);
  }
  const dw::PointView v = pcl::gpu::toPointView(cloud);
  ASSERT_EQ(v.size, 5u);
  EXPECT_EQ(v.stride, sizeof(pcl::PointXYZI));
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(v[i][0], double(i));
    EXPECT_EQ(v[i][1], double(2 * i));
    EXPECT_EQ(v[i][2], -double(i));
  }
  EXPECT_EQ(pcl::gpu::toPointView(pcl::PointCloud<pcl::PointXYZ>{}).size, 0u);
}

TEST(GpuPclAdapters, TransformsRoundTripAndSettingsComeFromPcl) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m(0, 1) = 0.25f;
  m(2, 3) = -3.5f;
  const auto d = pcl::gpu::fromEigen(m);
  EXPECT_EQ(d[1], 0.25);
  EXPECT_EQ(d[11], -3.5);
  EXPECT_EQ(pcl::gpu::toEigen<float>(d), m);

  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setMaximumIterations(37);
  icp.setTransformationEpsilon(1e-9);
  icp.setEuclideanFitnessEpsilon(1e-6);
  icp.setMaxCorrespondenceDistance(0.25);
  const auto p = pcl::gpu::parametersFrom(icp);
  EXPECT_EQ(p.max_iterations, 37);
  EXPECT_EQ(p.transformation_epsilon, 1e-9);
  EXPECT_EQ(p.euclidean_fitness_epsilon, 1e-6);
  EXPECT_EQ(p.max_correspondence_distance, 0.25);
}

TEST(GpuPclAdapters, PclFaceNamesTheEngineAndSharesAUnitWithPclGpu) {
  static_assert(std::is_same<pcl::gpu::DelaunayWalk, dw::gpu::DelaunayWalk>::value, "one class, two names");
  static_assert(std::is_same<pcl::gpu::IterativeClosestPoint, dw::gpu::IterativeClosestPoint>::value,
                "one class, two names");
  static_assert(!std::is_same<pcl::gpu::DeviceArray<float>, dw::gpu::DeviceBuffer<float>>::value,
                "PCL's container and ours are distinct classes");
  EXPECT_TRUE(dw::gpu::DeviceBuffer<float>().empty());
}

TEST(GpuPclAdapters, AlignsAPclCloud) {
  if (dw::gpu::cudaDeviceCount() == 0)
    GTEST_SKIP() << "no CUDA device: the GPU part runs on a machine with one";
  pcl::PointCloud<pcl::PointXYZ> target, source;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) {
      const float x = 0.05f * i, y = 0.05f * j, z = 0.1f * std::sin(3.f * x) * std::cos(2.f * y);
      target.push_back(pcl::PointXYZ(x, y, z));
      source.push_back(pcl::PointXYZ(x + 0.01f, y - 0.005f, z));
    }
  const auto graph = dw::buildDelaunayGraph(pcl::gpu::toPointView(target));
  auto walk = std::make_shared<dw::gpu::DelaunayWalk>(graph);
  dw::gpu::IterativeClosestPoint icp(walk);
  dw::gpu::IcpParameters p;
  p.max_iterations = 50;
  p.max_correspondence_distance = 0.1;
  icp.setParameters(p);
  Eigen::Matrix4f out;
  const auto r = pcl::gpu::align(icp, source, Eigen::Matrix4f::Identity().eval(), out);
  EXPECT_GT(r.iterations, 0);
  EXPECT_NEAR(out(0, 3), -0.01f, 2e-3f);
  EXPECT_NEAR(out(1, 3), 0.005f, 2e-3f);
}

}  // namespace
