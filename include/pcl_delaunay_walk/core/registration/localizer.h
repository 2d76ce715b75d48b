/// \file localizer.h
/// \brief Localization against a prior map: the map's Delaunay graph is built once (all threads) or
/// loaded from a graph file, and every incoming scan is registered onto it by the ICP loop
/// (icp.h) from a constant-velocity prediction, warm-started at the previous frame's answers.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/registration/frame_track.h"
#include "pcl_delaunay_walk/core/registration/icp.h"
#include "pcl_delaunay_walk/core/registration/walk_correspondence_search.h"

namespace dw {

struct LocalizerOptions {
  IcpOptions icp;      ///< its num_threads is replaced by num_threads below
  double voxel = 0.0;  ///< scan downsampling leaf in metres (0: full resolution)
  bool constant_velocity = true;
  double min_fitness = 0.3;                                   ///< LostTrack below this
  double max_rmse = std::numeric_limits<double>::infinity();  ///< LostTrack above this
  std::size_t normal_neighbours = 10;                         ///< k of the map normals (point-to-plane)
  /// Keep each scan point's last nearest vertex as the next frame's start (else KD-ANN per frame).
  bool warm_start_across_frames = true;
  unsigned num_threads = 0;  ///< map build, normals and correspondence search (0: all cores)

  LocalizerOptions() {
    icp.max_correspondence_distance = 1.0;
    icp.max_iterations = 30;
    icp.transformation_epsilon = 1e-8;
  }
};

class Localizer {
 public:
  using Ptr = std::shared_ptr<Localizer>;

  /// Builds the map graph of `map` (NaN/Inf points skipped) on options.num_threads threads.
  explicit Localizer(const PointView& map, const LocalizerOptions& options = {},
                     const ProgressCallback& progress = {});
  /// Takes a built or loaded graph; the map points are its vertices in caller coordinates.
  explicit Localizer(DelaunayGraph graph, const LocalizerOptions& options = {});
  /// Loads a graph file written by save(). Throws dw::GraphFileError naming the file and the defect
  /// (corrupt, truncated, foreign, another version).
  static Localizer load(const std::string& path, const LocalizerOptions& options = {});
  /// Writes the map graph through a temporary file renamed over `path`: a failed write leaves an
  /// existing file intact. Throws dw::Error.
  void save(const std::string& path) const;

  /// Sets the current pose (sensor -> map) and forgets the motion: the next frame starts from it.
  void setPose(const Eigen::Matrix4d& pose) { track_.setPose(pose); }
  const Eigen::Matrix4d& pose() const { return track_.pose(); }
  /// The guess the next registerScan starts from.
  Eigen::Matrix4d predictedPose() const { return track_.predictedPose(options_.constant_velocity); }

  /// Registers one scan (sensor coordinates). Never throws for bad scan content.
  FrameResult registerScan(const PointView& scan);

  void setOptions(const LocalizerOptions& options);
  const LocalizerOptions& options() const { return options_; }
  const DelaunayGraph& graph() const { return search_->callerSearch().graph(); }
  std::size_t mapPoints() const { return search_->size(); }
  /// The map normals (3 floats per map point); computed on first use.
  const std::vector<float>& mapNormals();
  const CorrespondenceSearch& correspondenceSearch() const { return *search_; }

 private:
  void init(std::shared_ptr<const DelaunayGraph> graph, std::vector<float> xyz);

  LocalizerOptions options_;
  std::shared_ptr<WalkCorrespondenceSearch> search_;
  std::vector<float> normals_;
  IcpWorkspace workspace_;
  FrameTrack track_;
};

}  // namespace dw
