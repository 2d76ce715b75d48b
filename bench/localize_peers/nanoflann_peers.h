/// \file nanoflann_peers.h
/// \brief nanoflann 1.12.1 as dw_localize_bench's peer (benchmark-only): its static tree as the ICP
/// loop's correspondence search, and the same odometry as dw::SlidingWindowOdometry over its
/// incremental tree. The trees read the caller's float array through FloatCloud, never a copy.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <cstdint>
#include <nanoflann.hpp>
#include <unordered_map>
#include <vector>

#include "pcl_delaunay_walk/core/registration/icp.h"
#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw_bench {

/// nanoflann's dataset adaptor over 3 floats a point.
struct FloatCloud {
  const std::vector<float>* xyz;
  std::size_t kdtree_get_point_count() const { return xyz->size() / 3; }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return (*xyz)[3 * i + d]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using NanoTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, FloatCloud>,
                                                     FloatCloud, 3, std::uint32_t>;

/// The static tree (leaf 10, built on `threads` threads) answering the ICP loop's queries.
class NanoflannSearch final : public dw::CorrespondenceSearch {
 public:
  NanoflannSearch(const std::vector<float>& xyz, unsigned threads)
      : cloud_{&xyz},
        tree_(3, cloud_,
              nanoflann::KDTreeSingleIndexAdaptorParams(10, nanoflann::KDTreeSingleIndexAdaptorFlags::None,
                                                        dw::resolveThreads(threads))) {}
  std::size_t size() const override { return cloud_.kdtree_get_point_count(); }
  const float* point(std::size_t i) const override { return &(*cloud_.xyz)[3 * i]; }
  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) return false;
    std::uint32_t i = 0;
    float d = 0;
    if (tree_.knnSearch(q, 1, &i, &d) != 1) return false;
    index = std::int32_t(i);
    dist2 = d;
    return true;
  }

 private:
  FloatCloud cloud_;
  NanoTree tree_;
};
using NanoIncrementalTree =
    nanoflann::KDTreeSingleIndexIncrementalAdaptor<nanoflann::L2_Simple_Adaptor<float, FloatCloud>,
                                                   FloatCloud, 3, std::uint32_t>;

/// The same odometry with nanoflann 1.12.1's incremental tree as the local map: the same ICP loop,
/// 0.5 m voxel hash (one point per voxel), range bound and constant-velocity prediction as
/// dw::SlidingWindowOdometry, so the two differ only in the nearest-neighbour structure.
class NanoflannOdometry final : public dw::CorrespondenceSearch {
 public:
  /// `icp`: the loop's settings (the bench passes dw::SlidingWindowOdometry's).
  explicit NanoflannOdometry(const dw::IcpOptions& icp) : icp_(icp) {}

  std::size_t size() const override { return points_.size() / 3; }
  const float* point(std::size_t i) const override { return &points_[3 * i]; }
  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    std::uint32_t i = 0;
    float d = 0;
    if (live_count_ == 0 || tree_.knnSearch(q, 1, &i, &d) != 1) return false;
    index = std::int32_t(i);
    dist2 = d;
    return true;
  }

  /// Registers a scan and updates the map; returns the pose (sensor -> first frame).
  Eigen::Matrix4d registerScan(const std::vector<float>& scan) {
    const std::vector<float> pts =
        dw::voxelDownsample(dw::PointView::fromFloat(scan.data(), scan.size() / 3), 0.5);
    const Eigen::Matrix4d guess = pose_ * velocity_;
    Eigen::Matrix4d pose = pose_;
    if (live_count_ > 0) {
      pose = dw::alignIcp(*this, nullptr, pts.data(), pts.size() / 3, guess, icp_, ws_).transform;
    }
    velocity_ = pose_.inverse() * pose;
    pose_ = pose;
    const Eigen::Vector3d c = pose.topRightCorner<3, 1>();
    for (std::size_t i = 0; i < live_.size(); ++i) {
      if (!live_[i]) continue;
      const Eigen::Vector3d p(points_[3 * i], points_[3 * i + 1], points_[3 * i + 2]);
      if ((p - c).squaredNorm() > 60.0 * 60.0) {
        tree_.removePoint(std::uint32_t(i));
        live_[i] = 0, --live_count_;
        voxels_.erase(keys_[i]);
      }
    }
    const std::size_t first = size();
    for (std::size_t i = 0; i < pts.size() / 3; ++i) {
      float p[3];
      for (int r = 0; r < 3; ++r)
        p[r] = float(pose(r, 0) * pts[3 * i] + pose(r, 1) * pts[3 * i + 1] + pose(r, 2) * pts[3 * i + 2] +
                     pose(r, 3));
      std::uint64_t key = 0;
      for (int d = 0; d < 3; ++d)
        key = (key << 21) | (std::uint64_t(std::int64_t(std::floor(double(p[d]) / 0.5))) & ((1u << 21) - 1));
      if (!voxels_.emplace(key, size()).second) continue;
      points_.insert(points_.end(), p, p + 3);
      keys_.push_back(key);
      live_.push_back(1);
      ++live_count_;
    }
    if (size() > first) tree_.addPoints(std::uint32_t(first), std::uint32_t(size() - 1));
    return pose;
  }

 private:
  dw::IcpOptions icp_;
  std::vector<float> points_;
  FloatCloud cloud_{&points_};
  NanoIncrementalTree tree_{3, cloud_};
  std::unordered_map<std::uint64_t, std::size_t> voxels_;
  std::vector<std::uint64_t> keys_;
  std::vector<char> live_;
  std::size_t live_count_ = 0;
  dw::IcpWorkspace ws_;
  Eigen::Matrix4d pose_ = Eigen::Matrix4d::Identity(), velocity_ = Eigen::Matrix4d::Identity();
};

}  // namespace dw_bench
