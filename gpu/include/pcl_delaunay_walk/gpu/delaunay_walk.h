/// \file delaunay_walk.h
/// \brief dw::gpu::DelaunayWalk: exact batch nearest-neighbour, kNN and radius search on the GPU by the
/// Delaunay walk (Anderson et al. 2022), over a graph built on the host by the core (dw::DelaunayGraph).
///
/// Device layout (built from the core's CSR on upload): vertices as float4 {x, y, z, safe-ball r^2}
/// (16-byte loads, 7 MB for the 437k dragon, so the whole vertex set stays in the H100's 50 MB L2) and,
/// per directed edge, the neighbour index j (4 bytes instead of the core's 20-byte record), plus the
/// neighbour's position inline where that fits L2. The walk compares squared distances
/// |q - x_j|^2 < |q - x_i|^2 directly, which is the same exactness argument as the core's c > m test
/// (docs/architecture.md, "Why the searches are exact"): in float where float decides with margin, otherwise
/// in double from the float coordinates, the very comparison a brute-force search makes. Reported distances
/// are the doubles rounded to float.
#pragma once

#include <cuda_runtime_api.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/point_view.h"
#include "pcl_delaunay_walk/gpu/device_buffer.h"

namespace dw {
namespace gpu {

/// Raw device pointers of an uploaded graph: what kernels receive by value.
struct DeviceGraphView {
  const float4* points = nullptr;          ///< n vertices, local frame, w = safe-ball radius^2 (0: none)
  const std::uint32_t* offsets = nullptr;  ///< n + 1 CSR offsets
  const std::uint32_t* neighbours = nullptr;
  /// Optional per-edge copy of the neighbour's position, w = j's bits (see setInlineNeighbourPositions).
  const float4* edge_points = nullptr;
  const std::uint32_t* originals_offsets = nullptr;  ///< n + 1
  const std::uint32_t* originals = nullptr;          ///< input indices per vertex, ascending
  std::uint32_t num_vertices = 0;
  bool safe_ball = true;        ///< stop at once inside points[v].w (DelaunayWalk::setSafeBallTest)
  bool shortest_first = false;  ///< neighbourhoods sorted by edge length: scans may stop early
  // Start grid (KD-ANN's role, O(1)): seed vertex of each cell = exact NN of the cell centre.
  const std::uint32_t* grid_seeds = nullptr;
  float grid_min[3] = {0.f, 0.f, 0.f};
  float grid_inv_cell[3] = {0.f, 0.f, 0.f};
  int grid_dim[3] = {0, 0, 0};
};

/// Exact batch search over a Delaunay graph on the device. Queries are float4 {x, y, z, ignored} in the
/// graph's local frame (toLocal() converts caller points); results are graph vertices (nearest) or input
/// indices (kNN, radius; duplicates expanded). All calls are asynchronous on `stream` unless stated.
class DelaunayWalk {
 public:
  using Ptr = std::shared_ptr<DelaunayWalk>;
  using ConstPtr = std::shared_ptr<const DelaunayWalk>;

  /// Largest k for knn() and max_nn for radius(): the expansion keeps its state in registers/local memory.
  static constexpr unsigned kMaxK = 64;

  DelaunayWalk() = default;
  /// Uploads `graph` (see setGraph()).
  explicit DelaunayWalk(const dw::DelaunayGraph& graph) { setGraph(graph); }

  /// \brief Uploads the graph and builds the start grid on the current device. Synchronous.
  /// \param[in] graph a validated core graph (any size, 0 vertices included)
  /// \param[in] cells_per_vertex start-grid resolution: about this many cells per vertex (capped)
  void setGraph(const dw::DelaunayGraph& graph, double cells_per_vertex = 0.25);

  std::size_t numVertices() const { return view_.num_vertices; }
  std::size_t numInputPoints() const { return num_inputs_; }
  const std::array<double, 3>& origin() const { return origin_; }
  const DeviceGraphView& view() const { return view_; }
  /// Vertex -> representative input index (the smallest input index that collapsed onto it).
  const std::vector<std::uint32_t>& vertexToInput() const { return vertex_to_input_; }

  /// \brief Caller points (world frame) to device queries in the graph's local frame (subtract in double).
  void toLocal(const dw::PointView& points, std::vector<float4>& out) const;

  /// \brief Lanes cooperating on one query's neighbourhood scan: 1 (thread per query), 2, 4, 8, 16 or 32.
  /// 0 (the default) picks defaultGroupSize() for the uploaded graph. The ICP loop uses it too.
  void setGroupSize(int lanes);
  int groupSize() const { return group_size_; }
  /// The lanes measured fastest on the H100 for a graph of this many vertices (docs/gpu.md).
  static int defaultGroupSize(std::size_t num_vertices);

  /// \brief Also store, per directed edge, the neighbour's position next to its index (16 bytes per
  /// edge instead of 4): a scan then reads one contiguous run instead of gathering vertices, one
  /// dependent load fewer per step. Pays while the edge array fits in L2 (docs/gpu.md). Without a call,
  /// each uploaded graph gets defaultInlineNeighbourPositions(); a call fixes the choice. Synchronous.
  void setInlineNeighbourPositions(bool on);
  /// The layout measured faster on the H100 for a graph of this many directed edges (docs/gpu.md).
  static bool defaultInlineNeighbourPositions(std::size_t num_directed_edges);
  bool inlineNeighbourPositions() const { return view_.edge_points != nullptr; }

