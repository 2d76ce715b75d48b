/// \file impl/delaunay_walk.hpp
/// \brief Template definitions of pcl::search::DelaunayWalk (explicitly instantiated in
/// src/search/delaunay_walk.cpp; include with PCL_NO_PRECOMPILE for other point types).
#pragma once

#include <chrono>
#include <cstring>
#include <type_traits>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

namespace pcl {
namespace search {
namespace detail {

/// Throws unless every index of the subset lies in the cloud.
template <typename PointT>
void checkIndices(const pcl::PointCloud<PointT>& cloud, const pcl::Indices& indices) {
  for (std::size_t i = 0; i < indices.size(); ++i)
    if (indices[i] < 0 || static_cast<std::size_t>(indices[i]) >= cloud.size())
      throw dw::Error("pcl::search::DelaunayWalk: index " + std::to_string(indices[i]) + " at position " +
                      std::to_string(i) + " is outside the cloud of " + std::to_string(cloud.size()) +
                      " points");
}

/// The coordinates the graph is built on, 3 floats per point of the cloud (or of its subset, in
/// subset order): x, y, z, or the representation's vector padded with zeros; and the subset's cloud
/// indices.
template <typename PointT>
void gatherXyz(const pcl::PointCloud<PointT>& cloud, const pcl::Indices* indices,
               const pcl::PointRepresentation<PointT>* representation, std::vector<float>& xyz,
               std::vector<std::int32_t>& input_to_cloud) {
  static_assert(sizeof(pcl::index_t) <= sizeof(std::int32_t) || std::is_signed<pcl::index_t>::value,
                "pcl_delaunay_walk supports PCL's default 32-bit index_t");
  const std::size_t n = indices ? indices->size() : cloud.size();
  if (n >= static_cast<std::size_t>(INT32_MAX))
    throw dw::Error("pcl::search::DelaunayWalk: clouds of 2^31 points or more are not supported");
  if (indices) checkIndices(cloud, *indices);
  xyz.resize(3 * n);
  input_to_cloud.clear();
  if (indices) input_to_cloud.assign(indices->begin(), indices->end());
  for (std::size_t i = 0; i < n; ++i) {
    const PointT& p = cloud[indices ? static_cast<std::size_t>((*indices)[i]) : i];
    float* out = &xyz[3 * i];
    if (!representation) {
      out[0] = p.x;
      out[1] = p.y;
      out[2] = p.z;
      continue;
    }
    float v[3] = {0.f, 0.f, 0.f};  // unused dimensions stay 0: they add nothing to any distance
    representation->vectorize(p, v);
    std::copy(v, v + 3, out);
  }
}

/// Bitwise equality (NaN-safe): the graph is reused only for exactly the same coordinates.
inline bool sameContent(const dw::CallerMetricSearch& q, const std::vector<float>& xyz,
                        const std::vector<std::int32_t>& input_to_cloud) {
  return q.inputXyz().size() == xyz.size() && q.inputToCloud() == input_to_cloud &&
         (xyz.empty() || std::memcmp(q.inputXyz().data(), xyz.data(), xyz.size() * sizeof(float)) == 0);
}

}  // namespace detail

template <typename PointT>
DelaunayWalk<PointT>::DelaunayWalk(bool sorted) : Search<PointT>("DelaunayWalk", sorted) {}

template <typename PointT>
typename DelaunayWalk<PointT>::RepresentationRoute DelaunayWalk<PointT>::routeOf(
    const PointRepresentationConstPtr& representation) {
  if (!representation) return RepresentationRoute::Xyz;
  const int dims = representation->getNumberOfDimensions();
  if (dims <= 0)
    throw dw::Error("pcl::search::DelaunayWalk: the point representation has " + std::to_string(dims) +
                    " dimensions");
  // Trivial: vectorize() copies the point's first floats unscaled, and every xyz type starts x, y, z.
  if (dims == 3 && representation->isTrivial()) return RepresentationRoute::Xyz;
  return dims <= 3 ? RepresentationRoute::Represented : RepresentationRoute::KdTreeFallback;
}

template <typename PointT>
void DelaunayWalk<PointT>::setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices) {
  setInputCloud(cloud, indices, representation_);
}

template <typename PointT>
void DelaunayWalk<PointT>::setPointRepresentation(const PointRepresentationConstPtr& representation) {
  if (input_)
    setInputCloud(input_, indices_, representation);
  else {
    route_ = routeOf(representation);
    representation_ = representation;
  }
}

template <typename PointT>
void DelaunayWalk<PointT>::setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices,
                                         const PointRepresentationConstPtr& representation) {
  if (!cloud) throw dw::Error("pcl::search::DelaunayWalk::setInputCloud: null cloud");
  const RepresentationRoute route = routeOf(representation);
  if (route == RepresentationRoute::KdTreeFallback) {
    setFallbackInput(cloud, indices, representation);
    return;
  }
  std::vector<float> xyz;
  std::vector<std::int32_t> map;
  detail::gatherXyz(*cloud, indices.get(), route == RepresentationRoute::Xyz ? nullptr : representation.get(),
                    xyz, map);
  const auto t0 = std::chrono::steady_clock::now();
  dw::CallerMetricSearch::ConstPtr q;
  if (pending_graph_) {
    dw::CallerMetricSearch::checkGraphMatches(*pending_graph_, xyz);
    q = std::make_shared<const dw::CallerMetricSearch>(pending_graph_, std::move(xyz), std::move(map));
  } else if (query_ && detail::sameContent(*query_, xyz, map)) {
    q = query_;  // PCL re-sets unchanged targets (every Registration::align()): keep the graph
  } else {
    auto graph = std::make_shared<const dw::DelaunayGraph>(
        dw::buildDelaunayGraph(dw::PointView::fromFloat(xyz.data(), xyz.size() / 3), build_options_));
    q = std::make_shared<const dw::CallerMetricSearch>(std::move(graph), std::move(xyz), std::move(map));
    ++num_builds_;
  }
  const bool reused = q == query_;
  std::vector<std::int32_t> cloud_to_input;
  if (indices) {
    cloud_to_input.assign(cloud->size(), -1);
    for (std::size_t i = 0; i < indices->size(); ++i)
      if (cloud_to_input[(*indices)[i]] < 0) cloud_to_input[(*indices)[i]] = static_cast<std::int32_t>(i);
  }
  // Commit only after everything that can throw.
  last_build_seconds_ =
      reused ? 0.0 : std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  pending_graph_.reset();
  query_ = std::move(q);
  cloud_to_input_ = std::move(cloud_to_input);
  fallback_.reset();
  fallback_content_.clear();
  fallback_points_ = 0;
  representation_ = representation;
  route_ = route;
  input_ = cloud;
  indices_ = indices;
}

