/// \file localizer_delaunay_walk.h
/// \brief pcl::registration::LocalizerDelaunayWalk: localization of a stream of PCL scans against a
/// prior map, the PCL face of dw::Localizer (core/registration/localizer.h).
#pragma once

#include <pcl/point_cloud.h>

#include <Eigen/Core>
#include <memory>
#include <string>

#include "pcl_delaunay_walk/core/registration/localizer.h"

namespace pcl {
namespace registration {

/** \brief Registers each incoming scan onto a fixed map whose Delaunay graph is built once (or loaded).
 *
 * With the default point-to-point metric and no kernel, one registerScan() gives the pose of
 * pcl::IterativeClosestPoint<PointT, PointT, double> aligning the scan to the map from the predicted
 * pose with the same maximum distance, iteration limit and epsilons. The prediction is the previous
 * pose moved by the previous frame's motion (setUseMotionModel(false): the previous pose).
 * Every frame gets a status (dw::FrameStatus); bad scans never throw.
 */
template <typename PointT>
class LocalizerDelaunayWalk {
 public:
  using Ptr = shared_ptr<LocalizerDelaunayWalk<PointT>>;
  using ConstPtr = shared_ptr<const LocalizerDelaunayWalk<PointT>>;
  using PointCloud = pcl::PointCloud<PointT>;
  using Matrix4 = Eigen::Matrix4d;

  LocalizerDelaunayWalk() = default;

  /** \brief Builds the map graph of \a map (NaN points skipped) on the configured threads. */
  void setInputMap(const typename PointCloud::ConstPtr& map);
  /** \brief Loads a map graph saved by saveMap() (or dw_localize --save-map); throws
   * dw::GraphFileError naming the file for a corrupt or other-version file. */
  void loadMap(const std::string& path);
  /** \brief Saves the map graph (through a temporary file: a failed write keeps an existing file). */
  void saveMap(const std::string& path) const;
  bool hasMap() const { return localizer_ != nullptr; }

  /** \brief Registers one scan (sensor frame). \param[in] scan the scan \return the frame's result,
   * its pose sensor -> map. Throws dw::Error only when no map is set. */
  dw::FrameResult registerScan(const PointCloud& scan);

  /** \brief Sets the pose (sensor -> map) the next frame starts from and forgets the motion. */
  void setPose(const Matrix4& pose);
  Matrix4 getPose() const { return localizer_ ? localizer_->pose() : pose_; }

  void setMaxCorrespondenceDistance(double d) {
    update([&](dw::LocalizerOptions& o) { o.icp.max_correspondence_distance = d; });
  }
  void setMaximumIterations(int n) {
    update([&](dw::LocalizerOptions& o) { o.icp.max_iterations = n; });
  }
  void setTransformationEpsilon(double e) {
    update([&](dw::LocalizerOptions& o) { o.icp.transformation_epsilon = e; });
  }
  void setTransformationRotationEpsilon(double e) {
    update([&](dw::LocalizerOptions& o) { o.icp.rotation_epsilon = e; });
  }
  void setEuclideanFitnessEpsilon(double e) {
    update([&](dw::LocalizerOptions& o) { o.icp.euclidean_fitness_epsilon = e; });
  }
  /** \brief Point-to-plane ICP (map normals from the walk's k nearest neighbours, computed once). */
  void setUsePointToPlane(bool on) {
    update([&](dw::LocalizerOptions& o) {
      o.icp.metric = on ? dw::IcpMetric::PointToPlane : dw::IcpMetric::PointToPoint;
    });
  }
  void setRobustKernel(dw::RobustKernel k, double scale) {
    update([&](dw::LocalizerOptions& o) { o.icp.kernel = k, o.icp.kernel_scale = scale; });
  }
  /** \brief Voxel leaf for the scans (0: full resolution). */
  void setScanLeafSize(double leaf) {
    update([&](dw::LocalizerOptions& o) { o.voxel = leaf; });
  }
  void setUseMotionModel(bool on) {
    update([&](dw::LocalizerOptions& o) { o.constant_velocity = on; });
  }
  /** \brief Frames with a fitness (inlier fraction) below this are dw::FrameStatus::LostTrack. */
  void setMinimumFitness(double f) {
    update([&](dw::LocalizerOptions& o) { o.min_fitness = f; });
  }
  /** \brief Threads for the map build and the correspondence search (0: all cores). */
  void setNumberOfThreads(unsigned n) {
    update([&](dw::LocalizerOptions& o) { o.num_threads = n; });
  }
  const dw::LocalizerOptions& getOptions() const { return options_; }

  /** \brief The core localizer (null before a map is set). */
  const std::shared_ptr<dw::Localizer>& getLocalizer() const { return localizer_; }

 private:
  template <typename F>
  void update(F&& f) {
    f(options_);
    if (localizer_) localizer_->setOptions(options_);
  }

  dw::LocalizerOptions options_;
  std::shared_ptr<dw::Localizer> localizer_;
  Matrix4 pose_ = Matrix4::Identity();
};

}  // namespace registration
}  // namespace pcl
