/// \file impl/kdtree_delaunay_walk.hpp
/// \brief Template definitions of pcl::search::KdTreeDelaunayWalk.
#pragma once

#include "pcl_delaunay_walk/search/impl/delaunay_walk.hpp"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"

namespace pcl {
namespace search {

template <typename PointT>
KdTreeDelaunayWalk<PointT>::KdTreeDelaunayWalk(bool sorted)
    : KdTree<PointT>(sorted), walk_(new DelaunayWalk<PointT>(sorted)) {
  this->name_ = "KdTreeDelaunayWalk";
}

template <typename PointT>
KdTreeDelaunayWalk<PointT>::KdTreeDelaunayWalk(const WalkPtr& walk) : KdTree<PointT>(true), walk_(walk) {
  if (!walk_) throw dw::Error("pcl::search::KdTreeDelaunayWalk: null walk search");
  this->name_ = "KdTreeDelaunayWalk";
}

template <typename PointT>
void KdTreeDelaunayWalk<PointT>::setInputCloud(const PointCloudConstPtr& cloud,
                                               const IndicesConstPtr& indices) {
  // The inherited FLANN tree is deliberately left empty: building it is the cost this class avoids.
  walk_->setInputCloud(cloud, indices);
  input_ = cloud;
  indices_ = indices;
}

}  // namespace search
}  // namespace pcl

#define PCL_INSTANTIATE_KdTreeDelaunayWalk(T) template class pcl::search::KdTreeDelaunayWalk<T>;
