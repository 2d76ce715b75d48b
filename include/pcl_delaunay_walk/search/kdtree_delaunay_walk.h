/// \file kdtree_delaunay_walk.h
/// \brief pcl::search::KdTreeDelaunayWalk: a pcl::search::KdTree that answers with the Delaunay walk
/// and never builds FLANN. It exists because pcl::Registration (ICP, GICP, getFitnessScore) holds a
/// concrete KdTree<PointTarget>::Ptr; pass this with setSearchMethodTarget(tree) to put the walk there.
#pragma once

#include <pcl/search/kdtree.h>

#include "pcl_delaunay_walk/search/delaunay_walk.h"

namespace pcl {
namespace search {
namespace detail {

/** \brief The FLANN tree slot of a KdTreeDelaunayWalk. It never builds an index: it holds the point
 * representation PCL gives the tree and hands it to the walk. search::KdTree::setPointRepresentation
 * is not virtual, so a call through a KdTree pointer (pcl::Registration makes one on every align())
 * reaches only this slot; pcl::KdTree::setPointRepresentation then calls the virtual setInputCloud
 * below, which is where the walk learns of it.
 */
template <typename PointT>
class RepresentationSlot : public pcl::KdTreeFLANN<PointT> {
 public:
  using Ptr = shared_ptr<RepresentationSlot<PointT>>;
  using PointCloudConstPtr = typename pcl::KdTreeFLANN<PointT>::PointCloudConstPtr;

  /** \brief Constructor.
   * \param[in] walk the walk that receives the representation
   */
  explicit RepresentationSlot(const typename DelaunayWalk<PointT>::Ptr& walk) : walk_(walk) {}

  /** \brief Remember the tree's cloud without building anything (so that a later
   * setPointRepresentation re-enters setInputCloud below). */
  void attach(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices) {
    this->input_ = cloud;
    this->indices_ = indices;
  }

  /** \brief Reached from setPointRepresentation once a cloud is attached: the walk takes the
   * representation (rebuilding only if the represented coordinates change). */
  void setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices) override {
    attach(cloud, indices);
    walk_->setInputCloud(cloud, indices, this->getPointRepresentation());
  }

 private:
  typename DelaunayWalk<PointT>::Ptr walk_;
};

}  // namespace detail

/** \brief A KdTree whose queries are answered exactly by a DelaunayWalk search (no FLANN index).
 *
 * Everything a KdTree user calls works: setInputCloud (content-checked, so re-setting an unchanged
 * target keeps the graph), every nearestKSearch/radiusSearch overload, and setPointRepresentation,
 * also through a KdTree pointer (as pcl::Registration calls it): the walk takes the representation as
 * described in DelaunayWalk. Epsilon is accepted and has no effect: the walk is always exact.
 * Several objects (e.g. this tree and a CorrespondenceEstimationDelaunayWalk) may share one walk.
 */
template <typename PointT>
class KdTreeDelaunayWalk : public KdTree<PointT> {
 public:
  using PointCloud = typename KdTree<PointT>::PointCloud;
  using PointCloudConstPtr = typename KdTree<PointT>::PointCloudConstPtr;
  using Ptr = shared_ptr<KdTreeDelaunayWalk<PointT>>;
  using ConstPtr = shared_ptr<const KdTreeDelaunayWalk<PointT>>;
  using WalkPtr = typename DelaunayWalk<PointT>::Ptr;
  using PointRepresentationConstPtr = typename KdTree<PointT>::PointRepresentationConstPtr;

  using KdTree<PointT>::input_;
  using KdTree<PointT>::indices_;
  using KdTree<PointT>::nearestKSearch;
  using KdTree<PointT>::radiusSearch;

  /** \brief Constructor with its own walk search.
   * \param[in] sorted kept for compatibility; results are always sorted
   */
  explicit KdTreeDelaunayWalk(bool sorted = true);

