/// \file icp_estimators.h
/// \brief Plugs every NN peer into stock pcl::IterativeClosestPoint and times the ICP steps (seed
/// Figs. 1-2: correspondence search vs transformation estimation vs the rest) and each iteration
/// (Fig. 14), without changing what ICP computes.
#pragma once

#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_svd.h>

#include <memory>
#include <vector>

#include "nn_methods.h"

namespace dwb {

using PointT = pcl::PointXYZ;
using Cloud = pcl::PointCloud<PointT>;

/// Timestamps of one align(): correspondence search (NN) and transformation estimation (SVD) per
/// iteration. An iteration runs from one NN step's start to the next one's (the last ends at end()).
struct IterationClock {
  Clock::time_point align_begin, align_end;
  std::vector<Clock::time_point> nn_begin;
  std::vector<double> nn_seconds, svd_seconds;
  void begin() {
    nn_begin.clear();
    nn_seconds.clear();
    svd_seconds.clear();
    align_begin = Clock::now();
  }
  void end() { align_end = Clock::now(); }
  std::size_t iterations() const { return nn_begin.size(); }
  double iterationSeconds(std::size_t i) const {
    const auto stop = i + 1 < nn_begin.size() ? nn_begin[i + 1] : align_end;
    return std::chrono::duration<double>(stop - nn_begin[i]).count();
  }
  double totalSeconds() const { return std::chrono::duration<double>(align_end - align_begin).count(); }
  double sumNn() const { return sum(nn_seconds); }
  double sumSvd() const { return sum(svd_seconds); }
  static double sum(const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return s;
  }
};

/// Correspondence estimation through any NnMethod. The method is built by the caller (build time is
/// reported on its own); the bench passes ICP a never-built KdTree with force_no_recompute so that
/// Registration does not build FLANN behind our back.
class MethodCorrespondenceEstimation
    : public pcl::registration::CorrespondenceEstimationBase<PointT, PointT, float> {
 public:
  using Ptr = std::shared_ptr<MethodCorrespondenceEstimation>;
  using Base = pcl::registration::CorrespondenceEstimationBase<PointT, PointT, float>;

  MethodCorrespondenceEstimation(std::shared_ptr<NnMethod> method, IterationClock* clock,
                                 unsigned threads = 1)
      : method_(std::move(method)), clock_(clock), threads_(threads) {
    corr_name_ = "MethodCorrespondenceEstimation";
  }

  /// Forgets the PNN hints: the next align() starts like the seed's first iteration.
  void resetHints() { batch_.resetHints(); }
  /// Walk moves of every query of every iteration since the last takeSteps().
  std::vector<std::uint32_t> takeSteps() { return std::move(steps_); }
  void recordSteps(bool on) { record_steps_ = on; }

  void determineCorrespondences(pcl::Correspondences& corr, double max_distance) override {
    if (clock_) clock_->nn_begin.push_back(Clock::now());
    const auto t0 = Clock::now();
    if (!pcl::PCLBase<PointT>::initCompute()) return;
    const std::size_t n = indices_->size();
    queries_.resize(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const PointT& p = (*input_)[(*indices_)[i]];
      queries_[3 * i] = p.x, queries_[3 * i + 1] = p.y, queries_[3 * i + 2] = p.z;
    }
    method_->nearest(queries_.data(), n, batch_, threads_);
    const double max_d2 = max_distance * max_distance;
    corr.resize(n);
    std::size_t valid = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (batch_.index[i] < 0 || batch_.dist2[i] > max_d2) continue;
      corr[valid++] = pcl::Correspondence((*indices_)[i], batch_.index[i], batch_.dist2[i]);
    }
    corr.resize(valid);
    if (record_steps_ && method_->isWalk())
      steps_.insert(steps_.end(), batch_.steps.begin(), batch_.steps.end());
    pcl::PCLBase<PointT>::deinitCompute();
    if (clock_) clock_->nn_seconds.push_back(secondsSince(t0));
  }

  void determineReciprocalCorrespondences(pcl::Correspondences&, double) override {
    throw dw::Error("dw_bench: reciprocal correspondences are not part of the benchmark protocol");
  }

  Base::Ptr clone() const override { return std::make_shared<MethodCorrespondenceEstimation>(*this); }

 private:
  std::shared_ptr<NnMethod> method_;
  IterationClock* clock_;
  unsigned threads_;
  NnBatch batch_;
  std::vector<float> queries_;
  std::vector<std::uint32_t> steps_;
  bool record_steps_ = false;
};

/// PCL's own estimator, unchanged, with its NN step timed (the stock pcl::search::KdTree path).
class TimedStockCorrespondenceEstimation
    : public pcl::registration::CorrespondenceEstimation<PointT, PointT, float> {
 public:
  explicit TimedStockCorrespondenceEstimation(IterationClock* clock) : clock_(clock) {}
  void determineCorrespondences(pcl::Correspondences& corr, double max_distance) override {
    clock_->nn_begin.push_back(Clock::now());
    const auto t0 = Clock::now();
    pcl::registration::CorrespondenceEstimation<PointT, PointT, float>::determineCorrespondences(
        corr, max_distance);
    clock_->nn_seconds.push_back(secondsSince(t0));
  }

 private:
  IterationClock* clock_;
};

/// PCL's SVD transformation estimation, unchanged, timed.
class TimedSvd : public pcl::registration::TransformationEstimationSVD<PointT, PointT, float> {
 public:
  using Base = pcl::registration::TransformationEstimationSVD<PointT, PointT, float>;
  using Base::estimateRigidTransformation;
  explicit TimedSvd(IterationClock* clock) : clock_(clock) {}
  void estimateRigidTransformation(const Cloud& src, const Cloud& tgt, const pcl::Correspondences& corr,
                                   Matrix4& t) const override {
    const auto t0 = Clock::now();
    Base::estimateRigidTransformation(src, tgt, corr, t);
    clock_->svd_seconds.push_back(secondsSince(t0));
  }

 private:
  IterationClock* clock_;
};

/// The seed's ICP settings: at most `max_iterations`, error 1e-11 (transformation and relative MSE).
inline void configureIcp(pcl::IterativeClosestPoint<PointT, PointT, float>& icp, int max_iterations) {
  icp.setMaximumIterations(max_iterations);
  icp.setTransformationEpsilon(1e-11);
  icp.setEuclideanFitnessEpsilon(1e-11);
}

}  // namespace dwb
