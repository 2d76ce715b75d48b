#pragma once

#include "pcl_delaunay_walk/registration/localizer_delaunay_walk.h"

namespace pcl {
namespace registration {

template <typename PointT>
void LocalizerDelaunayWalk<PointT>::setInputMap(const typename PointCloud::ConstPtr& map) {
  if (!map) throw dw::Error("pcl::registration::LocalizerDelaunayWalk: null map");
  const dw::PointView view =
      map->empty() ? dw::PointView{} : dw::PointView::fromFloat(&(*map)[0].x, map->size(), sizeof(PointT));
  localizer_ = std::make_shared<dw::Localizer>(view, options_);
  localizer_->setPose(pose_);
}

template <typename PointT>
void LocalizerDelaunayWalk<PointT>::loadMap(const std::string& path) {
  localizer_ = std::make_shared<dw::Localizer>(dw::Localizer::load(path, options_));
  localizer_->setPose(pose_);
}

template <typename PointT>
void LocalizerDelaunayWalk<PointT>::saveMap(const std::string& path) const {
  if (!localizer_) throw dw::Error("pcl::registration::LocalizerDelaunayWalk: no map to save");
  localizer_->save(path);
}

template <typename PointT>
void LocalizerDelaunayWalk<PointT>::setPose(const Matrix4& pose) {
  pose_ = pose;
  if (localizer_) localizer_->setPose(pose);
}

template <typename PointT>
dw::FrameResult LocalizerDelaunayWalk<PointT>::registerScan(const PointCloud& scan) {
  if (!localizer_)
    throw dw::Error("pcl::registration::LocalizerDelaunayWalk: no map (setInputMap or loadMap)");
  const dw::PointView view =
      scan.empty() ? dw::PointView{} : dw::PointView::fromFloat(&scan[0].x, scan.size(), sizeof(PointT));
  return localizer_->registerScan(view);
}

}  // namespace registration
}  // namespace pcl
