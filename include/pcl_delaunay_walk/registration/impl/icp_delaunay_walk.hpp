/// \file impl/icp_delaunay_walk.hpp
/// \brief Template definitions of pcl::IterativeClosestPointDelaunayWalk.
#pragma once

#include <pcl/registration/icp.h>

#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"
#include "pcl_delaunay_walk/registration/impl/correspondence_estimation_delaunay_walk.hpp"
#include "pcl_delaunay_walk/search/impl/kdtree_delaunay_walk.hpp"

namespace pcl {

template <typename PointSource, typename PointTarget, typename Scalar>
IterativeClosestPointDelaunayWalk<PointSource, PointTarget, Scalar>::IterativeClosestPointDelaunayWalk()
    : walk_(new WalkSearch), walk_tree_(new WalkTree(walk_)), estimation_(new WalkEstimation(walk_)) {
  this->reg_name_ = "IterativeClosestPointDelaunayWalk";
  // force_no_recompute = false: Registration re-sets the target on the tree every align(), which the
  // walk turns into a content check, so a changed target is picked up and an unchanged one kept.
  this->setSearchMethodTarget(walk_tree_, false);
  this->setCorrespondenceEstimation(estimation_);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void IterativeClosestPointDelaunayWalk<PointSource, PointTarget, Scalar>::setTargetGraph(
    dw::DelaunayGraph::ConstPtr graph) {
  walk_->setGraph(std::move(graph));
  this->target_cloud_updated_ = true;
}

template <typename PointSource, typename PointTarget, typename Scalar>
void IterativeClosestPointDelaunayWalk<PointSource, PointTarget, Scalar>::loadTargetGraph(
    const std::string& path) {
  walk_->loadGraph(path);
  this->target_cloud_updated_ = true;
}

template <typename PointSource, typename PointTarget, typename Scalar>
void IterativeClosestPointDelaunayWalk<PointSource, PointTarget, Scalar>::computeTransformation(
    PointCloudSource& output, const Matrix4& guess) {
  // Registration::initCompute() has already given the target to the tree (building or keeping the
  // graph); the estimator's own check below is then a comparison only.
  build_seconds_ = walk_->getLastBuildSeconds();
  estimation_->clearStatistics();
  Base::computeTransformation(output, guess);
}

}  // namespace pcl
