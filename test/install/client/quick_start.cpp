// The README's quick start, verbatim inside a function: it must compile against the installed package.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl_delaunay_walk/registration/icp_delaunay_walk.h>
#include <pcl_delaunay_walk/search/delaunay_walk.h>

std::size_t quickStart() {
  pcl::PointCloud<pcl::PointXYZ>::Ptr target(new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 1000; ++i)
    target->push_back(pcl::PointXYZ(float(i % 10), float(i / 10 % 10), float(i / 100) + 0.01f * (i % 7)));
  pcl::PointCloud<pcl::PointXYZ>::Ptr source(new pcl::PointCloud<pcl::PointXYZ>(*target));
  for (auto& p : *source) p.x += 0.05f;

  // Exact search, anywhere PCL takes a Search::Ptr (NormalEstimation, EuclideanClusterExtraction, ...).
  pcl::search::DelaunayWalk<pcl::PointXYZ>::Ptr search(new pcl::search::DelaunayWalk<pcl::PointXYZ>);
  search->setInputCloud(target);
  pcl::Indices k_indices;
  std::vector<float> k_sqr_distances;
  search->nearestKSearch((*source)[0], 8, k_indices, k_sqr_distances);

  // ICP whose correspondence search walks from the previous iteration's correspondences.
  pcl::IterativeClosestPointDelaunayWalk<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(source);
  icp.setInputTarget(target);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  icp.align(aligned);
  return k_indices.size() + (icp.hasConverged() ? 1 : 0);
}
