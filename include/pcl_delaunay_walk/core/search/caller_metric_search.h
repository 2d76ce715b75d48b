/// \file caller_metric_search.h
/// \brief Exact queries in the caller's float metric on top of the core walk graph: the bridge that
/// makes pcl::search::DelaunayWalk answer exactly like pcl::search::KdTree (FLANN).
///
/// The core searches in the graph's local frame (float coordinates relative to a double origin), and
/// its distances differ from FLANN's, which subtracts the caller's float coordinates directly, by a
/// few units in the last place. That is enough to swap two near-equal neighbours or to move a point
/// across a radius. CallerMetricSearch therefore recomputes every distance from the caller's coordinates,
/// exactly as FLANN does, and certifies each answer: it asks the core for one neighbour more than
/// needed and accepts the result only if that extra one is farther by more than the bound on the
/// local/caller rounding difference; otherwise it widens to a radius query over the uncertain band.
/// Ties are broken by ascending caller index. The class is PCL-free so that it compiles once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/search/neighbour_search.h"

namespace dw {

/// One neighbour in the caller's metric: squared distance and index into the caller's cloud.
struct WalkNeighbour {
  float sqr_distance;
  std::int32_t index;
};

/// What one query cost and where it ended, for hints (PNN) and statistics.
struct CallerMetricSearchStats {
  dw::index_t nn_vertex = dw::kInvalidIndex;  ///< the query's nearest vertex (the next PNN hint)
  std::uint32_t walk_steps = 0;               ///< moves of the walk (seed: "walk count")
  bool widened = false;                       ///< the certification needed the radius fallback
  /// nearest() only: another point lies at exactly the answer's caller distance (an exact tie, or a
  /// duplicate of the answer); the answer is then the lowest caller index among them. A k-d tree
  /// may name another of them (FLANN keeps the first it visits), so callers that must equal one can
  /// resolve these queries by asking it.
  bool tied = false;
};

class CallerMetricSearch {
 public:
  using Ptr = std::shared_ptr<CallerMetricSearch>;
  using ConstPtr = std::shared_ptr<const CallerMetricSearch>;

  /// \param[in] graph the walk graph built from exactly these points (same count, same order)
  /// \param[in] xyz caller coordinates of the graph's input points, 3 floats each (NaN allowed)
  /// \param[in] input_to_cloud caller index of each graph input; empty means the identity
  CallerMetricSearch(dw::DelaunayGraph::ConstPtr graph, std::vector<float> xyz,
                     std::vector<std::int32_t> input_to_cloud);

  const dw::DelaunayGraph& graph() const { return search_->graph(); }
  const dw::DelaunayGraph::ConstPtr& graphPtr() const { return search_->graphPtr(); }
  const dw::NeighbourSearch& neighbourSearch() const { return *search_; }
  /// Caller coordinates of the graph inputs (3 floats each).
  const std::vector<float>& inputXyz() const { return xyz_; }
  const std::vector<std::int32_t>& inputToCloud() const { return input_to_cloud_; }
  std::size_t numInputs() const { return xyz_.size() / 3; }
  /// Number of finite inputs: what k is clamped to (FLANN's total_nr_points_).
  std::size_t numFinite() const { return num_finite_; }
  /// Unique over the process lifetime: tells caches (PNN hints) that the graph changed.
  std::uint64_t id() const { return id_; }

  std::int32_t cloudIndex(std::size_t input) const {
    return input_to_cloud_.empty() ? static_cast<std::int32_t>(input) : input_to_cloud_[input];
  }
  /// Vertex of a graph input (kInvalidIndex for a skipped NaN input or an out-of-range one).
  dw::index_t vertexOfInput(std::size_t input) const {
    return input < numInputs() ? graph().input_to_vertex[input] : dw::kInvalidIndex;
  }

