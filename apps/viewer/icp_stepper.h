/// \file icp_stepper.h
/// \brief ICP with the Delaunay walk, one iteration at a time, keeping what a viewer wants to draw:
/// each source point's correspondence, walk length and start vertex.
///
/// The loop body is stock pcl::IterativeClosestPoint's (correspondences within the distance limit,
/// TransformationEstimationSVD on the transformed source, float re-transformation of the source,
/// DefaultConvergenceCriteria with ICP's settings), so stepping to the end gives stock ICP's result;
/// the test checks that. It is not IterativeClosestPointDelaunayWalk itself because align() runs to
/// convergence and its statistics are per iteration, while the viewer colours points by their own walk.
#pragma once

#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/default_convergence_criteria.h>
#include <pcl/registration/transformation_estimation_svd.h>

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

namespace dw_viewer {

/// ICP settings; the defaults are stock PCL's.
struct IcpSettings {
  int max_iterations = 10;
  double max_correspondence_distance = std::sqrt(std::numeric_limits<double>::max());
  double transformation_epsilon = 0.0;
  double euclidean_fitness_epsilon = -std::numeric_limits<double>::max();
  dw::StartStrategy start = dw::StartStrategy::PnnOptimized;
  dw::BuildOptions build;
  unsigned threads = 0;
};

/// The nearest-neighbour search at the current pose.
struct SearchStats {
  std::size_t queries = 0;
  std::size_t correspondences = 0;
  std::uint64_t walk_steps = 0;
  std::size_t widened = 0;  ///< queries certified by the near-tie fallback
  std::uint32_t max_walk = 0;
  double nn_seconds = 0.0;
  double rms = 0.0;  ///< RMS distance of the correspondences (the pose's error)

  double meanWalk() const { return queries ? static_cast<double>(walk_steps) / queries : 0.0; }
};

class IcpStepper {
 public:
  using Cloud = pcl::PointCloud<pcl::PointXYZ>;
  using Criteria = pcl::registration::DefaultConvergenceCriteria<float>;
  using State = Criteria::ConvergenceState;
  using WalkSearch = pcl::search::DelaunayWalk<pcl::PointXYZ>;

  /// Builds the target's Delaunay graph and searches at the initial pose.
  /// \throws dw::Error on empty or non-finite clouds or invalid settings
  IcpStepper(Cloud::ConstPtr source, Cloud::ConstPtr target, const IcpSettings& settings)
      : source_(std::move(source)), target_(std::move(target)), settings_(settings) {
    if (!source_ || source_->empty()) throw dw::Error("dw_viewer: the source cloud is empty");
    if (!target_ || target_->empty()) throw dw::Error("dw_viewer: the target cloud is empty");
    if (settings_.max_iterations < 1) throw dw::Error("dw_viewer: max_iterations must be >= 1");
    if (!(settings_.max_correspondence_distance > 0))
      throw dw::Error("dw_viewer: the correspondence distance limit must be > 0");
    for (const auto* cloud : {source_.get(), target_.get()})
      for (const auto& p : *cloud)
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
          throw dw::Error("dw_viewer: the ICP clouds must be finite (drop NaN points when loading)");
    walk_.reset(new WalkSearch);
    walk_->setBuildOptions(settings_.build);
    walk_->setInputCloud(target_);
    reset();
  }

  IcpStepper(const IcpStepper&) = delete;
  IcpStepper& operator=(const IcpStepper&) = delete;

  /// Back to the initial pose (and a fresh PNN cache), then searches there.
  void reset() {
    current_.reset(new Cloud(*source_));
    iteration_ = 0;
    final_ = Eigen::Matrix4f::Identity();
    increment_ = Eigen::Matrix4f::Identity();
    hints_.assign(source_->size(), dw::kInvalidIndex);
    used_correspondences_.clear();
    // Fresh criteria: they keep the previous MSE between calls, exactly as in one align().
    criteria_.reset(new Criteria(iteration_, increment_, used_correspondences_));
    criteria_->setMaximumIterations(settings_.max_iterations);
    criteria_->setRelativeMSE(settings_.euclidean_fitness_epsilon);
    criteria_->setTranslationThreshold(settings_.transformation_epsilon);
    criteria_->setRotationThreshold(1.0 - settings_.transformation_epsilon);
    state_ = Criteria::CONVERGENCE_CRITERIA_NOT_CONVERGED;
    search();
  }

  /// One ICP iteration: estimate the rigid motion from the current correspondences, move the source,
  /// check convergence, and search again at the new pose. Returns false (doing nothing) once finished.
  bool step() {
    if (finished()) return false;
    if (correspondences_.size() < 3) {  // stock ICP's min_number_correspondences_
      state_ = Criteria::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES;
      return false;
    }
    used_correspondences_ = correspondences_;
    estimator_.estimateRigidTransformation(*current_, *target_, used_correspondences_, increment_);
    transformInPlace(*current_, increment_);
    final_ = increment_ * final_;
    ++iteration_;
    criteria_->hasConverged();
    state_ = criteria_->getConvergenceState();
    search();
    return true;
  }

  /// True once ICP has stopped (converged, iteration limit, or too few correspondences).
  bool finished() const { return state_ != Criteria::CONVERGENCE_CRITERIA_NOT_CONVERGED; }
  State state() const { return state_; }

