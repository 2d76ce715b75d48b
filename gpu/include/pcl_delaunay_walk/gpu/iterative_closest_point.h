/// \file iterative_closest_point.h
/// \brief dw::gpu::IterativeClosestPoint: the whole point-to-point ICP loop on the device, with the
/// semantics of PCL 1.13's IterativeClosestPoint + TransformationEstimationSVD +
/// DefaultConvergenceCriteria, and a batched form that registers many sources against one target.
///
/// Per iteration, three kernels and no host synchronisation: (1) every source point is transformed by
/// its source's current estimate and walked to its exact nearest target vertex from the previous
/// iteration's answer (PNN), kept when dist^2 <= max_correspondence_distance^2; (2) the 17 sums of the
/// cross-covariance are reduced in double per source (deterministic order); (3) one thread per source
/// solves the step (rigid_transform.h), composes the transform and applies PCL's convergence rules,
/// setting a per-source "done" flag that makes later launches for that source return at once. The
/// host reads a done count from mapped memory to stop launching early. The walk uses the target's
/// group size and layout (DelaunayWalk::setGroupSize, setInlineNeighbourPositions). Sources go to the
/// device through page-locked staging buffers, asynchronously on stream(); with setWarmStart(true)
/// each source point starts where the point of the same caller index ended in the previous align.
#pragma once

#include <cuda_runtime_api.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "pcl_delaunay_walk/core/graph/point_view.h"
#include "pcl_delaunay_walk/gpu/delaunay_walk.h"
#include "pcl_delaunay_walk/gpu/device_buffer.h"
#include "pcl_delaunay_walk/gpu/pinned_buffer.h"

namespace dw {
namespace gpu {

/// Row-major 4x4 rigid transform (double), world frame: target ~ T * source.
using Matrix4d = std::array<double, 16>;
inline Matrix4d identityMatrix4d() {
  return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
}

/// Mirrors pcl::registration::DefaultConvergenceCriteria::ConvergenceState.
enum class ConvergenceState : int {
  NotConverged = 0,
  Iterations = 1,
  Transform = 2,
  AbsMse = 3,
  RelMse = 4,
  NoCorrespondences = 5,
  FailureAfterMaxIterations = 6,
};
const char* toString(ConvergenceState s);

/// ICP settings, with PCL 1.13's defaults and meanings.
struct IcpParameters {
  int max_iterations = 10;              ///< Registration::setMaximumIterations
  double transformation_epsilon = 0.0;  ///< compared with the step's squared translation (as PCL does)
  double transformation_rotation_epsilon = 0.0;  ///< cos threshold; 0: 1 - transformation_epsilon
  double euclidean_fitness_epsilon = -std::numeric_limits<double>::max();  ///< relative MSE change
  double max_correspondence_distance = std::sqrt(std::numeric_limits<double>::max());
  double mse_threshold_absolute = 1e-12;  ///< DefaultConvergenceCriteria's absolute MSE threshold
  int max_iterations_similar_transforms = 0;
  bool failure_after_max_iterations = false;
  unsigned min_number_correspondences = 3;
  /// Evaluate the transformation criterion on the step rounded to float, as PCL's
  /// IterativeClosestPoint<..., float> (its default Scalar) does: cos(angle) = 0.5 (trace - 1) with the
  /// diagonal summed in float, the squared translation in float. Float quantises cos(angle) in steps of
  /// ~6e-8, so with a tight transformation_epsilon PCL stops on the translation alone where a double
  /// test would also wait for the rotation. false: in double (IterativeClosestPoint<..., double>).
  /// parametersFrom() (pcl_adapters.h) sets it from the PCL object's Scalar.
  bool float_transform_criteria = true;
  /// Keep the moved source in float and move it by each step, as dw::alignIcp and PCL's loop do
  /// (transformPointCloud of the float source every iteration): each point is x' = T x rounded to float
  /// with T the world-frame step in double, in their operation order, and the correspondences and sums
  /// read those floats. Both loops then round the same way, reach the same float fixed points and stop
  /// at the same iterations. false: the source stays centred and unmoved, every iteration applies the
  /// composite estimate (composed in double) to it. The sources keep the mode they were added under:
  /// change it before addSource / setInputSource (align throws otherwise).
  bool move_source_in_float = false;
};

/// Outcome of one registration.
struct IcpResult {
  Matrix4d transformation = identityMatrix4d();  ///< final_transformation_ (guess included)
  int iterations = 0;                            ///< nr_iterations_
  ConvergenceState state = ConvergenceState::NotConverged;
  bool converged = false;             ///< hasConverged() as PCL reports it
  double mse = 0.0;                   ///< mean squared correspondence distance, last iteration
  std::uint32_t correspondences = 0;  ///< correspondences of the last iteration
};

class IterativeClosestPoint {
 public:
  using Ptr = std::shared_ptr<IterativeClosestPoint>;

