/// \file correspondence_estimation_delaunay_walk.h
/// \brief Correspondence estimation by the Delaunay walk with per-source-point PNN caching (seed:
/// Anderson et al. 2022, §4): a drop-in for pcl::registration::CorrespondenceEstimation.
#pragma once

#include <pcl/registration/correspondence_estimation.h>

#include <cstdint>
#include <vector>

#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"

namespace pcl {
namespace registration {

/** \brief What one determineCorrespondences() call cost: one ICP iteration. */
struct DelaunayWalkIterationStats {
  std::size_t queries = 0;          ///< source points searched (finite ones)
  std::size_t correspondences = 0;  ///< correspondences kept (within max_distance)
  std::uint64_t walk_steps = 0;     ///< total walk moves (seed: walk count)
  std::size_t widened = 0;          ///< queries that needed the near-tie fallback
  std::size_t ties = 0;             ///< queries whose nearest distance several targets share
  double nn_seconds = 0.0;          ///< wall time of the nearest-neighbour searches

  /** \brief Mean walk moves per query. */
  double meanWalkSteps() const {
    return queries ? static_cast<double>(walk_steps) / static_cast<double>(queries) : 0.0;
  }
};

/** \brief One query whose nearest target distance several target points share (an exact tie). */
struct DelaunayWalkTie {
  std::size_t call = 0;      ///< which determineCorrespondences() call since clearStatistics (0-based)
  pcl::index_t query = 0;    ///< source index
  pcl::index_t lowest = 0;   ///< the lowest target index at that distance (the walk's own answer)
  pcl::index_t chosen = 0;   ///< the target index the correspondence got (see TieBreak)
  float sqr_distance = 0.f;  ///< the shared squared distance
};

/** \brief How an exact tie between equidistant target points is broken. */
enum class DelaunayWalkTieBreak {
  KdTreeOrder,  ///< as pcl::KdTreeFLANN (the stock estimator's tree): its pick, asked from such a tree
  LowestIndex   ///< the lowest target index (no k-d tree is ever built)
};

/** \brief Nearest-neighbour correspondences by the Delaunay walk.
 *
 * Install it in an existing pipeline with icp.setCorrespondenceEstimation(ce). It gives the same
 * correspondences as CorrespondenceEstimation with a KdTree (exact, FLANN's float distances, ties by
 * lowest index), and:
 *  - keeps the target graph across align() calls while the target's coordinates are unchanged
 *    (PCL re-sets the target on every align());
 *  - remembers each source point's previous nearest vertex and starts its next walk there (PNN), which
 *    is what makes later ICP iterations cheap; the cache is dropped when the source cloud object, its
 *    size or the graph changes;
 *  - runs multi-threaded (setNumberOfThreads), with results independent of the thread count.
 * When the Registration's target tree is a KdTreeDelaunayWalk (setSearchMethodTarget), the estimator
 * shares its walk, so the graph is built once and FLANN never. Reciprocal correspondences use the walk
 * for the forward search and PCL's source KdTree for the backward one, exactly as the stock class.
 * Source points with NaN coordinates get no correspondence.
 *
 * Exact ties: when several target points lie at exactly the nearest distance (duplicates, or
 * equidistant points, common when source and target share a scanner's quantisation grid), FLANN keeps
 * the first one its tree visits, which no rule on the points alone reproduces. With the default
 * DelaunayWalkTieBreak::KdTreeOrder those queries (the walk reports them) are answered by a
 * pcl::KdTreeFLANN of the target built with the stock estimator's settings, on the first tie only,
 * so the correspondences, and ICP's trajectory, are the stock estimator's. getTies() lists them.
 */
template <typename PointSource, typename PointTarget, typename Scalar = float>
class CorrespondenceEstimationDelaunayWalk
    : public CorrespondenceEstimationBase<PointSource, PointTarget, Scalar> {
 public:
  using Base = CorrespondenceEstimationBase<PointSource, PointTarget, Scalar>;
  using Ptr = shared_ptr<CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>>;
  using ConstPtr = shared_ptr<const CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>>;
  using WalkSearch = pcl::search::DelaunayWalk<PointTarget>;
  using WalkSearchPtr = typename WalkSearch::Ptr;
  using PointCloudTarget = typename Base::PointCloudTarget;

  using Base::corr_name_;
  using Base::force_no_recompute_;
  using Base::indices_;
  using Base::input_;
  using Base::target_;
  using Base::target_cloud_updated_;
  using Base::target_indices_;
  using Base::tree_;
  using Base::tree_reciprocal_;

  /** \brief Constructor with its own walk search. */
  CorrespondenceEstimationDelaunayWalk();

  /** \brief Constructor sharing a walk search (and its graph) with other objects.
   * \param[in] walk the walk search (must not be null)
   */
  explicit CorrespondenceEstimationDelaunayWalk(const WalkSearchPtr& walk);

  ~CorrespondenceEstimationDelaunayWalk() override = default;

  /** \brief Set the walk search to use (and share).
   * \param[in] walk the walk search (must not be null)
   */
  void setSearchMethodWalk(const WalkSearchPtr& walk);

  /** \brief The walk search in use. */
  const WalkSearchPtr& getSearchMethodWalk() const { return walk_; }

  /** \brief Set the start strategy of the walks: Zero, KdAnn, Pnn (previous correspondence, Zero in
   * the first iteration) or PnnOptimized (default: previous correspondence, KD-ANN in the first).
   * \param[in] strategy the start strategy
   */
  void setStartStrategy(dw::StartStrategy strategy) { strategy_ = strategy; }

  /** \brief Get the start strategy. */
  dw::StartStrategy getStartStrategy() const { return strategy_; }

  /** \brief Set the number of threads (0: all hardware threads). Results do not depend on it.
   * \param[in] nr_threads the number of threads
   */
  void setNumberOfThreads(unsigned int nr_threads) { nr_threads_ = nr_threads; }

  /** \brief Get the number of threads (0: all hardware threads). */
  unsigned int getNumberOfThreads() const { return nr_threads_; }

  /** \brief Set how exact ties between equidistant target points are broken (see the class).
   * \param[in] tie_break KdTreeOrder (default, as the stock estimator) or LowestIndex
   */
  void setTieBreak(DelaunayWalkTieBreak tie_break) { tie_break_ = tie_break; }

  /** \brief Get the tie rule. */
  DelaunayWalkTieBreak getTieBreak() const { return tie_break_; }

  /** \brief The tied queries of every call since the last clearStatistics(). */
  const std::vector<DelaunayWalkTie>& getTies() const { return ties_; }

  /** \brief Nearest target point of every source point within max_distance.
   * \param[out] correspondences the correspondences, in source order
   * \param[in] max_distance maximum distance between corresponding points
   */
  void determineCorrespondences(pcl::Correspondences& correspondences,
                                double max_distance = std::numeric_limits<double>::max()) override;

  /** \brief Correspondences that are nearest neighbours in both directions.
   * \param[out] correspondences the correspondences, in source order
   * \param[in] max_distance maximum distance between corresponding points
   */
  void determineReciprocalCorrespondences(pcl::Correspondences& correspondences,
                                          double max_distance = std::numeric_limits<double>::max()) override;

  /** \brief A copy with its own walk search object (sharing the immutable graph) and cache. */
  typename Base::Ptr clone() const override;

  /** \brief Drop the PNN cache (the next call starts every walk afresh). */
  void invalidateCache() {
    hint_source_ = nullptr;
    hints_.clear();
  }

  /** \brief Statistics of every determineCorrespondences() call since the last clearStatistics(). */
  const std::vector<DelaunayWalkIterationStats>& getStatistics() const { return stats_; }

  /** \brief Forget the collected statistics and ties. */
  void clearStatistics() {
    stats_.clear();
    ties_.clear();
  }

 protected:
  /** \brief Target set-up: share the walk of a KdTreeDelaunayWalk target tree if there is one, and
   * give the walk the target (a no-op when unchanged). Never builds the base's FLANN tree. */
  bool initComputeWalk();

  /** \brief The forward nearest-neighbour pass shared by both public methods. */
  void searchAll(double max_distance, bool reciprocal, pcl::Correspondences& correspondences);

  /** \brief The same through the walk's internal k-d tree (its KdTreeFallback route). */
  void searchAllByTree(double max_distance, bool reciprocal, pcl::Correspondences& correspondences);

  /** \brief Gives the tied slots (keep_ == 2) the k-d tree's pick and the reciprocal check. */
  void resolveTies(double max_dist_sqr, bool reciprocal);

  /** \brief Whether target point \a match keeps source point \a idx as its own nearest. */
  bool reciprocalHolds(pcl::index_t idx, pcl::index_t match, double max_dist_sqr) const;

  WalkSearchPtr walk_;
  dw::StartStrategy strategy_ = dw::StartStrategy::PnnOptimized;
  unsigned int nr_threads_ = 0;
  // PNN cache: previous nearest vertex per source index, valid for one source object and one graph.
  const void* hint_source_ = nullptr;
  std::uint64_t hint_graph_ = 0;
  std::vector<dw::index_t> hints_;
  std::vector<DelaunayWalkIterationStats> stats_;
  std::vector<DelaunayWalkTie> ties_;
  DelaunayWalkTieBreak tie_break_ = DelaunayWalkTieBreak::KdTreeOrder;
  // The stock estimator's tree, built on the first tie of a target (keyed on the walk's graph id).
  typename pcl::KdTreeFLANN<PointTarget>::Ptr tie_tree_;
  std::uint64_t tie_tree_graph_ = 0;
  // Per-iteration scratch, kept between iterations: freeing and re-mapping five source-sized arrays
  // every iteration costs page faults next to walks of ~1-2 steps.
  std::vector<pcl::Correspondence> found_;
  std::vector<unsigned char> keep_;
  std::vector<dw::index_t> new_hints_, start_, order_;
};

}  // namespace registration
}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include "pcl_delaunay_walk/registration/impl/correspondence_estimation_delaunay_walk.hpp"
#endif
