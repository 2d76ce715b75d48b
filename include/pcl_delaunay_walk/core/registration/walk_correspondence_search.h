/// \file walk_correspondence_search.h
/// \brief The Delaunay walk as the ICP loop's correspondence search: exact nearest neighbours in the
/// caller's float metric (dw::CallerMetricSearch), each query warm-started at its previous answer (PNN),
/// or by the KD-ANN locator when it has none (PNN-optimized) or when the hint lies farther from the
/// query than max_hint_distance: a hint kept from another frame (scan point i of the last frame) can be
/// anywhere when the scans do not keep their point order, and a walk costs steps in proportion to
/// the distance it covers, while KD-ANN costs one descent.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/registration/icp.h"
#include "pcl_delaunay_walk/core/search/caller_metric_search.h"

namespace dw {

class WalkCorrespondenceSearch final : public CorrespondenceSearch {
 public:
  /// The search's inputs are the map points (its input_to_cloud must be the identity).
  /// \param[in] max_hint_distance hints farther than this from the query are dropped (infinity: never)
  explicit WalkCorrespondenceSearch(std::shared_ptr<const CallerMetricSearch> search,
                                    StartStrategy strategy = StartStrategy::PnnOptimized,
                                    double max_hint_distance = std::numeric_limits<double>::infinity())
      : search_(std::move(search)), strategy_(strategy) {
    setMaxHintDistance(max_hint_distance);
    if (!search_) throw Error("dw::WalkCorrespondenceSearch: no search");
    if (!search_->inputToCloud().empty())
      throw Error("dw::WalkCorrespondenceSearch: the map search must index its inputs directly");
  }

  std::size_t size() const override { return search_->numInputs(); }
  const float* point(std::size_t i) const override { return &search_->inputXyz()[3 * i]; }
  bool nearest(const float q[3], index_t& hint, std::int32_t& index, float& dist2) const override {
    if (hint != kInvalidIndex && max_hint2_ < std::numeric_limits<float>::infinity()) {
      const DelaunayGraph& g = search_->graph();
      if (hint >= g.numVertices() ||
          squaredDistance(g.toLocal(q[0], q[1], q[2]), g.points[hint]) > max_hint2_)
        hint = kInvalidIndex;
    }
    WalkNeighbour nb;
    CallerMetricSearchStats stats;
    if (!search_->nearest(q, strategy_, hint, nb, &stats)) return false;
    hint = stats.nn_vertex;
    if (!retired_.empty() && retired_[static_cast<std::size_t>(nb.index)] && !nearestLive(q, hint, nb))
      return false;
    index = nb.index;
    dist2 = nb.sqr_distance;
    return true;
  }
  void prefetch(index_t hint) const override { search_->prefetchStart(hint); }
  index_t closerStart(const float* q, index_t own, index_t previous) const override {
    const DelaunayGraph& g = search_->graph();
    if (previous >= g.numVertices()) return own;
    if (own >= g.numVertices()) return previous;
    const Vec3f l = g.toLocal(q[0], q[1], q[2]);
    return squaredDistance(l, g.points[previous]) < squaredDistance(l, g.points[own]) ? previous : own;
  }

  void setMaxHintDistance(double d) {
    max_hint2_ = d < 1e18 ? static_cast<float>(d * d) : std::numeric_limits<float>::infinity();
  }

  /// Map points that are in the graph but no longer in the map (a sliding window's retired points):
  /// never answered. retired[i] != 0 for map point i (empty: none). A query whose nearest point is
  /// retired is answered by the nearest live one, found by expanding its exact k nearest; when every
  /// point within `max_distance` is retired it has no answer (nearest() returns false), as the ICP
  /// loop drops a match beyond its maximum correspondence distance anyway.
  void setRetired(std::vector<std::uint8_t> retired, double max_distance) {
    if (!retired.empty() && retired.size() != size())
      throw Error("dw::WalkCorrespondenceSearch: one retired flag per map point");
    retired_ = std::move(retired);
    retired_max2_ = max_distance < 1e18 ? static_cast<float>(max_distance * max_distance)
                                        : std::numeric_limits<float>::infinity();
  }

  const CallerMetricSearch& callerSearch() const { return *search_; }
  const std::shared_ptr<const CallerMetricSearch>& callerSearchPtr() const { return search_; }

 private:
  /// The nearest live point of q, where its nearest point is retired: the first live one among its k
  /// nearest (ascending, so exact), k growing until one is found, all points are in, or the k-th lies
  /// beyond retired_max2_ (then false).
  bool nearestLive(const float q[3], index_t hint, WalkNeighbour& nb) const {
    thread_local std::vector<WalkNeighbour> found;
    for (std::size_t k = 8;; k *= 4) {
      const std::size_t m = search_->knn(q, k, strategy_, hint, found);
      for (std::size_t j = 0; j < m; ++j)
        if (!retired_[static_cast<std::size_t>(found[j].index)]) {
          nb = found[j];
          return true;
        }
      if (m < k || m == 0 || found[m - 1].sqr_distance > retired_max2_) return false;
    }
  }

  std::shared_ptr<const CallerMetricSearch> search_;
  StartStrategy strategy_;
  float max_hint2_ = std::numeric_limits<float>::infinity();
  std::vector<std::uint8_t> retired_;
  float retired_max2_ = std::numeric_limits<float>::infinity();
};

}  // namespace dw
