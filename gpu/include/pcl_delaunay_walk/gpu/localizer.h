/// \file localizer.h
/// \brief dw::gpu::Localizer: localization against a prior map with the whole ICP loop on the GPU. The
/// map's Delaunay graph is built on the host (all threads) or loaded from a graph file, uploaded once
/// and kept resident on the device; every scan is downsampled on the host as the CPU dw::Localizer
/// does, copied to the device through page-locked memory on the ICP's stream, and registered by
/// dw::gpu::IterativeClosestPoint (no host synchronisation inside its iterations), warm-started at the
/// vertices the previous frame's points ended at. The prediction and the per-frame statuses are the
/// CPU localizer's own code (dw::FrameTrack), so both give the same statuses and, to rounding, poses.
///
/// Point-to-point only, without a robust kernel (what the GPU ICP does); setOptions refuses others.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/registration/frame_track.h"
#include "pcl_delaunay_walk/core/registration/localizer.h"
#include "pcl_delaunay_walk/gpu/delaunay_walk.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"

namespace dw {
namespace gpu {

/// The GPU ICP's settings for dw::IcpOptions: the same thresholds, and the CPU loop's double-precision
/// convergence test (not PCL's float one), so both loops stop by the same rules. Throws dw::Error for
/// what the GPU ICP does not do (point-to-plane, a robust kernel) and for the options alignIcp refuses.
IcpParameters icpParametersFor(const dw::IcpOptions& options);

class Localizer {
 public:
  using Ptr = std::shared_ptr<Localizer>;

  /// Builds the map graph of `map` (NaN/Inf points skipped) on options.num_threads host threads, from
  /// the points rounded to float as dw::Localizer does, and uploads it. Throws dw::gpu::CudaError
  /// where no device is usable.
  explicit Localizer(const PointView& map, const LocalizerOptions& options = {},
                     const ProgressCallback& progress = {});
  /// Uploads a built or loaded graph.
  explicit Localizer(DelaunayGraph graph, const LocalizerOptions& options = {});
  /// Loads a graph file written by save() or dw::Localizer::save(). Throws dw::GraphFileError naming
  /// the file and the defect.
  static Localizer load(const std::string& path, const LocalizerOptions& options = {});
  /// Writes the map graph (dw::saveGraph: a failed write leaves an existing file intact).
  void save(const std::string& path) const;

  /// Sets the current pose (sensor -> map) and forgets the motion: the next frame starts from it.
  void setPose(const Eigen::Matrix4d& pose) { track_.setPose(pose); }
  const Eigen::Matrix4d& pose() const { return track_.pose(); }
  /// The guess the next registerScan starts from.
  Eigen::Matrix4d predictedPose() const { return track_.predictedPose(options_.constant_velocity); }

  /// Registers one scan (sensor coordinates). Never throws for bad scan content (statuses as
  /// dw::Localizer's); a failing device call throws dw::gpu::CudaError.
  FrameResult registerScan(const PointView& scan);

  /// Throws dw::Error for settings the GPU ICP lacks (see icpParametersFor) or bad bounds.
  void setOptions(const LocalizerOptions& options);
  const LocalizerOptions& options() const { return options_; }
  const DelaunayGraph& graph() const { return *graph_; }
  std::size_t mapPoints() const { return graph_->numInputPoints(); }
  /// The uploaded map, shared with other device users (e.g. a dw::gpu::IterativeClosestPoint of theirs).
  DelaunayWalk::ConstPtr deviceMap() const { return map_; }

 private:
  std::shared_ptr<const DelaunayGraph> graph_;
  DelaunayWalk::ConstPtr map_;
  std::unique_ptr<IterativeClosestPoint> icp_;
  LocalizerOptions options_;
  FrameTrack track_;
};

}  // namespace gpu
}  // namespace dw