  /// \brief Registers sources against `target`, an uploaded graph shared with other users.
  explicit IterativeClosestPoint(DelaunayWalk::ConstPtr target);
  ~IterativeClosestPoint();
  IterativeClosestPoint(const IterativeClosestPoint&) = delete;
  IterativeClosestPoint& operator=(const IterativeClosestPoint&) = delete;

  void setParameters(const IcpParameters& p);
  const IcpParameters& parameters() const { return params_; }

  /// \brief Replaces every source by this one (world frame). Non-finite points are dropped.
  void setInputSource(const dw::PointView& source);
  /// \brief Adds a source for the batched alignAll(); returns its index.
  std::size_t addSource(const dw::PointView& source);
  void clearSources();
  std::size_t numSources() const { return sources_.size(); }

  /// \brief Warm starts across align calls (off by default: every align starts from the start grid).
  /// On, the first iteration walks each source point from the vertex that the point with the same
  /// caller index (its position in the PointViews given since the last clearSources, counting
  /// non-finite ones) ended at in the previous align; points without one start from the grid. A
  /// spinning LiDAR keeps its point order, so that vertex is near. Starts never change an answer (the
  /// walk is exact from any start), only how far it walks.
  void setWarmStart(bool on) { warm_start_ = on; }
  bool warmStart() const { return warm_start_; }
  /// \brief Forgets the warm starts kept so far (the next align starts from the grid).
  void clearWarmStart() { warm_valid_ = 0; }

  /// \brief Registers source 0 starting from `guess` (PCL's align(output, guess)).
  IcpResult align(const Matrix4d& guess = identityMatrix4d());
  /// \brief Registers every source in one set of launches; guesses: one per source, or empty (identity).
  std::vector<IcpResult> alignAll(const std::vector<Matrix4d>& guesses = {});

  /// \brief The stream every launch goes to (default: a stream owned by this object).
  cudaStream_t stream() const { return stream_; }

 private:
  struct HostSource {
    std::size_t begin = 0, size = 0;  ///< range in the concatenated device source array
    std::size_t input_begin = 0;      ///< caller index of its first point, over all sources
    double centroid[3] = {0, 0, 0};   ///< device points are stored relative to it (float precision)
    bool moved = false;               ///< added under move_source_in_float (centroid 0)
  };
  void uploadLayout();
  /// Queues the iterations (walk, accumulate, solve) until every source is done or max_iterations.
  void runIterations();
  /// Sets every point's first start: its warm start where one is kept, else the grid.
  void seedHints();
  /// Keeps every point's last vertex as the warm start of its caller index.
  void keepHints();

  DelaunayWalk::ConstPtr target_;
  IcpParameters params_;
  std::vector<HostSource> sources_;
  std::vector<float4> host_points_;              ///< concatenated, centred, Morton-sorted per source
  std::vector<std::uint32_t> host_input_index_;  ///< per point: its caller index
  std::size_t total_inputs_ = 0;                 ///< caller points given since clearSources, finite or not
  bool dirty_ = true;
  bool warm_start_ = false;
  std::size_t warm_valid_ = 0;  ///< caller indices below this have a kept warm start

  PinnedBuffer<float4> stage_points_;          ///< upload staging of the points
  PinnedBuffer<std::uint32_t> stage_indices_;  ///< upload staging of the index arrays

  DeviceBuffer<float4> points_;
  DeviceBuffer<float4> moved_;  ///< move_source_in_float: the source moved so far (world frame)
  DeviceBuffer<std::uint32_t> hints_;         ///< per point: last nearest vertex (PNN start)
  DeviceBuffer<float> corr_d2_;               ///< per point: accepted squared distance, or -1
  DeviceBuffer<std::uint32_t> point_source_;  ///< per point: its source
  DeviceBuffer<std::uint32_t> input_index_;   ///< per point: its caller index
  DeviceBuffer<std::uint32_t> warm_hints_;    ///< per caller index: the last vertex its point ended at
  DeviceBuffer<std::uint32_t> block_source_;
  DeviceBuffer<std::uint32_t> source_meta_;  ///< per source: begin, size, first block, #blocks
  DeviceBuffer<double> partials_;
  DeviceBuffer<unsigned char> states_;  ///< per-source solver state (see the .cu)
  std::uint32_t num_blocks_ = 0;
  cudaStream_t stream_ = nullptr;
  std::array<cudaEvent_t, 3> events_{};  ///< ring: limits how many iterations are queued ahead
  unsigned* done_host_ = nullptr;        ///< mapped pinned: how many sources are done
  unsigned* done_host_dev_ = nullptr;    ///< its device address
  DeviceBuffer<unsigned> done_count_;
  DeviceBuffer<unsigned> tickets_;  ///< per source: blocks finished this iteration
  DeviceBuffer<double> sums_;       ///< per source: the 17 sums of this iteration
};

}  // namespace gpu
}  // namespace dw