template <typename PointT>
void DelaunayWalk<PointT>::setFallbackInput(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices,
                                            const PointRepresentationConstPtr& representation) {
  const int dims = representation->getNumberOfDimensions();
  if (pending_graph_)
    throw dw::Error(
        "pcl::search::DelaunayWalk: a prebuilt graph cannot answer for a point representation of " +
        std::to_string(dims) + " dimensions (the walk searches at most 3)");
  if (indices) detail::checkIndices(*cloud, *indices);
  // The represented vectors decide whether the tree can be kept, as the coordinates do for a graph.
  const std::size_t n = indices ? indices->size() : cloud->size();
  std::vector<float> content(static_cast<std::size_t>(dims) * n + n);
  std::size_t valid = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const PointT& p = (*cloud)[indices ? static_cast<std::size_t>((*indices)[i]) : i];
    float* out = &content[static_cast<std::size_t>(dims) * i];
    representation->vectorize(p, out);
    const bool ok = representation->isValid(p);
    content[static_cast<std::size_t>(dims) * n + i] = ok ? 1.f : 0.f;
    valid += ok ? 1 : 0;
  }
  if (indices)
    for (const auto idx : *indices) content.push_back(static_cast<float>(idx));
  const auto t0 = std::chrono::steady_clock::now();
  typename FallbackTree::ConstPtr tree = fallback_;
  const bool reused =
      tree && fallback_content_.size() == content.size() &&
      std::memcmp(fallback_content_.data(), content.data(), content.size() * sizeof(float)) == 0;
  if (!reused) {
    auto built = pcl::make_shared<FallbackTree>(true);
    built->setEpsilon(0.f);  // exact, whatever epsilon the caller gave a KdTree
    built->setPointRepresentation(representation);
    if (valid > 0) built->setInputCloud(cloud, indices);
    tree = built;
    ++num_builds_;
  }
  if (!fallback_warned_) {
    PCL_WARN(
        "[pcl::search::DelaunayWalk] the point representation has %d dimensions and the Delaunay walk "
        "searches at most 3; queries are answered exactly by an internal pcl::KdTreeFLANN with the "
        "same representation instead.\n",
        dims);
    fallback_warned_ = true;
  }
  last_build_seconds_ =
      reused ? 0.0 : std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  query_.reset();
  cloud_to_input_.clear();
  fallback_ = std::move(tree);
  fallback_content_ = std::move(content);
  fallback_points_ = valid;
  representation_ = representation;
  route_ = RepresentationRoute::KdTreeFallback;
  input_ = cloud;
  indices_ = indices;
}

