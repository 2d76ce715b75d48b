/// \file small_gicp_peers.h
/// \brief small_gicp 1.0.1+ as dw_localize_bench's peer (benchmark-only), three ways:
///   - SmallGicpKdTreeSearch: its KdTree as the correspondence search of *our* ICP loop (exact: the
///     poses must equal the walk's);
///   - SmallGicpIcp: its *own* registration (point-to-point ICPFactor, Levenberg-Marquardt, distance
///     rejector) on the prior map, a different loop with its own termination rule;
///   - SmallGicpOdometry: its incremental voxel map as the odometry's local map, registered into with
///     its ICP the way its odometry benchmark does (odometry_benchmark_small_gicp*.cpp).
///
/// Points are std::vector<Eigen::Vector4d>, which small_gicp's traits accept (points/eigen.hpp): its
/// PointCloud would also allocate a normal and a 4x4 covariance per point, 160 unused bytes that ICP
/// never reads (1.6 GB on a 10M-point map). Threads come from OpenMP (its only CPU backend besides
/// TBB); without OpenMP everything here runs serially and smallGicpThreads() says 1.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <memory>
#include <small_gicp/ann/incremental_voxelmap.hpp>
#include <small_gicp/ann/kdtree.hpp>
#include <small_gicp/factors/icp_factor.hpp>
#include <small_gicp/points/eigen.hpp>
#include <small_gicp/registration/reduction.hpp>
#include <small_gicp/registration/registration.hpp>
#include <vector>

#ifdef _OPENMP
// Included only with OpenMP: without it these headers fall back to one thread with a #warning.
#include <small_gicp/ann/kdtree_omp.hpp>
#include <small_gicp/registration/reduction_omp.hpp>
#endif

#include "pcl_delaunay_walk/core/registration/icp.h"
#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw_bench {

/// Version label of the copy in ../shared/peers (its README): the last release plus the commit.
inline constexpr const char* kSmallGicpLabel = "small_gicp 1.0.1+ @aea1313";

using SgPoints = std::vector<Eigen::Vector4d>;
using SgTree = small_gicp::KdTree<SgPoints>;

/// The threads small_gicp gets for `requested` (0: all cores): one without OpenMP.
inline int smallGicpThreads(unsigned requested) {
#ifdef _OPENMP
  return int(dw::resolveThreads(requested));
#else
  (void)requested;
  return 1;
#endif
}

inline std::shared_ptr<SgPoints> toSmallGicpPoints(const float* xyz, std::size_t n) {
  auto p = std::make_shared<SgPoints>(n);
  for (std::size_t i = 0; i < n; ++i)
    (*p)[i] = Eigen::Vector4d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 1.0);
  return p;
}

/// Its KdTree (leaf size 20, axis-aligned median splits: its defaults), built on `threads` threads.
inline std::shared_ptr<const SgTree> buildSmallGicpTree(std::shared_ptr<const SgPoints> points, int threads) {
#ifdef _OPENMP
  if (threads > 1) return std::make_shared<const SgTree>(points, small_gicp::KdTreeBuilderOMP(threads));
#endif
  (void)threads;
  return std::make_shared<const SgTree>(points);
}

/// small_gicp's KdTree answering our loop's queries. It measures in double; the returned squared
/// distance is recomputed in float from the caller's coordinates, so the distance rejection sees
/// the same numbers as with the other searches (only the choice of the point is the tree's).
class SmallGicpKdTreeSearch final : public dw::CorrespondenceSearch {
 public:
  SmallGicpKdTreeSearch(const std::vector<float>& xyz, unsigned threads)
      : xyz_(xyz),
        tree_(buildSmallGicpTree(toSmallGicpPoints(xyz.data(), xyz.size() / 3), smallGicpThreads(threads))) {}

  std::size_t size() const override { return xyz_.size() / 3; }
  const float* point(std::size_t i) const override { return &xyz_[3 * i]; }

  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    if (size() == 0 || !std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) return false;
    std::size_t i = 0;
    double d2 = 0;
    if (tree_->nearest_neighbor_search(Eigen::Vector4d(q[0], q[1], q[2], 1.0), &i, &d2) != 1) return false;
    const float* p = point(i);
    const float dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2];
    index = std::int32_t(i);
    dist2 = dx * dx + dy * dy + dz * dz;
    return true;
  }

 private:
  const std::vector<float>& xyz_;
  std::shared_ptr<const SgTree> tree_;
};

/// Our loop's settings in small_gicp's terms. Ours stops when the increment's squared translation is
/// <= transformation_epsilon and its rotation's cosine >= 1 - transformation_epsilon (PCL's rule);
/// small_gicp compares the increment's norms, so the same bounds are sqrt(eps) m and acos(1 - eps) rad.
struct SmallGicpSettings {
  double max_distance = 1.0;
  int max_iterations = 30;
  double translation_eps = 1e-4, rotation_eps = 1.4e-4;
  int threads = 1;

