/// \file delaunay_walk.h
/// \brief pcl::search::DelaunayWalk: an exact pcl::search::Search backend that answers nearest,
/// k-nearest and radius queries by walking the Delaunay graph of the input cloud (Anderson et al.
/// 2022), with results identical to pcl::search::KdTree up to exact ties.
#pragma once

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_representation.h>
#include <pcl/search/search.h>

#include <cstdint>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/caller_metric_search.h"
#include "pcl_delaunay_walk/core/search/start_strategy.h"

namespace pcl {
namespace search {

/** \brief Exact neighbour search by the Delaunay walk.
 *
 * A drop-in for pcl::search::KdTree in any PCL algorithm that takes a Search::Ptr
 * (NormalEstimation, NormalEstimationOMP, EuclideanClusterExtraction, ...). Results follow
 * KdTreeFLANN's conventions: indices into the original cloud (also when an indices subset is given),
 * squared distances computed from the cloud's float coordinates, ascending order (ties by ascending
 * index), k clamped to the number of finite points, radius membership strict (d^2 < r^2), max_nn = 0
 * meaning no limit. NaN points of the cloud are never returned; a NaN query, k <= 0, or a negative
 * radius return 0 neighbours. Queries are const and safe from many threads at once.
 *
 * The graph is rebuilt only when the cloud's coordinates (or the indices) change: setting the same
 * content again, as pcl::Registration does on every align(), costs one comparison. A graph can also be
 * adopted ready-made (setInputCloudAndGraph) or loaded from a file (loadGraph); it is then checked
 * against the cloud point by point.
 *
 * A pcl::PointRepresentation (setPointRepresentation) is honoured as KdTreeFLANN honours it: the
 * search space is the representation's (rescaled) vector, and the distances are FLANN's in that
 * space. The route depends on its dimension (getRepresentationRoute()):
 *  - none, or a trivial 3-D one (x, y, z): the graph of x, y, z, as without a representation;
 *  - 1 to 3 dimensions otherwise: the graph of the represented coordinates (padded with zeros to 3-D,
 *    which adds nothing to any distance), walked exactly as x, y, z;
 *  - more than 3: the walk cannot search it, so an internal pcl::KdTreeFLANN with the same
 *    representation and epsilon 0 answers (exact; a one-time PCL_WARN names the reason).
 */
template <typename PointT>
class DelaunayWalk : public Search<PointT> {
 public:
  using PointCloud = typename Search<PointT>::PointCloud;
  using PointCloudConstPtr = typename Search<PointT>::PointCloudConstPtr;
  using Ptr = shared_ptr<DelaunayWalk<PointT>>;
  using ConstPtr = shared_ptr<const DelaunayWalk<PointT>>;
  using PointRepresentationConstPtr = typename PointRepresentation<PointT>::ConstPtr;
  using FallbackTree = pcl::KdTreeFLANN<PointT>;

  /** \brief How queries are answered under the current point representation (see the class). */
  enum class RepresentationRoute {
    Xyz,            ///< the graph of x, y, z (no representation, or a trivial 3-D one)
    Represented,    ///< the graph of the represented coordinates (1 to 3 dimensions)
    KdTreeFallback  ///< more than 3 dimensions: an internal exact pcl::KdTreeFLANN
  };

  using Search<PointT>::indices_;
  using Search<PointT>::input_;
  using Search<PointT>::getIndices;
  using Search<PointT>::getInputCloud;
  using Search<PointT>::nearestKSearch;
  using Search<PointT>::radiusSearch;
  using Search<PointT>::sorted_results_;

  /** \brief Constructor.
   * \param[in] sorted kept for interface compatibility: results are always sorted (exactness needs it)
   */
  explicit DelaunayWalk(bool sorted = true);
  ~DelaunayWalk() override = default;

  /** \brief Set the reference cloud; builds its Delaunay graph unless the content is unchanged or a
   * graph given with setGraph() matches it.
   * \param[in] cloud the reference cloud (must not be null)
   * \param[in] indices optional subset; results are still indices into \a cloud
   * \throws dw::Error on a null cloud, out-of-range indices, or a pending graph that does not match
   */
  void setInputCloud(const PointCloudConstPtr& cloud,
                     const IndicesConstPtr& indices = IndicesConstPtr()) override;

  /** \brief setInputCloud and setPointRepresentation in one step: one build, and nothing changes if
   * it throws.
   * \param[in] cloud the reference cloud (must not be null)
   * \param[in] indices optional subset
   * \param[in] representation the point representation (null: x, y, z)
   */
  void setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices,
                     const PointRepresentationConstPtr& representation);