template <typename PointT>
void DelaunayWalk<PointT>::setInputCloudAndGraph(const PointCloudConstPtr& cloud,
                                                 dw::DelaunayGraph::ConstPtr graph,
                                                 const IndicesConstPtr& indices) {
  if (!graph) throw dw::Error("pcl::search::DelaunayWalk::setInputCloudAndGraph: null graph");
  graph->validate();
  const auto saved = pending_graph_;
  pending_graph_ = std::move(graph);
  try {
    setInputCloud(cloud, indices);
  } catch (...) {
    pending_graph_ = saved;
    throw;
  }
}

template <typename PointT>
void DelaunayWalk<PointT>::setGraph(dw::DelaunayGraph::ConstPtr graph) {
  if (graph) graph->validate();
  pending_graph_ = std::move(graph);
}

template <typename PointT>
void DelaunayWalk<PointT>::loadGraph(const std::string& path) {
  pending_graph_ = std::make_shared<const dw::DelaunayGraph>(dw::loadGraph(path));
}

template <typename PointT>
void DelaunayWalk<PointT>::saveGraph(const std::string& path) const {
  dw::saveGraph(query().graph(), path);
}

template <typename PointT>
dw::DelaunayGraph::ConstPtr DelaunayWalk<PointT>::getGraph() const {
  return query_ ? query_->graphPtr() : dw::DelaunayGraph::ConstPtr();
}

template <typename PointT>
const dw::CallerMetricSearch& DelaunayWalk<PointT>::query() const {
  if (!query_) throw dw::Error("pcl::search::DelaunayWalk: no input cloud (call setInputCloud first)");
  return *query_;
}

namespace detail {
/// The previous query's nearest vertex on this thread, tagged with the graph it belongs to.
struct SequenceHint {
  std::uint64_t query_id = 0;
  dw::index_t vertex = dw::kInvalidIndex;
  static SequenceHint& get() {
    thread_local SequenceHint h;
    return h;
  }
};

inline void toPcl(const std::vector<dw::WalkNeighbour>& r, Indices& k_indices,
                  std::vector<float>& k_sqr_distances) {
  k_indices.resize(r.size());
  k_sqr_distances.resize(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    k_indices[i] = r[i].index;
    k_sqr_distances[i] = r[i].sqr_distance;
  }
}

inline std::vector<dw::WalkNeighbour>& resultScratch() {
  thread_local std::vector<dw::WalkNeighbour> r;
  return r;
}
}  // namespace detail

template <typename PointT>
dw::index_t DelaunayWalk<PointT>::sequenceHint() const {
  if (strategy_ != dw::StartStrategy::Pnn && strategy_ != dw::StartStrategy::PnnOptimized)
    return dw::kInvalidIndex;
  const auto& h = detail::SequenceHint::get();
  return h.query_id == query_->id() ? h.vertex : dw::kInvalidIndex;
}

template <typename PointT>
void DelaunayWalk<PointT>::rememberHint(dw::index_t vertex) const {
  if (strategy_ != dw::StartStrategy::Pnn && strategy_ != dw::StartStrategy::PnnOptimized) return;
  auto& h = detail::SequenceHint::get();
  h.query_id = query_->id();
  h.vertex = vertex;
}

