/// \file impl/correspondence_estimation_delaunay_walk.hpp
/// \brief Template definitions of pcl::registration::CorrespondenceEstimationDelaunayWalk.
#pragma once

#include <pcl/common/copy_point.h>

#include <chrono>
#include <cmath>

#include "pcl_delaunay_walk/core/search/query_order.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"

namespace pcl {
namespace registration {

template <typename PointSource, typename PointTarget, typename Scalar>
CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::CorrespondenceEstimationDelaunayWalk()
    : walk_(new WalkSearch) {
  corr_name_ = "CorrespondenceEstimationDelaunayWalk";
}

template <typename PointSource, typename PointTarget, typename Scalar>
CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::CorrespondenceEstimationDelaunayWalk(
    const WalkSearchPtr& walk)
    : walk_(walk) {
  if (!walk_) throw dw::Error("CorrespondenceEstimationDelaunayWalk: null walk search");
  corr_name_ = "CorrespondenceEstimationDelaunayWalk";
}

template <typename PointSource, typename PointTarget, typename Scalar>
void CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::setSearchMethodWalk(
    const WalkSearchPtr& walk) {
  if (!walk) throw dw::Error("CorrespondenceEstimationDelaunayWalk::setSearchMethodWalk: null walk search");
  walk_ = walk;
  target_cloud_updated_ = true;
  invalidateCache();
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::initComputeWalk() {
  if (!target_) {
    PCL_ERROR("[pcl::registration::%s::compute] No input target dataset was given!\n", corr_name_.c_str());
    return false;
  }
  // Registration hands us its target tree every align(); if it is a walk tree, use its graph.
  // The point representation is the one the stock estimator's queries would see: its tree's, which
  // setPointRepresentation on this estimator (or on the Registration) has been given.
  const auto walk_tree = std::dynamic_pointer_cast<pcl::search::KdTreeDelaunayWalk<PointTarget>>(tree_);
  bool tree_owns_target = false;
  if (walk_tree) {
    if (walk_tree->getDelaunayWalk() != walk_) walk_ = walk_tree->getDelaunayWalk();
    // With force_no_recompute the user has set the tree's cloud and asked us to leave it alone.
    tree_owns_target = force_no_recompute_ && walk_->getInputCloud();
  }
  const auto representation = tree_ ? tree_->getPointRepresentation() : this->point_representation_;
  if ((target_cloud_updated_ && !tree_owns_target) || !walk_->getInputCloud()) {
    // Content-checked: an unchanged target keeps its graph, so this is one comparison per align().
    if (walk_tree)
      walk_tree->setInputCloud(target_, target_indices_);
    else
      walk_->setInputCloud(target_, target_indices_, representation);
  }
  target_cloud_updated_ = false;
  return PCLBase<PointSource>::initCompute();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::searchAll(
    double max_distance, bool reciprocal, pcl::Correspondences& correspondences) {
  if (walk_->getRepresentationRoute() == WalkSearch::RepresentationRoute::KdTreeFallback) {
    searchAllByTree(max_distance, reciprocal, correspondences);
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const dw::CallerMetricSearch& wq = *walk_->getCallerMetricSearch();
  const bool represented = walk_->getRepresentationRoute() == WalkSearch::RepresentationRoute::Represented;
  const std::size_t n = indices_->size();
  if (hint_source_ != input_.get() || hints_.size() != input_->size() || hint_graph_ != wq.id()) {
    hints_.assign(input_->size(), dw::kInvalidIndex);
    hint_source_ = input_.get();
    hint_graph_ = wq.id();
  }
  const bool use_hints = strategy_ == dw::StartStrategy::Pnn || strategy_ == dw::StartStrategy::PnnOptimized;
  const double max_dist_sqr = max_distance * max_distance;

  // Each slot is written by exactly one worker; the compaction below is sequential, so the output
  // does not depend on how the range was split.
  std::vector<pcl::Correspondence>& found = found_;
  std::vector<unsigned char>& keep = keep_;
  std::vector<dw::index_t>& new_hints = new_hints_;
  found.resize(n);
  keep.assign(n, 0);
  new_hints.assign(n, dw::kInvalidIndex);
  const unsigned workers = dw::workerCount(n, nr_threads_);
  std::vector<DelaunayWalkIterationStats> partial(workers);
  // With hints, walk the batch grouped by start vertex (graph memory order) rather than source order;
  // each slot still gets its own query's answer, so the output is the same.
  std::vector<dw::index_t>& order = order_;
  if (use_hints) {
    start_.resize(n);
    for (std::size_t i = 0; i < n; ++i) start_[i] = hints_[(*indices_)[i]];
    order = dw::orderByStartVertex(start_.data(), n, wq.neighbourSearch().graph().numVertices());
  }

  dw::parallelFor(n, workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    DelaunayWalkIterationStats& st = partial[w];
    PointTarget as_target;
    constexpr std::size_t kAhead = 6;  // queries between a start-vertex prefetch and its walk
    for (std::size_t k = begin; k < end; ++k) {
      if (use_hints && k + kAhead < end) {
        const auto ahead = (*indices_)[order[k + kAhead]];
        wq.prefetchStart(hints_[ahead]);
        __builtin_prefetch(&(*input_)[ahead]);  // in graph order, source reads scatter
      }
      const std::size_t i = use_hints ? order[k] : k;
      const auto idx = (*indices_)[i];
      const PointSource& p = (*input_)[idx];
      float q[3] = {p.x, p.y, p.z};
      if (represented) {
        copyPoint(p, as_target);  // what the stock estimator's tree vectorizes
        walk_->graphCoordinates(as_target, q);
      }
      if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) continue;
      dw::WalkNeighbour nb;
      dw::CallerMetricSearchStats qs;
      const dw::index_t hint = use_hints ? hints_[idx] : dw::kInvalidIndex;
      if (!wq.nearest(q, strategy_, hint, nb, &qs)) continue;
      ++st.queries;
      st.walk_steps += qs.walk_steps;
      st.widened += qs.widened ? 1 : 0;
      st.ties += qs.tied ? 1 : 0;
      new_hints[i] = qs.nn_vertex;
      // Every tied target is at this distance, so the cut holds whichever one is kept.
      if (nb.sqr_distance > max_dist_sqr) continue;  // as the stock estimator: float vs double
      found[i] = pcl::Correspondence(idx, nb.index, nb.sqr_distance);
      if (qs.tied) {
        keep[i] = 2;  // resolved after the loop (resolveTies)
        continue;
      }
      if (reciprocal && !reciprocalHolds(idx, nb.index, max_dist_sqr)) continue;
      keep[i] = 1;
    }
  });

  DelaunayWalkIterationStats total;
  for (const auto& s : partial) {
    total.queries += s.queries;
    total.walk_steps += s.walk_steps;
    total.widened += s.widened;
    total.ties += s.ties;
  }
  if (total.ties > 0) resolveTies(max_dist_sqr, reciprocal);
  correspondences.clear();
  correspondences.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (keep[i]) correspondences.push_back(found[i]);
    // Last write wins for a repeated source index, the same for any thread count.
    if (new_hints[i] != dw::kInvalidIndex) hints_[(*indices_)[i]] = new_hints[i];
  }
  total.correspondences = correspondences.size();
  total.nn_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stats_.push_back(total);
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::reciprocalHolds(
    pcl::index_t idx, pcl::index_t match, double max_dist_sqr) const {
  // As the stock estimator: the target point, as a source point, searched in the source tree.
  PointSource as_source;
  copyPoint((*target_)[match], as_source);
  pcl::Indices index_r(1);
  std::vector<float> dist_r(1);
  tree_reciprocal_->nearestKSearch(as_source, 1, index_r, dist_r);
  return !(dist_r[0] > max_dist_sqr) && idx == index_r[0];
}

template <typename PointSource, typename PointTarget, typename Scalar>
void CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::resolveTies(double max_dist_sqr,
                                                                                         bool reciprocal) {
  const std::size_t n = indices_->size();
  std::vector<std::size_t> tied;
  for (std::size_t i = 0; i < n; ++i)
    if (keep_[i] == 2) tied.push_back(i);
  const bool break_ties = tie_break_ == DelaunayWalkTieBreak::KdTreeOrder;
  const std::uint64_t graph = walk_->getCallerMetricSearch()->id();
  if (break_ties && (!tie_tree_ || tie_tree_graph_ != graph)) {
    // The stock estimator's tree: a search::KdTree's KdTreeFLANN (sorted, epsilon 0) over the same
    // target, indices and representation, so its traversal, and its pick among ties, are the same.
    typename pcl::KdTreeFLANN<PointTarget>::Ptr tree(new pcl::KdTreeFLANN<PointTarget>(true));
    if (walk_->getPointRepresentation()) tree->setPointRepresentation(walk_->getPointRepresentation());
    tree->setInputCloud(target_, target_indices_);
    tie_tree_ = tree;
    tie_tree_graph_ = graph;
  }
  const std::size_t call = stats_.size();
  std::vector<DelaunayWalkTie> resolved(tied.size());
  dw::parallelFor(
      tied.size(), dw::workerCount(tied.size(), nr_threads_),
      [&](std::size_t begin, std::size_t end, unsigned) {
        pcl::Indices index(1);
        std::vector<float> dist(1);
        PointTarget as_target;
        for (std::size_t t = begin; t < end; ++t) {
          pcl::Correspondence& c = found_[tied[t]];
          resolved[t] = {call, c.index_query, c.index_match, c.index_match, c.distance};
          if (break_ties) {
            copyPoint((*input_)[c.index_query], as_target);
            // Only a pick at the same distance: the walk's answer is exact either way.
            if (tie_tree_->nearestKSearch(as_target, 1, index, dist) == 1 && dist[0] == c.distance)
              c.index_match = resolved[t].chosen = index[0];
          }
          keep_[tied[t]] = !reciprocal || reciprocalHolds(c.index_query, c.index_match, max_dist_sqr);
        }
      });
  ties_.insert(ties_.end(), resolved.begin(), resolved.end());
}

template <typename PointSource, typename PointTarget, typename Scalar>
void CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::searchAllByTree(
    double max_distance, bool reciprocal, pcl::Correspondences& correspondences) {
  // The walk's KdTreeFallback route (a representation of more than 3 dimensions): each query through
  // the walk's public search, which its internal exact k-d tree answers; no hints.
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = indices_->size();
  const double max_dist_sqr = max_distance * max_distance;
  found_.resize(n);
  keep_.assign(n, 0);
  const unsigned workers = dw::workerCount(n, nr_threads_);
  std::vector<std::size_t> partial(workers, 0);
  dw::parallelFor(n, workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    pcl::Indices index(1);
    std::vector<float> dist(1);
    PointTarget as_target;
    for (std::size_t i = begin; i < end; ++i) {
      const auto idx = (*indices_)[i];
      copyPoint((*input_)[idx], as_target);
      if (walk_->nearestKSearch(as_target, 1, index, dist) != 1) continue;
      ++partial[w];
      if (dist[0] > max_dist_sqr) continue;
      if (reciprocal && !reciprocalHolds(idx, index[0], max_dist_sqr)) continue;
      found_[i] = pcl::Correspondence(idx, index[0], dist[0]);
      keep_[i] = 1;
    }
  });
  correspondences.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (keep_[i]) correspondences.push_back(found_[i]);
  DelaunayWalkIterationStats total;
  for (const std::size_t q : partial) total.queries += q;
  total.correspondences = correspondences.size();
  total.nn_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stats_.push_back(total);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::determineCorrespondences(
    pcl::Correspondences& correspondences, double max_distance) {
  if (!initComputeWalk()) return;
  searchAll(max_distance, false, correspondences);
  this->deinitCompute();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::
    determineReciprocalCorrespondences(pcl::Correspondences& correspondences, double max_distance) {
  if (!initComputeWalk()) return;
  // The backward search runs over the moving source, rebuilt every iteration: a k-d tree build is
  // ~50x cheaper than a Delaunay graph there, so it stays PCL's KdTree, as in the stock estimator.
  if (!this->initComputeReciprocal()) return;
  searchAll(max_distance, true, correspondences);
  this->deinitCompute();
}

template <typename PointSource, typename PointTarget, typename Scalar>
typename CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::Base::Ptr
CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>::clone() const {
  Ptr copy(new CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>(*this));
  // A separate walk object (same immutable graph), so re-targeting the copy leaves this one alone.
  copy->walk_.reset(new WalkSearch(*walk_));
  return copy;
}

}  // namespace registration
}  // namespace pcl