  /** \brief Set the point representation the search space is made of, as KdTreeFLANN's. With an input
   * cloud already set, the search is rebuilt for it (unless the represented coordinates are unchanged).
   * \param[in] representation the representation (null: x, y, z)
   * \throws dw::Error for a representation of no dimensions
   */
  void setPointRepresentation(const PointRepresentationConstPtr& representation);

  /** \brief The point representation in use (null when none was set: x, y, z). */
  PointRepresentationConstPtr getPointRepresentation() const { return representation_; }

  /** \brief How queries are answered under the current representation (see the class). */
  RepresentationRoute getRepresentationRoute() const { return route_; }

  /** \brief The route a representation would take (null: Xyz).
   * \param[in] representation the representation
   * \throws dw::Error for a representation of no dimensions
   */
  static RepresentationRoute routeOf(const PointRepresentationConstPtr& representation);

  /** \brief The query's coordinates in the graph's space: x, y, z, or the represented coordinates
   * padded with zeros (Represented route). Not meaningful for the KdTreeFallback route.
   * \param[in] point the query point
   * \param[out] q its three coordinates in the graph's space
   */
  void graphCoordinates(const PointT& point, float q[3]) const {
    if (route_ == RepresentationRoute::Xyz) {
      q[0] = point.x;
      q[1] = point.y;
      q[2] = point.z;
      return;
    }
    q[0] = q[1] = q[2] = 0.f;
    representation_->vectorize(point, q);
  }

  /** \brief The internal k-d tree of the KdTreeFallback route (null on the graph routes). */
  const typename FallbackTree::ConstPtr& getFallbackTree() const { return fallback_; }

  /** \brief Set the reference cloud together with a prebuilt graph of it (no build).
   * \param[in] cloud the reference cloud
   * \param[in] graph a graph built from exactly \a cloud (or its \a indices subset, in that order)
   * \param[in] indices optional subset
   * \throws dw::Error if the graph is invalid or was built from other points
   */
  void setInputCloudAndGraph(const PointCloudConstPtr& cloud, dw::DelaunayGraph::ConstPtr graph,
                             const IndicesConstPtr& indices = IndicesConstPtr());

  /** \brief Offer a prebuilt graph for the next setInputCloud(): it is adopted if it matches that
   * cloud and an error is raised if not. For localisation against a fixed map.
   * \param[in] graph the graph (null withdraws a pending one)
   */
  void setGraph(dw::DelaunayGraph::ConstPtr graph);

  /** \brief Load a graph file (see dw::saveGraph) and offer it like setGraph().
   * \param[in] path the graph file
   * \throws dw::GraphFileError on a corrupt, truncated or foreign file
   */
  void loadGraph(const std::string& path);

  /** \brief Save the current graph to a file.
   * \param[in] path output file
   * \throws dw::Error when there is no graph yet or on I/O failure
   */
  void saveGraph(const std::string& path) const;

  /** \brief The current graph (null before setInputCloud and on the KdTreeFallback route). */
  dw::DelaunayGraph::ConstPtr getGraph() const;

  /** \brief The exact query engine over the current graph (null before setInputCloud and on the
   * KdTreeFallback route). */
  dw::CallerMetricSearch::ConstPtr getCallerMetricSearch() const { return query_; }

  /** \brief Set where walks start: Zero, KdAnn (default), Pnn or PnnOptimized. With Pnn the hint is
   * the previous query's nearest vertex on the same thread (good for coherent query sequences); the
   * index forms of the queries always start at the query point's own vertex.
   * \param[in] strategy the start strategy
   */
  void setStartStrategy(dw::StartStrategy strategy) { strategy_ = strategy; }

  /** \brief Get the start strategy. */
  dw::StartStrategy getStartStrategy() const { return strategy_; }

  /** \brief Set the options used when a graph has to be built (builder, threads, progress).
   * \param[in] options the build options
   */
  void setBuildOptions(const dw::BuildOptions& options) { build_options_ = options; }

  /** \brief Get the build options. */
  const dw::BuildOptions& getBuildOptions() const { return build_options_; }

  /** \brief Seconds spent building (or adopting) the graph in the last setInputCloud; 0 if reused. */
  double getLastBuildSeconds() const { return last_build_seconds_; }

  /** \brief Number of graphs built (not reused) by this object so far. */
  std::size_t getNumberOfBuilds() const { return num_builds_; }