  /// Starts loading what nearest() reads first for a walk from vertex v: the core's start data and
  /// v's caller-side record. Late in ICP a walk ends where it starts, and that record's load was
  /// nearest()'s largest cost (a cache miss in 38 % of its samples on a KITTI frame).
  void prefetchStart(dw::index_t v) const {
    search_->prefetchStart(v);
    if (v < vertex_.size()) __builtin_prefetch(&vertex_[v]);
  }
  /// Exact nearest neighbour of q. Returns false (and leaves `out` alone) for a non-finite query or
  /// an empty graph.
  bool nearest(const float q[3], dw::StartStrategy strategy, dw::index_t hint, WalkNeighbour& out,
               CallerMetricSearchStats* stats = nullptr) const;

  /// Exact k nearest (k clamped to numFinite()), ascending (distance, index). Returns the count.
  std::size_t knn(const float q[3], std::size_t k, dw::StartStrategy strategy, dw::index_t hint,
                  std::vector<WalkNeighbour>& out, CallerMetricSearchStats* stats = nullptr) const;

  /// Every point with squared distance < float(radius^2) (strict, as FLANN), ascending; at most max_nn
  /// (the nearest ones) unless max_nn is 0. A negative or NaN radius finds nothing.
  std::size_t radius(const float q[3], double radius, std::size_t max_nn, dw::StartStrategy strategy,
                     dw::index_t hint, std::vector<WalkNeighbour>& out,
                     CallerMetricSearchStats* stats = nullptr) const;

  /// Upper bound on |local - caller| squared-distance rounding difference at squared distance d2 for a
  /// query whose local coordinates have magnitude up to q_extent.
  float tolerance(float d2, float q_extent) const;

  /// Throws dw::Error unless `graph` was built from exactly the points `xyz` (3 floats each, in input
  /// order): same count, NaN inputs skipped, every finite input on a vertex at its local position.
  static void checkGraphMatches(const dw::DelaunayGraph& graph, const std::vector<float>& xyz);

 private:
  float callerDistance(const float q[3], dw::index_t input) const {
    return distance(q, &xyz_[3 * static_cast<std::size_t>(input)]);
  }
  static float distance(const float q[3], const float* p) {
    // The same operations in the same order as FLANN's L2_Simple, so equal inputs give equal bits.
    const float dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2];
    float r = 0.f;
    r += dx * dx;
    r += dy * dy;
    r += dz * dz;
    return r;
  }
  bool locate(const float q[3], dw::StartStrategy strategy, dw::index_t hint, dw::Vec3f& ql, float& q_extent,
              dw::WalkResult& nn, CallerMetricSearchStats* stats) const;
  void collect(const float q[3], const std::vector<dw::index_t>& inputs, std::size_t count,
               std::vector<WalkNeighbour>& out) const;
  /// The first `count` inputs of the listed vertices, in list order, in the caller's metric.
  void collectVertices(const float q[3], const std::vector<dw::VertexNeighbour>& vertices, std::size_t count,
                       std::vector<WalkNeighbour>& out) const;

  std::shared_ptr<const dw::NeighbourSearch> search_;
  std::vector<float> xyz_;
  std::vector<std::int32_t> input_to_cloud_;
  // Per vertex, in vertex (curve) order: the caller coordinates shared by its originals and the lowest
  // cloud index among them, so the nearest-neighbour path reads one record next to where the walk
  // ended. Real scans collapse thousands of points onto one vertex (e.g. LiDAR no-return points at the
  // sensor origin); scanning them per query was the largest single cost. A vertex whose originals
  // differ in caller coordinates (distinct floats that round to one local point) is marked mixed and
  // scanned in full.
  struct VertexRecord {
    float xyz[3];
    /// The lowest cloud index c of the originals: c for a vertex of one point, ~c (negative) for
    /// duplicates at the same caller coordinates; kMixed: scan them all.
    std::int32_t cloud;
  };
  static constexpr std::int32_t kMixed = std::numeric_limits<std::int32_t>::min();
  std::vector<VertexRecord> vertex_;  // one 16-byte record: one line to prefetch (prefetchStart)
  std::size_t num_finite_ = 0;
  float extent_ = 0.f;  ///< largest |local coordinate| of any vertex
  std::uint64_t id_ = 0;
};

}  // namespace dw
