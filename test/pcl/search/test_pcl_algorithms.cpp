// PCL algorithms that take a Search::Ptr give the same output with DelaunayWalk as with KdTree:
// NormalEstimation (kNN and radius), NormalEstimationOMP (concurrent queries) and
// EuclideanClusterExtraction.
#include <pcl/features/normal_3d.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "search_test_util.h"

using namespace dw_pcl_test;

namespace {

using Normals = pcl::PointCloud<pcl::Normal>;

/// Normals are bit-identical when the neighbour lists are; NaN normals must match as NaN.
void expectSameNormals(const Normals& a, const Normals& b) {
  ASSERT_EQ(a.size(), b.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto& p = a[i];
    const auto& q = b[i];
    for (int k = 0; k < 4; ++k) {
      const float x = k < 3 ? p.normal[k] : p.curvature, y = k < 3 ? q.normal[k] : q.curvature;
      if (std::isnan(x) && std::isnan(y)) continue;
      if (x != y) ++differ;
    }
  }
  EXPECT_EQ(differ, 0u);
}

Cloud::Ptr dragonOrSynthetic() {
  if (auto c = loadShared("models/dragon_vrip_res3.ply")) return c;
  return uniformCloud(5000, 17);
}

}  // namespace

TEST(PclAlgorithms, NormalEstimationKnnAndRadius) {
  auto cloud = dragonOrSynthetic();
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  pcl::search::DelaunayWalk<pcl::PointXYZ>::Ptr walk(new pcl::search::DelaunayWalk<pcl::PointXYZ>);
  for (int mode = 0; mode < 2; ++mode) {
    Normals a, b;
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
    ne.setInputCloud(cloud);
    if (mode == 0)
      ne.setKSearch(12);
    else
      ne.setRadiusSearch(0.004);
    ne.setSearchMethod(tree);
    ne.compute(a);
    ne.setSearchMethod(walk);
    ne.compute(b);
    expectSameNormals(a, b);
  }
}

TEST(PclAlgorithms, NormalEstimationWithSearchSurfaceAndIndices) {
  auto cloud = dragonOrSynthetic();
  auto keys = subsample(*cloud, 5);
  pcl::IndicesPtr some(new pcl::Indices);
  for (int i = 0; i < static_cast<int>(keys->size()); i += 2) some->push_back(i);
  Normals a, b;
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud(keys);
  ne.setIndices(some);
  ne.setSearchSurface(cloud);
  ne.setKSearch(20);
  ne.setSearchMethod(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
  ne.compute(a);
  ne.setSearchMethod(
      pcl::search::DelaunayWalk<pcl::PointXYZ>::Ptr(new pcl::search::DelaunayWalk<pcl::PointXYZ>));
  ne.compute(b);
  expectSameNormals(a, b);
}

TEST(PclAlgorithms, NormalEstimationOmpConcurrentQueries) {
  auto cloud = dragonOrSynthetic();
  Normals a, b, c;
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(4);
  ne.setInputCloud(cloud);
  ne.setKSearch(16);
  ne.setSearchMethod(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
  ne.compute(a);
  pcl::search::DelaunayWalk<pcl::PointXYZ>::Ptr walk(new pcl::search::DelaunayWalk<pcl::PointXYZ>);
  walk->setStartStrategy(dw::StartStrategy::PnnOptimized);
  ne.setSearchMethod(walk);
  ne.compute(b);
  expectSameNormals(a, b);
  ne.setNumberOfThreads(1);
  ne.compute(c);
  expectSameNormals(b, c);
}

TEST(PclAlgorithms, EuclideanClusterExtraction) {
  Cloud::Ptr cloud = loadShared("scans/fastgicp_251370668.pcd");
  if (!cloud) GTEST_SKIP() << "shared data scans/fastgicp_251370668.pcd absent";
  cloud = subsample(*cloud, 3);
  auto clusters = [&](const pcl::search::Search<pcl::PointXYZ>::Ptr& search) {
    std::vector<pcl::PointIndices> out;
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
    ec.setClusterTolerance(0.5);
    ec.setMinClusterSize(5);
    ec.setMaxClusterSize(1000000);
    ec.setSearchMethod(search);
    ec.setInputCloud(cloud);
    ec.extract(out);
    std::vector<std::vector<int>> sets;
    for (auto& pi : out) {
      std::vector<int> s(pi.indices.begin(), pi.indices.end());
      std::sort(s.begin(), s.end());
      sets.push_back(s);
    }
    std::sort(sets.begin(), sets.end());
    return sets;
  };
  const auto a = clusters(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
  const auto b =
      clusters(pcl::search::DelaunayWalk<pcl::PointXYZ>::Ptr(new pcl::search::DelaunayWalk<pcl::PointXYZ>));
  ASSERT_GT(a.size(), 3u);
  EXPECT_EQ(a, b);
}
