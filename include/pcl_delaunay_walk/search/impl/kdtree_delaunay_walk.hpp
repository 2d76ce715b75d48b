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
  this->tree_.reset(new detail::RepresentationSlot<PointT>(walk_));
}

template <typename PointT>
KdTreeDelaunayWalk<PointT>::KdTreeDelaunayWalk(const WalkPtr& walk) : KdTree<PointT>(true), walk_(walk) {
  if (!walk_) throw dw::Error("pcl::search::KdTreeDelaunayWalk: null walk search");
  this->name_ = "KdTreeDelaunayWalk";
  this->tree_.reset(new detail::RepresentationSlot<PointT>(walk_));
  // A walk that already has a representation keeps it (the slot's default would replace it).
  if (walk_->getPointRepresentation()) this->tree_->setPointRepresentation(walk_->getPointRepresentation());
}

template <typename PointT>
void KdTreeDelaunayWalk<PointT>::setPointRepresentation(const PointRepresentationConstPtr& representation) {
  // The slot re-enters its setInputCloud (and so the walk) when a cloud is attached.
  this->tree_->setPointRepresentation(representation);
  if (!input_) walk_->setPointRepresentation(representation);
}

template <typename PointT>
void KdTreeDelaunayWalk<PointT>::setInputCloud(const PointCloudConstPtr& cloud,
                                               const IndicesConstPtr& indices) {
  // The inherited FLANN slot never builds: building it is the cost this class avoids.
  walk_->setInputCloud(cloud, indices, this->tree_->getPointRepresentation());
  std::static_pointer_cast<detail::RepresentationSlot<PointT>>(this->tree_)->attach(cloud, indices);
  input_ = cloud;
  indices_ = indices;
}

}  // namespace search
}  // namespace pcl

#define PCL_INSTANTIATE_KdTreeDelaunayWalk(T) template class pcl::search::KdTreeDelaunayWalk<T>;
