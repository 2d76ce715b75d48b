/// \file test_delaunay_tin_pcl.cpp
/// \brief pcl::DelaunayTin: PolygonMesh and compact output agree, are certified Delaunay in (x, y),
/// keep z, honour indices, and do not depend on threads or strips.
#include <gtest/gtest.h>
#include <pcl/conversions.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "core/tin/tin_test_util.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/surface/delaunay_tin.h"

namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr terrainCloud(std::size_t n, unsigned seed) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 200.0f);
  for (std::size_t i = 0; i < n; ++i) {
    const float x = u(rng), y = u(rng);
    c->push_back(pcl::PointXYZ(x, y, 0.05f * x + std::sin(y * 0.1f)));
  }
  return c;
}

bool certified(const pcl::PointCloud<pcl::PointXYZ>& c, const std::vector<std::uint32_t>& tris,
               std::size_t verts) {
  std::vector<double> x, y;
  for (const auto& p : c) {
    x.push_back(p.x);
    y.push_back(p.y);
  }
  return dw::tin::certifyDelaunay(x.data(), y.data(), c.size(), tris, verts).ok;
}

TEST(DelaunayTinPcl, PolygonMeshMatchesCompactTrianglesAndIsDelaunay) {
  const auto cloud = terrainCloud(5000, 1);
  pcl::DelaunayTin<pcl::PointXYZ> tin;
  tin.setInputCloud(cloud);
  tin.setNumberOfThreads(2);
  tin.setNumberOfStrips(3);
  pcl::PolygonMesh mesh;
  tin.reconstruct(mesh);
  EXPECT_EQ(mesh.cloud.width * mesh.cloud.height, cloud->size());
  pcl::PointCloud<pcl::PointXYZ> back;
  pcl::fromPCLPointCloud2(mesh.cloud, back);
  EXPECT_EQ(back[17].z, (*cloud)[17].z);  // z is carried unchanged

  std::vector<std::uint32_t> tris;
  ASSERT_TRUE(tin.reconstructTriangles(tris));
  ASSERT_EQ(mesh.polygons.size() * 3, tris.size());
  std::vector<std::uint32_t> from_mesh;
  for (const auto& poly : mesh.polygons) {
    ASSERT_EQ(poly.vertices.size(), 3u);
    for (auto v : poly.vertices) from_mesh.push_back(std::uint32_t(v));
  }
  // With several threads the triangles' order may differ between runs (docs/tin.md); the set may not.
  EXPECT_EQ(dw_test::canonical(from_mesh), dw_test::canonical(tris));
  EXPECT_TRUE(certified(*cloud, tris, cloud->size()));
}

TEST(DelaunayTinPcl, ThreadsAndStripsDoNotChangeTheMesh) {
  const auto cloud = terrainCloud(4000, 2);
  std::vector<std::uint32_t> ref;
  pcl::DelaunayTin<pcl::PointXYZ> tin;
  tin.setInputCloud(cloud);
  tin.setNumberOfStrips(1);
  tin.setNumberOfThreads(1);
  ASSERT_TRUE(tin.reconstructTriangles(ref));
  for (unsigned s : {2u, 4u, 7u}) {
    tin.setNumberOfStrips(s);
    tin.setNumberOfThreads(2);
    std::vector<std::uint32_t> t;
    ASSERT_TRUE(tin.reconstructTriangles(t));
    EXPECT_EQ(dw_test::canonical(t), dw_test::canonical(ref)) << s << " strips";
  }
}

TEST(DelaunayTinPcl, IndicesSelectASubsetAndMapBack) {
  const auto cloud = terrainCloud(3000, 3);
  pcl::IndicesPtr idx(new pcl::Indices);
  for (int i = 0; i < 3000; i += 2) idx->push_back(i);  // even points only
  pcl::DelaunayTin<pcl::PointXYZ> tin;
  tin.setInputCloud(cloud);
  tin.setIndices(idx);
  std::vector<pcl::Vertices> polys;
  tin.reconstruct(polys);
  ASSERT_FALSE(polys.empty());
  std::vector<std::uint32_t> tris;
  for (const auto& p : polys)
    for (auto v : p.vertices) {
      EXPECT_EQ(v % 2, 0);
      tris.push_back(std::uint32_t(v));
    }
  EXPECT_TRUE(certified(*cloud, tris, idx->size()));
}

TEST(DelaunayTinPcl, DuplicatesNaNAndNoInput) {
  auto cloud = terrainCloud(200, 4);
  cloud->push_back((*cloud)[5]);
  cloud->push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 1.0f, 1.0f));
  cloud->is_dense = false;
  pcl::DelaunayTin<pcl::PointXYZ> tin;
  tin.setInputCloud(cloud);
  std::vector<std::uint32_t> tris;
  ASSERT_TRUE(tin.reconstructTriangles(tris));
  ASSERT_EQ(tin.getLastResult().duplicates.size(), 1u);
  EXPECT_EQ(tin.getLastResult().duplicates[0], std::make_pair(dw::index_t(200), dw::index_t(5)));
  EXPECT_EQ(tin.getLastResult().skipped, std::vector<dw::index_t>{201});
  for (auto v : tris) EXPECT_LT(v, 200u);

  pcl::DelaunayTin<pcl::PointXYZ> empty;
  std::vector<std::uint32_t> none;
  EXPECT_FALSE(empty.reconstructTriangles(none));
  EXPECT_TRUE(none.empty());
}

}  // namespace