template <typename PointT>
int DelaunayWalk<PointT>::knnFrom(const float q[3], int k, dw::StartStrategy strategy, dw::index_t hint,
                                  Indices& k_indices, std::vector<float>& k_sqr_distances) const {
  const dw::CallerMetricSearch& wq = query();
  auto& r = detail::resultScratch();
  dw::CallerMetricSearchStats stats;
  if (k > 0)
    wq.knn(q, static_cast<std::size_t>(k), strategy, hint, r, &stats);
  else
    r.clear();
  if (!r.empty()) rememberHint(stats.nn_vertex);
  detail::toPcl(r, k_indices, k_sqr_distances);
  return static_cast<int>(r.size());
}

template <typename PointT>
int DelaunayWalk<PointT>::radiusFrom(const float q[3], double radius, unsigned int max_nn,
                                     dw::StartStrategy strategy, dw::index_t hint, Indices& k_indices,
                                     std::vector<float>& k_sqr_distances) const {
  const dw::CallerMetricSearch& wq = query();
  auto& r = detail::resultScratch();
  dw::CallerMetricSearchStats stats;
  wq.radius(q, radius, max_nn, strategy, hint, r, &stats);
  if (stats.nn_vertex != dw::kInvalidIndex) rememberHint(stats.nn_vertex);
  detail::toPcl(r, k_indices, k_sqr_distances);
  return static_cast<int>(r.size());
}

template <typename PointT>
int DelaunayWalk<PointT>::fallbackKnn(const PointT& point, int k, Indices& k_indices,
                                      std::vector<float>& k_sqr_distances) const {
  if (!fallback_) query();  // the same clear error as the graph routes
  k_indices.clear();
  k_sqr_distances.clear();
  // FLANN asserts on these; the walk's conventions (0 results) hold on every route.
  if (k <= 0 || !fallbackAnswers() || !representation_->isValid(point)) return 0;
  return fallback_->nearestKSearch(point, k, k_indices, k_sqr_distances);
}

template <typename PointT>
int DelaunayWalk<PointT>::fallbackRadius(const PointT& point, double radius, Indices& k_indices,
                                         std::vector<float>& k_sqr_distances, unsigned int max_nn) const {
  if (!fallback_) query();
  k_indices.clear();
  k_sqr_distances.clear();
  if (!(radius >= 0.0) || !fallbackAnswers() || !representation_->isValid(point)) return 0;
  return fallback_->radiusSearch(point, radius, k_indices, k_sqr_distances, max_nn);
}

template <typename PointT>
const PointT* DelaunayWalk<PointT>::fallbackPointAt(index_t index) const {
  if (!fallback_) query();
  const std::size_t n = indices_ ? indices_->size() : input_->size();
  if (index < 0 || static_cast<std::size_t>(index) >= n) return nullptr;
  return &(
      *input_)[indices_ ? static_cast<std::size_t>((*indices_)[index]) : static_cast<std::size_t>(index)];
}

template <typename PointT>
int DelaunayWalk<PointT>::nearestKSearch(const PointT& point, int k, Indices& k_indices,
                                         std::vector<float>& k_sqr_distances) const {
  if (route_ == RepresentationRoute::KdTreeFallback) return fallbackKnn(point, k, k_indices, k_sqr_distances);
  float q[3];
  graphCoordinates(point, q);
  query();  // a clear error before any hint lookup
  return knnFrom(q, k, strategy_, sequenceHint(), k_indices, k_sqr_distances);
}

template <typename PointT>
std::int64_t DelaunayWalk<PointT>::inputOfCloudIndex(index_t index) const {
  if (index < 0) return -1;
  if (!indices_) return static_cast<std::size_t>(index) < query().numInputs() ? index : -1;
  return static_cast<std::size_t>(index) < cloud_to_input_.size() ? cloud_to_input_[index] : -1;
}

