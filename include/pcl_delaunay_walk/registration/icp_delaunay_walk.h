/// \file icp_delaunay_walk.h
/// \brief pcl::IterativeClosestPointDelaunayWalk: stock ICP with the Delaunay walk installed in both
/// places PCL searches the target (the correspondence estimator and the Registration's target tree).
#pragma once

#include <pcl/registration/icp.h>

#include <string>
#include <vector>

#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"

namespace pcl {

/** \brief IterativeClosestPoint whose target searches are Delaunay walks.
 *
 * Behaves exactly like pcl::IterativeClosestPoint (same transformation, same iterations: the walk is
 * exact) and accepts everything it accepts (rejectors, point-to-plane transformation estimation via
 * setTransformationEstimation, reciprocal correspondences, guesses). In addition:
 *  - the target graph is built once and kept while the target is unchanged, across align() calls;
 *  - a prebuilt or saved graph can be given for the target (setTargetGraph / loadTargetGraph), for
 *    localisation against a fixed map;
 *  - per-iteration statistics (walk counts, NN time) are kept for the last align().
 * getFitnessScore() and anything else that queries the target tree also walks.
 * A point representation (setPointRepresentation, here or through a Registration pointer) is
 * honoured as stock ICP honours it: searches in the represented space, by the walk for up to 3
 * dimensions and by an internal exact pcl::KdTreeFLANN beyond (pcl::search::DelaunayWalk).
 */
template <typename PointSource, typename PointTarget, typename Scalar = float>
class IterativeClosestPointDelaunayWalk : public IterativeClosestPoint<PointSource, PointTarget, Scalar> {
 public:
  using Base = IterativeClosestPoint<PointSource, PointTarget, Scalar>;
  using Ptr = shared_ptr<IterativeClosestPointDelaunayWalk<PointSource, PointTarget, Scalar>>;
  using ConstPtr = shared_ptr<const IterativeClosestPointDelaunayWalk<PointSource, PointTarget, Scalar>>;
  using PointCloudSource = typename Base::PointCloudSource;
  using Matrix4 = typename Base::Matrix4;
  using WalkSearch = pcl::search::DelaunayWalk<PointTarget>;
  using WalkTree = pcl::search::KdTreeDelaunayWalk<PointTarget>;
  using WalkEstimation =
      pcl::registration::CorrespondenceEstimationDelaunayWalk<PointSource, PointTarget, Scalar>;

  /** \brief Constructor: installs a walk tree and a walk correspondence estimator sharing one graph. */
  IterativeClosestPointDelaunayWalk();
  ~IterativeClosestPointDelaunayWalk() override = default;

  /** \brief Set the point representation of the target searches, as stock ICP's. Called on this
   * class, the walk takes it at once, so the first align() builds one graph; called through a
   * Registration pointer, it reaches the walk inside align() (the first align() then builds twice).
   * \param[in] representation the representation
   */
  void setPointRepresentation(const typename Base::PointRepresentationConstPtr& representation) {
    Base::setPointRepresentation(representation);
    walk_tree_->setPointRepresentation(representation);
  }

  /** \brief Use a prebuilt graph of the target instead of building one; checked against the target
   * at the next align() (a dw::Error is thrown from align() if it was built from other points).
   * \param[in] graph the target's graph
   */
  void setTargetGraph(dw::DelaunayGraph::ConstPtr graph);

  /** \brief Like setTargetGraph, from a graph file.
   * \param[in] path the graph file (see dw::saveGraph)
   * \throws dw::GraphFileError on a corrupt, truncated or foreign file
   */
  void loadTargetGraph(const std::string& path);

  /** \brief The target's current graph (null before the first align()). */
  dw::DelaunayGraph::ConstPtr getTargetGraph() const { return walk_->getGraph(); }

  /** \brief Set the walk start strategy of the correspondence search (default PnnOptimized).
   * \param[in] strategy the start strategy
   */
  void setStartStrategy(dw::StartStrategy strategy) { estimation_->setStartStrategy(strategy); }

  /** \brief Set the number of threads of the correspondence search (0: all hardware threads).
   * \param[in] nr_threads the number of threads
   */
  void setNumberOfThreads(unsigned int nr_threads) { estimation_->setNumberOfThreads(nr_threads); }

  /** \brief Per-iteration statistics of the last align() (one entry per correspondence search). */
  const std::vector<pcl::registration::DelaunayWalkIterationStats>& getIterationStatistics() const {
    return estimation_->getStatistics();
  }

  /** \brief Seconds the last align() spent building or adopting the target graph (0 if kept). */
  double getGraphBuildSeconds() const { return build_seconds_; }

  /** \brief The shared walk search over the target. */
  const typename WalkSearch::Ptr& getSearchMethodWalk() const { return walk_; }

  /** \brief The walk correspondence estimator installed by the constructor. */
  const typename WalkEstimation::Ptr& getCorrespondenceEstimationWalk() const { return estimation_; }

 protected:
  /** \brief Prepares the target graph (timed), clears the statistics, then runs stock ICP. */
  void computeTransformation(PointCloudSource& output, const Matrix4& guess) override;

  typename WalkSearch::Ptr walk_;
  typename WalkTree::Ptr walk_tree_;
  typename WalkEstimation::Ptr estimation_;
  double build_seconds_ = 0.0;
};

}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include "pcl_delaunay_walk/registration/impl/icp_delaunay_walk.hpp"
#endif