  /// \brief Stop a walk without scanning edges when the query lies inside the current vertex's safe
  /// ball (radius: half the distance to its nearest neighbour, shrunk by 1e-5), where that vertex is
  /// certainly the nearest. On by default; off only to measure what it saves.
  void setSafeBallTest(bool on);
  bool safeBallTest() const { return safe_ball_; }

  /// \brief Exact nearest vertex of each query.
  /// \param[in] queries n queries (device)
  /// \param[in] n number of queries
  /// \param[in] hints optional start vertices (device, n entries, PNN); entries >= numVertices() (e.g.
  ///            dw::kInvalidIndex) start from the grid. nullptr: every query starts from the grid.
  /// \param[out] vertices nearest vertex (device, n); dw::kInvalidIndex for a non-finite query or empty graph
  /// \param[out] dist2 squared distance to it (device, n); +inf where vertices is invalid
  /// \param[out] steps optional walk length per query (device, n), nullptr to skip
  /// \param[in] stream CUDA stream
  void nearest(const float4* queries, std::size_t n, const std::uint32_t* hints, std::uint32_t* vertices,
               float* dist2, std::uint32_t* steps = nullptr, cudaStream_t stream = nullptr) const;

  /// \brief DeviceBuffer form of nearest(): sizes the outputs to the queries.
  void nearest(const DeviceBuffer<float4>& queries, const DeviceBuffer<std::uint32_t>* hints,
               DeviceBuffer<std::uint32_t>& vertices, DeviceBuffer<float>& dist2,
               DeviceBuffer<std::uint32_t>* steps = nullptr, cudaStream_t stream = nullptr) const;

  /// \brief Exact k nearest input points of each query, ascending distance.
  /// \param[in] queries device queries
  /// \param[in] k 1 .. kMaxK
  /// \param[in] hints optional start vertices as in nearest() (nullptr: grid)
  /// \param[out] indices n*k input indices (row i = query i); unused slots dw::kInvalidIndex
  /// \param[out] dist2 n*k squared distances; unused slots +inf
  /// \param[out] counts n: how many were found (min(k, finite inputs); 0 for a non-finite query)
  void knn(const DeviceBuffer<float4>& queries, unsigned k, const DeviceBuffer<std::uint32_t>* hints,
           DeviceBuffer<std::uint32_t>& indices, DeviceBuffer<float>& dist2,
           DeviceBuffer<std::uint32_t>& counts, cudaStream_t stream = nullptr) const;

  /// \brief Input points within `radius` (dist2 <= radius^2, in double) of each query: the max_nn nearest of
  /// them, ascending. Output is bounded: n*max_nn slots, counts[i] says how many are valid. \param[in] radius
  /// search radius (>= 0, finite) \param[in] max_nn 1 .. kMaxK
  void radius(const DeviceBuffer<float4>& queries, float radius, unsigned max_nn,
              const DeviceBuffer<std::uint32_t>* hints, DeviceBuffer<std::uint32_t>& indices,
              DeviceBuffer<float>& dist2, DeviceBuffer<std::uint32_t>& counts,
              cudaStream_t stream = nullptr) const;

  /// \brief Exact nearest vertex by brute force (every query against every vertex, shared-memory tiles).
  /// The reference the walk is tested and measured against. Ties go to the smaller vertex index.
  void bruteForceNearest(const float4* queries, std::size_t n, std::uint32_t* vertices, float* dist2,
                         cudaStream_t stream = nullptr) const;

  /// \brief Replaces vertex indices by their representative input indices (in place, device).
  void verticesToInputs(std::uint32_t* vertices, std::size_t n, cudaStream_t stream = nullptr) const;

 private:
  void expand(const DeviceBuffer<float4>& queries, unsigned k, double radius2,
              const DeviceBuffer<std::uint32_t>* hints, DeviceBuffer<std::uint32_t>& indices,
              DeviceBuffer<float>& dist2, DeviceBuffer<std::uint32_t>& counts, cudaStream_t stream) const;
  void buildStartGrid(const dw::DelaunayGraph& graph, double cells_per_vertex);
  void applyInlineNeighbourPositions(bool on);

  DeviceBuffer<float4> points_;
  DeviceBuffer<std::uint32_t> offsets_;
  DeviceBuffer<std::uint32_t> neighbours_;
  DeviceBuffer<float4> edge_points_;
  DeviceBuffer<std::uint32_t> originals_offsets_;
  DeviceBuffer<std::uint32_t> originals_;
  DeviceBuffer<std::uint32_t> grid_seeds_;
  DeviceBuffer<std::uint32_t> vertex_to_input_dev_;
  std::vector<std::uint32_t> vertex_to_input_;
  DeviceGraphView view_;
  std::array<double, 3> origin_{{0.0, 0.0, 0.0}};
  std::size_t num_inputs_ = 0;
  int group_size_ = 4;
  bool auto_group_size_ = true;
  bool auto_inline_ = true;
  bool safe_ball_ = true;
};

}  // namespace gpu
}  // namespace dw