template <typename PointT>
int DelaunayWalk<PointT>::nearestKSearch(index_t index, int k, Indices& k_indices,
                                         std::vector<float>& k_sqr_distances) const {
  if (route_ == RepresentationRoute::KdTreeFallback) {
    const PointT* p = fallbackPointAt(index);
    if (p) return fallbackKnn(*p, k, k_indices, k_sqr_distances);
    k_indices.clear();
    k_sqr_distances.clear();
    return 0;
  }
  const dw::CallerMetricSearch& wq = query();
  if (index < 0 || static_cast<std::size_t>(index) >= wq.numInputs()) {
    k_indices.clear();
    k_sqr_distances.clear();
    return 0;
  }
  // The query is a reference point: its own vertex is the exact nearest, so the walk makes no move.
  const std::size_t input = static_cast<std::size_t>(index);
  return knnFrom(&wq.inputXyz()[3 * input], k, dw::StartStrategy::Pnn, wq.vertexOfInput(input), k_indices,
                 k_sqr_distances);
}

template <typename PointT>
int DelaunayWalk<PointT>::nearestKSearch(const PointCloud& cloud, index_t index, int k, Indices& k_indices,
                                         std::vector<float>& k_sqr_distances) const {
  if (index < 0 || static_cast<std::size_t>(index) >= cloud.size()) {
    k_indices.clear();
    k_sqr_distances.clear();
    return 0;
  }
  if (&cloud == input_.get() && route_ != RepresentationRoute::KdTreeFallback) {
    const std::int64_t input = inputOfCloudIndex(index);
    if (input >= 0) return nearestKSearch(static_cast<index_t>(input), k, k_indices, k_sqr_distances);
  }
  return nearestKSearch(cloud[index], k, k_indices, k_sqr_distances);
}

template <typename PointT>
int DelaunayWalk<PointT>::radiusSearch(const PointT& point, double radius, Indices& k_indices,
                                       std::vector<float>& k_sqr_distances, unsigned int max_nn) const {
  if (route_ == RepresentationRoute::KdTreeFallback)
    return fallbackRadius(point, radius, k_indices, k_sqr_distances, max_nn);
  float q[3];
  graphCoordinates(point, q);
  query();
  return radiusFrom(q, radius, max_nn, strategy_, sequenceHint(), k_indices, k_sqr_distances);
}

template <typename PointT>
int DelaunayWalk<PointT>::radiusSearch(index_t index, double radius, Indices& k_indices,
                                       std::vector<float>& k_sqr_distances, unsigned int max_nn) const {
  if (route_ == RepresentationRoute::KdTreeFallback) {
    const PointT* p = fallbackPointAt(index);
    if (p) return fallbackRadius(*p, radius, k_indices, k_sqr_distances, max_nn);
    k_indices.clear();
    k_sqr_distances.clear();
    return 0;
  }
  const dw::CallerMetricSearch& wq = query();
  if (index < 0 || static_cast<std::size_t>(index) >= wq.numInputs()) {
    k_indices.clear();
    k_sqr_distances.clear();
    return 0;
  }
  const std::size_t input = static_cast<std::size_t>(index);
  return radiusFrom(&wq.inputXyz()[3 * input], radius, max_nn, dw::StartStrategy::Pnn,
                    wq.vertexOfInput(input), k_indices, k_sqr_distances);
}

template <typename PointT>
int DelaunayWalk<PointT>::radiusSearch(const PointCloud& cloud, index_t index, double radius,
                                       Indices& k_indices, std::vector<float>& k_sqr_distances,
                                       unsigned int max_nn) const {
  if (index < 0 || static_cast<std::size_t>(index) >= cloud.size()) {
    k_indices.clear();
    k_sqr_distances.clear();
    return 0;
  }
  if (&cloud == input_.get() && route_ != RepresentationRoute::KdTreeFallback) {
    const std::int64_t input = inputOfCloudIndex(index);
    if (input >= 0)
      return radiusSearch(static_cast<index_t>(input), radius, k_indices, k_sqr_distances, max_nn);
  }
  return radiusSearch(cloud[index], radius, k_indices, k_sqr_distances, max_nn);
}

}  // namespace search
}  // namespace pcl

#define PCL_INSTANTIATE_DelaunayWalk(T) template class pcl::search::DelaunayWalk<T>;
