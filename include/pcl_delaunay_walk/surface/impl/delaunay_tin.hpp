/// \file delaunay_tin.hpp
/// \brief Template definitions of pcl::DelaunayTin.
#pragma once

#include <pcl/conversions.h>

#include "pcl_delaunay_walk/surface/delaunay_tin.h"

namespace pcl {

template <typename PointInT>
void DelaunayTin<PointInT>::triangulate() {
  const auto& cloud = *this->input_;
  const auto& idx = *this->indices_;
  std::vector<double> x(idx.size()), y(idx.size());
  for (std::size_t i = 0; i < idx.size(); ++i) {
    x[i] = cloud[idx[i]].x;  // float -> double is exact: the predicates see the cloud's own values
    y[i] = cloud[idx[i]].y;
  }
  last_ = dw::tin::triangulate(std::move(x), std::move(y), options_);
  for (auto& v : last_.triangles) v = static_cast<std::uint32_t>(idx[v]);
  for (auto& d : last_.duplicates)
    d = {static_cast<dw::index_t>(idx[d.first]), static_cast<dw::index_t>(idx[d.second])};
  for (auto& s : last_.skipped) s = static_cast<dw::index_t>(idx[s]);
}

template <typename PointInT>
bool DelaunayTin<PointInT>::reconstructTriangles(std::vector<std::uint32_t>& triangles) {
  triangles.clear();
  if (!this->initCompute()) {
    PCL_ERROR("[pcl::%s::reconstructTriangles] no input cloud\n", getClassName().c_str());
    return false;
  }
  triangulate();
  triangles.swap(last_.triangles);
  this->deinitCompute();
  return true;
}

template <typename PointInT>
void DelaunayTin<PointInT>::performReconstruction(pcl::PolygonMesh& output) {
  pcl::toPCLPointCloud2(*this->input_, output.cloud);
  performReconstruction(output.polygons);
}

template <typename PointInT>
void DelaunayTin<PointInT>::performReconstruction(std::vector<pcl::Vertices>& polygons) {
  triangulate();
  const std::size_t nt = last_.triangles.size() / 3;
  polygons.assign(nt, pcl::Vertices());
  for (std::size_t t = 0; t < nt; ++t)
    polygons[t].vertices = {static_cast<pcl::index_t>(last_.triangles[3 * t]),
                            static_cast<pcl::index_t>(last_.triangles[3 * t + 1]),
                            static_cast<pcl::index_t>(last_.triangles[3 * t + 2])};
}

}  // namespace pcl

#define PCL_INSTANTIATE_DelaunayTin(T) template class pcl::DelaunayTin<T>;