  /** \brief Constructor that shares an existing walk search (and its graph).
   * \param[in] walk the walk search to answer with (must not be null)
   */
  explicit KdTreeDelaunayWalk(const WalkPtr& walk);

  ~KdTreeDelaunayWalk() override = default;

  /** \brief The walk search that answers the queries. */
  const WalkPtr& getDelaunayWalk() const { return walk_; }

  /** \brief Set the reference cloud: builds (or keeps) the walk graph; no FLANN index is built.
   * \param[in] cloud the reference cloud
   * \param[in] indices optional subset; results are indices into \a cloud
   */
  void setInputCloud(const PointCloudConstPtr& cloud,
                     const IndicesConstPtr& indices = IndicesConstPtr()) override;

  /** \brief Set the point representation (see DelaunayWalk::setPointRepresentation); a call through
   * a pcl::search::KdTree pointer has the same effect.
   * \param[in] representation the representation
   */
  void setPointRepresentation(const PointRepresentationConstPtr& representation);

  /** \brief Set where walks start (see DelaunayWalk::setStartStrategy).
   * \param[in] strategy the start strategy
   */
  void setStartStrategy(dw::StartStrategy strategy) { walk_->setStartStrategy(strategy); }

  /** \brief k nearest neighbours of a point (see DelaunayWalk).
   * \param[in] point the query point
   * \param[in] k the number of neighbours
   * \param[out] k_indices indices into the input cloud, nearest first
   * \param[out] k_sqr_distances squared distances, ascending
   * \return the number of neighbours found
   */
  int nearestKSearch(const PointT& point, int k, Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override {
    return walk_->nearestKSearch(point, k, k_indices, k_sqr_distances);
  }

  /** \brief k nearest neighbours of the input point at \a index (walk starts at its own vertex).
   * \param[in] index position in the input cloud (or in the indices)
   * \param[in] k the number of neighbours
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \return the number of neighbours found
   */
  int nearestKSearch(index_t index, int k, Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override {
    return walk_->nearestKSearch(index, k, k_indices, k_sqr_distances);
  }

  /** \brief k nearest neighbours of cloud[index].
   * \param[in] cloud the cloud holding the query point
   * \param[in] index its index
   * \param[in] k the number of neighbours
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \return the number of neighbours found
   */
  int nearestKSearch(const PointCloud& cloud, index_t index, int k, Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override {
    return walk_->nearestKSearch(cloud, index, k, k_indices, k_sqr_distances);
  }

  /** \brief Neighbours with squared distance < radius^2.
   * \param[in] point the query point
   * \param[in] radius the search radius
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \param[in] max_nn if > 0, only the max_nn nearest
   * \return the number of neighbours found
   */
  int radiusSearch(const PointT& point, double radius, Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override {
    return walk_->radiusSearch(point, radius, k_indices, k_sqr_distances, max_nn);
  }

  /** \brief Radius search around the input point at \a index.
   * \param[in] index position in the input cloud (or in the indices)
   * \param[in] radius the search radius
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \param[in] max_nn if > 0, only the max_nn nearest
   * \return the number of neighbours found
   */
  int radiusSearch(index_t index, double radius, Indices& k_indices, std::vector<float>& k_sqr_distances,
                   unsigned int max_nn = 0) const override {
    return walk_->radiusSearch(index, radius, k_indices, k_sqr_distances, max_nn);
  }

  /** \brief Radius search around cloud[index].
   * \param[in] cloud the cloud holding the query point
   * \param[in] index its index
   * \param[in] radius the search radius
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \param[in] max_nn if > 0, only the max_nn nearest
   * \return the number of neighbours found
   */
  int radiusSearch(const PointCloud& cloud, index_t index, double radius, Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override {
    return walk_->radiusSearch(cloud, index, radius, k_indices, k_sqr_distances, max_nn);
  }

 protected:
  WalkPtr walk_;
};

}  // namespace search
}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include "pcl_delaunay_walk/search/impl/kdtree_delaunay_walk.hpp"
#endif