  static SmallGicpSettings from(const dw::IcpOptions& o) {
    SmallGicpSettings s;
    s.max_distance = o.max_correspondence_distance;
    s.max_iterations = o.max_iterations;
    s.translation_eps = std::sqrt(o.transformation_epsilon);
    s.rotation_eps = std::acos(o.rotation_epsilon > 0 ? o.rotation_epsilon : 1.0 - o.transformation_epsilon);
    s.threads = smallGicpThreads(o.num_threads);
    return s;
  }
};

/// One registration with small_gicp's point-to-point ICP: serial reduction on one thread, its OpenMP
/// reduction on more.
template <typename Target, typename Tree>
small_gicp::RegistrationResult smallGicpAlign(const Target& target, const Tree& tree, const SgPoints& source,
                                              const Eigen::Matrix4d& guess, const SmallGicpSettings& s) {
  auto run = [&](auto reduction) {
    small_gicp::Registration<small_gicp::ICPFactor, decltype(reduction)> reg;
    reg.reduction = reduction;
    reg.rejector.max_dist_sq = s.max_distance * s.max_distance;
    reg.optimizer.max_iterations = s.max_iterations;
    reg.criteria.translation_eps = s.translation_eps;
    reg.criteria.rotation_eps = s.rotation_eps;
    return reg.align(target, source, tree, Eigen::Isometry3d(guess));
  };
#ifdef _OPENMP
  if (s.threads > 1) {
    small_gicp::ParallelReductionOMP omp;
    omp.num_threads = s.threads;
    return run(omp);
  }
#endif
  return run(small_gicp::SerialReduction());
}

/// small_gicp's own ICP against the prior map (its KdTree built once).
class SmallGicpIcp {
 public:
  SmallGicpIcp(const std::vector<float>& map, const dw::IcpOptions& options)
      : settings_(SmallGicpSettings::from(options)),
        map_(toSmallGicpPoints(map.data(), map.size() / 3)),
        tree_(buildSmallGicpTree(map_, settings_.threads)) {}

  /// Registers `scan` (3 floats a point) from `guess`; the time includes converting the scan.
  small_gicp::RegistrationResult align(const std::vector<float>& scan, const Eigen::Matrix4d& guess) const {
    const auto source = toSmallGicpPoints(scan.data(), scan.size() / 3);
    return smallGicpAlign(*map_, *tree_, *source, guess, settings_);
  }

  int threads() const { return settings_.threads; }

 private:
  SmallGicpSettings settings_;
  std::shared_ptr<const SgPoints> map_;
  std::shared_ptr<const SgTree> tree_;
};

/// Odometry over small_gicp's IncrementalVoxelMap of points (FlatContainerPoints: up to 10 points a
/// voxel, at least 0.1 m apart; voxels unseen for 100 frames dropped), as its odometry benchmark
/// builds it: register the scan into the map, then insert it at the new pose. The scan is downsampled
/// and the guess predicted (constant velocity) as in dw::SlidingWindowOdometry, so the rows differ
/// in the map and the ICP, not in the input. `search_offsets` (1, 7 or 27 voxels) bounds where a
/// correspondence can come from: 1, small_gicp's default, sees only the query's own voxel.
class SmallGicpOdometry {
 public:
  SmallGicpOdometry(double voxel, int search_offsets, const SmallGicpSettings& settings)
      : voxel_(voxel), settings_(settings), map_(voxel) {
    map_.set_search_offsets(search_offsets);
  }

  /// Registers a scan and adds it to the map; returns the pose (sensor -> first frame).
  Eigen::Matrix4d registerScan(const std::vector<float>& scan) {
    const std::vector<float> pts =
        dw::voxelDownsample(dw::PointView::fromFloat(scan.data(), scan.size() / 3), voxel_);
    const auto source = toSmallGicpPoints(pts.data(), pts.size() / 3);
    Eigen::Matrix4d pose = pose_;
    if (map_.size() > 0)
      pose = smallGicpAlign(map_, map_, *source, pose_ * velocity_, settings_).T_target_source.matrix();
    velocity_ = pose_.inverse() * pose;
    pose_ = pose;
    map_.insert(*source, Eigen::Isometry3d(pose));
    return pose;
  }

  std::size_t mapPoints() const { return small_gicp::traits::point_indices(map_).size(); }

 private:
  double voxel_;
  SmallGicpSettings settings_;
  small_gicp::IncrementalVoxelMap<small_gicp::FlatContainerPoints> map_;
  Eigen::Matrix4d pose_ = Eigen::Matrix4d::Identity(), velocity_ = Eigen::Matrix4d::Identity();
};

}  // namespace dw_bench