  static const char* stateName(State s) {
    switch (s) {
      case Criteria::CONVERGENCE_CRITERIA_NOT_CONVERGED: return "running";
      case Criteria::CONVERGENCE_CRITERIA_ITERATIONS: return "stopped: iteration limit";
      case Criteria::CONVERGENCE_CRITERIA_TRANSFORM: return "converged: transformation epsilon";
      case Criteria::CONVERGENCE_CRITERIA_ABS_MSE: return "converged: absolute MSE";
      case Criteria::CONVERGENCE_CRITERIA_REL_MSE: return "converged: relative MSE";
      case Criteria::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES: return "failed: fewer than 3 correspondences";
      case Criteria::CONVERGENCE_CRITERIA_FAILURE_AFTER_MAX_ITERATIONS:
        return "failed after the iteration limit";
    }
    return "unknown";
  }

  /// ICP iterations done (transformations applied).
  int iteration() const { return iteration_; }
  const Cloud& source() const { return *current_; }
  Cloud::ConstPtr sourcePtr() const { return current_; }
  const Cloud& target() const { return *target_; }
  Cloud::ConstPtr targetPtr() const { return target_; }
  /// Correspondences at the current pose (source order; query = source index, match = target index).
  const pcl::Correspondences& correspondences() const { return correspondences_; }
  /// Walk moves of every source point's search at the current pose.
  const std::vector<std::uint32_t>& walkLengths() const { return walk_lengths_; }
  /// The hint each source point's walk was given at the current pose (kInvalidIndex: none).
  const std::vector<dw::index_t>& hintsUsed() const { return hints_used_; }
  /// The strategy of the current pose's search.
  dw::StartStrategy startStrategy() const { return settings_.start; }
  const Eigen::Matrix4f& finalTransformation() const { return final_; }
  const SearchStats& stats() const { return stats_; }
  const WalkSearch& targetSearch() const { return *walk_; }
  const dw::DelaunayGraph& graph() const { return walk_->getCallerMetricSearch()->graph(); }
  double graphBuildSeconds() const { return walk_->getLastBuildSeconds(); }

 private:
  /// Stock ICP's transformCloud: float matrix times homogeneous float point.
  static void transformInPlace(Cloud& cloud, const Eigen::Matrix4f& t) {
    for (auto& p : cloud) {
      const Eigen::Vector4f q = t * Eigen::Vector4f(p.x, p.y, p.z, 1.0f);
      p.x = q[0];
      p.y = q[1];
      p.z = q[2];
    }
  }

  /// Nearest target point of every source point at the current pose; PNN hints for the next search.
  void search() {
    const auto& query = *walk_->getCallerMetricSearch();
    const std::size_t n = current_->size();
    const double max_sqr = settings_.max_correspondence_distance * settings_.max_correspondence_distance;
    std::vector<dw::WalkNeighbour> nn(n);
    std::vector<char> found(n, 0);
    walk_lengths_.assign(n, 0);
    std::vector<char> widened(n, 0);
    hints_used_ = hints_;
    const unsigned workers = dw::workerCount(n, settings_.threads);
    const auto t0 = std::chrono::steady_clock::now();
    dw::parallelFor(n, workers, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t i = b; i < e; ++i) {
        const auto& p = (*current_)[i];
        const float q[3] = {p.x, p.y, p.z};
        dw::CallerMetricSearchStats qs;
        found[i] = query.nearest(q, settings_.start, hints_[i], nn[i], &qs);
        walk_lengths_[i] = qs.walk_steps;
        widened[i] = qs.widened;
        hints_[i] = qs.nn_vertex;
      }
    });
    stats_ = SearchStats();
    stats_.nn_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    correspondences_.clear();
    double sum_sqr = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!found[i]) continue;
      ++stats_.queries;
      stats_.walk_steps += walk_lengths_[i];
      stats_.widened += widened[i] ? 1 : 0;
      stats_.max_walk = std::max(stats_.max_walk, walk_lengths_[i]);
      if (static_cast<double>(nn[i].sqr_distance) > max_sqr) continue;  // stock: d^2 > max^2 rejected
      pcl::Correspondence c;
      c.index_query = static_cast<pcl::index_t>(i);
      c.index_match = nn[i].index;
      c.distance = nn[i].sqr_distance;
      correspondences_.push_back(c);
      sum_sqr += nn[i].sqr_distance;
    }
    stats_.correspondences = correspondences_.size();
    stats_.rms = correspondences_.empty() ? 0.0 : std::sqrt(sum_sqr / correspondences_.size());
  }

  Cloud::ConstPtr source_, target_;
  IcpSettings settings_;
  WalkSearch::Ptr walk_;
  Cloud::Ptr current_;
  int iteration_ = 0;
  Eigen::Matrix4f final_ = Eigen::Matrix4f::Identity();
  Eigen::Matrix4f increment_ = Eigen::Matrix4f::Identity();
  pcl::Correspondences correspondences_, used_correspondences_;
  std::unique_ptr<Criteria> criteria_;  ///< refers to iteration_, increment_, used_correspondences_
  State state_ = Criteria::CONVERGENCE_CRITERIA_NOT_CONVERGED;
  pcl::registration::TransformationEstimationSVD<pcl::PointXYZ, pcl::PointXYZ, float> estimator_;
  std::vector<dw::index_t> hints_, hints_used_;
  std::vector<std::uint32_t> walk_lengths_;
  SearchStats stats_;
};

}  // namespace dw_viewer