  /** \brief Search for the k nearest neighbours of a point.
   * \param[in] point the query point
   * \param[in] k the number of neighbours (clamped to the number of finite points)
   * \param[out] k_indices indices into the input cloud, nearest first
   * \param[out] k_sqr_distances squared distances, ascending
   * \return the number of neighbours found
   */
  int nearestKSearch(const PointT& point, int k, Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override;

  /** \brief k nearest neighbours of the point at \a index of the input (of the indices, if given);
   * the walk starts at that point's own vertex.
   * \param[in] index position in the input cloud, or in the indices when a subset was given
   * \param[in] k the number of neighbours
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \return the number of neighbours found (0 for an out-of-range index)
   */
  int nearestKSearch(index_t index, int k, Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override;

  /** \brief k nearest neighbours of cloud[index].
   * \param[in] cloud the cloud holding the query point
   * \param[in] index its index in \a cloud
   * \param[in] k the number of neighbours
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \return the number of neighbours found
   */
  int nearestKSearch(const PointCloud& cloud, index_t index, int k, Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override;

  /** \brief All neighbours with squared distance < radius^2.
   * \param[in] point the query point
   * \param[in] radius the search radius
   * \param[out] k_indices indices into the input cloud, nearest first
   * \param[out] k_sqr_distances squared distances, ascending
   * \param[in] max_nn if > 0, return only the max_nn nearest
   * \return the number of neighbours found
   */
  int radiusSearch(const PointT& point, double radius, Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override;

  /** \brief Radius search around the point at \a index (see the index form of nearestKSearch).
   * \param[in] index position in the input cloud, or in the indices when a subset was given
   * \param[in] radius the search radius
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \param[in] max_nn if > 0, return only the max_nn nearest
   * \return the number of neighbours found
   */
  int radiusSearch(index_t index, double radius, Indices& k_indices, std::vector<float>& k_sqr_distances,
                   unsigned int max_nn = 0) const override;

  /** \brief Radius search around cloud[index].
   * \param[in] cloud the cloud holding the query point
   * \param[in] index its index in \a cloud
   * \param[in] radius the search radius
   * \param[out] k_indices indices into the input cloud
   * \param[out] k_sqr_distances squared distances
   * \param[in] max_nn if > 0, return only the max_nn nearest
   * \return the number of neighbours found
   */
  int radiusSearch(const PointCloud& cloud, index_t index, double radius, Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override;

 protected:
  /** \brief Query with an explicit start vertex hint (kInvalidIndex: per strategy). */
  int knnFrom(const float q[3], int k, dw::StartStrategy strategy, dw::index_t hint, Indices& k_indices,
              std::vector<float>& k_sqr_distances) const;
  int radiusFrom(const float q[3], double radius, unsigned int max_nn, dw::StartStrategy strategy,
                 dw::index_t hint, Indices& k_indices, std::vector<float>& k_sqr_distances) const;
  /** \brief Graph input of cloud index \a index of the input cloud, or -1. */
  std::int64_t inputOfCloudIndex(index_t index) const;
  /** \brief Strategy and hint for a point query (the thread's previous answer for Pnn). */
  dw::index_t sequenceHint() const;
  void rememberHint(dw::index_t vertex) const;
  const dw::CallerMetricSearch& query() const;
  /** \brief The KdTreeFallback route's setInputCloud. */
  void setFallbackInput(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices,
                        const PointRepresentationConstPtr& representation);
  /** \brief The KdTreeFallback route's queries, with the walk's conventions for degenerate input. */
  int fallbackKnn(const PointT& point, int k, Indices& k_indices, std::vector<float>& k_sqr_distances) const;
  int fallbackRadius(const PointT& point, double radius, Indices& k_indices,
                     std::vector<float>& k_sqr_distances, unsigned int max_nn) const;
  /** \brief The input point at position \a index (of the subset, if any), or null if out of range. */
  const PointT* fallbackPointAt(index_t index) const;
  /** \brief Whether the KdTreeFallback route answers, and has points to answer from. */
  bool fallbackAnswers() const { return fallback_ && fallback_points_ > 0; }

  dw::CallerMetricSearch::ConstPtr query_;
  PointRepresentationConstPtr representation_;
  RepresentationRoute route_ = RepresentationRoute::Xyz;
  typename FallbackTree::ConstPtr fallback_;
  std::vector<float> fallback_content_;  ///< the represented vectors the fallback tree was built on
  std::size_t fallback_points_ = 0;      ///< valid points in the fallback tree
  bool fallback_warned_ = false;
  dw::DelaunayGraph::ConstPtr pending_graph_;
  std::vector<std::int32_t> cloud_to_input_;  ///< only with an indices subset; -1 = not in it
  dw::StartStrategy strategy_ = dw::StartStrategy::KdAnn;
  dw::BuildOptions build_options_;
  double last_build_seconds_ = 0.0;
  std::size_t num_builds_ = 0;
};

}  // namespace search
}  // namespace pcl

#ifdef PCL_NO_PRECOMPILE
#include "pcl_delaunay_walk/search/impl/delaunay_walk.hpp"
#endif
