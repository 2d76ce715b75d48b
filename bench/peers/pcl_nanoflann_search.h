/// \file pcl_nanoflann_search.h
/// \brief A pcl::search::Search over nanoflann's KDTreeSingleIndexAdaptor (L2_Simple, leaf size 10),
/// so that PCL's own algorithms (NormalEstimationOMP, EuclideanClusterExtraction, ...) can run on
/// nanoflann as they run on pcl::search::KdTree: the stand-in for PCL 1.15's KdTreeNanoflann, which
/// PCL 1.13 lacks. Benchmark-only (bench/dw_pcl_pipelines.cpp): the including target puts the
/// nanoflann it measures first on its include path (bench/CMakeLists.txt, DW_PEERS_DIR).
///
/// Semantics follow pcl::search::KdTree: setInputCloud (re)builds the tree over the cloud, or over
/// the given indices, whose positions map back to cloud indices in every answer; kNN answers are
/// sorted by distance, radius answers only when sorted results are asked for; max_nn > 0 keeps the
/// max_nn nearest.
#pragma once

#include <pcl/search/search.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <nanoflann.hpp>
#include <string>
#include <vector>

static_assert(NANOFLANN_VERSION >= 0x150, "NanoflannSearch uses the nanoflann >= 1.5 search API");

namespace dwb {

template <typename PointT>
class NanoflannSearch : public pcl::search::Search<PointT> {
 public:
  using Base = pcl::search::Search<PointT>;
  using Base::nearestKSearch;
  using Base::radiusSearch;
  using typename Base::IndicesConstPtr;
  using typename Base::PointCloudConstPtr;

  explicit NanoflannSearch(bool sorted = false) : Base("NanoflannSearch", sorted) {}

  void setInputCloud(const PointCloudConstPtr& cloud,
                     const IndicesConstPtr& indices = IndicesConstPtr()) override {
    Base::setInputCloud(cloud, indices);
    index_.reset();
    points_.xyz.clear();
    map_.clear();
    if (!cloud) return;
    // The tree indexes positions 0..m-1 of the indexed subset; map_ turns them into cloud indices.
    const std::size_t m = indices ? indices->size() : cloud->size();
    points_.xyz.reserve(3 * m);
    map_.reserve(m);
    for (std::size_t j = 0; j < m; ++j) {
      const pcl::index_t i = indices ? (*indices)[j] : static_cast<pcl::index_t>(j);
      const PointT& p = (*cloud)[i];
      points_.xyz.insert(points_.xyz.end(), {p.x, p.y, p.z});
      map_.push_back(i);
    }
    index_ = std::make_unique<Index>(3, points_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  }

  int nearestKSearch(const PointT& point, int k, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override {
    if (!index_ || k <= 0) return 0;
    const float q[3] = {point.x, point.y, point.z};
    idx_.resize(static_cast<std::size_t>(k));
    k_sqr_distances.resize(static_cast<std::size_t>(k));
    nanoflann::KNNResultSet<float, std::uint32_t> rs(static_cast<std::size_t>(k));
    rs.init(idx_.data(), k_sqr_distances.data());
    (void)index_->findNeighbors(rs, q, nanoflann::SearchParameters());
    const std::size_t found = rs.size();
    k_indices.resize(found);
    k_sqr_distances.resize(found);
    for (std::size_t j = 0; j < found; ++j) k_indices[j] = map_[idx_[j]];
    return static_cast<int>(found);
  }

  int radiusSearch(const PointT& point, double radius, pcl::Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override {
    k_indices.clear();
    k_sqr_distances.clear();
    if (!index_) return 0;
    const float q[3] = {point.x, point.y, point.z};
    // nanoflann's L2 metrics take the squared radius.
    const float r2 = static_cast<float>(radius * radius);
    const bool keep_nearest = max_nn > 0 && max_nn < map_.size();
    const nanoflann::SearchParameters sp(0.f, this->sorted_results_ || keep_nearest);
    std::size_t found = index_->radiusSearch(q, r2, matches_, sp);
    if (keep_nearest) found = std::min<std::size_t>(found, max_nn);
    k_indices.resize(found);
    k_sqr_distances.resize(found);
    for (std::size_t j = 0; j < found; ++j) {
      k_indices[j] = map_[matches_[j].first];
      k_sqr_distances[j] = matches_[j].second;
    }
    return static_cast<int>(found);
  }

 private:
  struct Points {
    std::vector<float> xyz;
    std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const {
      return false;
    }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Points>, Points, 3,
                                                    std::uint32_t>;
  Points points_;
  std::vector<pcl::index_t> map_;
  std::unique_ptr<Index> index_;
  // Per-query scratch: PCL's searches are const, and each thread of NormalEstimationOMP needs its own.
  static thread_local std::vector<std::uint32_t> idx_;
  static thread_local std::vector<nanoflann::ResultItem<std::uint32_t, float>> matches_;
};

template <typename PointT>
thread_local std::vector<std::uint32_t> NanoflannSearch<PointT>::idx_;
template <typename PointT>
thread_local std::vector<nanoflann::ResultItem<std::uint32_t, float>> NanoflannSearch<PointT>::matches_;

}  // namespace dwb
