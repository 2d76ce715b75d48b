#include "pcl_delaunay_walk/core/registration/sliding_window_odometry.h"

#include <Eigen/LU>
#include <chrono>
#include <cmath>

#include "pcl_delaunay_walk/core/registration/voxel_downsample.h"

namespace dw {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
}  // namespace

SlidingWindowOdometry::SlidingWindowOdometry(const OdometryOptions& options) : options_(options) {
  if (!(options.voxel > 0)) throw Error("dw::SlidingWindowOdometry: voxel must be > 0");
  if (!(options.max_range > 0)) throw Error("dw::SlidingWindowOdometry: max_range must be > 0");
  if (!(options.compact_ratio >= 0)) throw Error("dw::SlidingWindowOdometry: compact_ratio must be >= 0");
  if (options.icp.metric != IcpMetric::PointToPoint)
    throw Error("dw::SlidingWindowOdometry: only point-to-point ICP (the map changes every frame)");
}

void SlidingWindowOdometry::setPose(const Eigen::Matrix4d& pose) {
  pose_ = pose;
  velocity_.setIdentity();
}

SlidingWindowOdometry::VoxelKey SlidingWindowOdometry::voxelOf(const float p[3]) const {
  // 21 bits per axis around the map origin: +-2^20 voxels (524 km at 0.5 m) before keys wrap, and a
  // wrapped key only merges two far-apart voxels (one point fewer), it never breaks the map.
  VoxelKey key = 0;
  for (int c = 0; c < 3; ++c) {
    const auto v = static_cast<std::int64_t>(std::floor(double(p[c]) / options_.voxel));
    key = (key << 21) | (static_cast<VoxelKey>(v) & ((VoxelKey(1) << 21) - 1));
  }
  return key;
}

FrameResult SlidingWindowOdometry::registerScan(const PointView& scan) {
  const auto t0 = Clock::now();
  FrameResult r;
  const Eigen::Matrix4d guess = pose_ * velocity_;
  r.pose = guess;
  auto finish = [&](FrameStatus status) {
    r.status = status;
    if (status != FrameStatus::Ok) r.pose = guess;
    velocity_ = pose_.inverse() * r.pose;
    pose_ = r.pose;
    ++frame_;
    r.latency_seconds = since(t0);
    return r;
  };
  if (scan.size == 0) return finish(FrameStatus::EmptyScan);
  const std::vector<float> pts = voxelDownsample(scan, options_.voxel);
  r.points = pts.size() / 3;
  if (r.points == 0) return finish(FrameStatus::NoFinitePoints);
  if (map_.size() == 0) {  // the first frame makes the map
    r.pose = pose_;
    r.fitness = 1.0;
    updateMap(pts, pose_);
    return finish(FrameStatus::Ok);
  }
  const auto tg = Clock::now();
  // Kept up to date by the map: only the points whose Delaunay star the last update changed are
  // re-read, then the graph is laid out again.
  std::vector<Id> ids;
  DelaunayGraph::ConstPtr graph = map_.walkGraph(retired_.empty() ? nullptr : &ids);
  std::vector<float> xyz(3 * graph->numInputPoints());
  // The map's origin is 0, so a vertex's local float position is its caller coordinate.
  for (std::size_t i = 0; i < graph->numInputPoints(); ++i) {
    const Vec3f& p = graph->points[graph->input_to_vertex[i]];
    xyz[3 * i] = p.x, xyz[3 * i + 1] = p.y, xyz[3 * i + 2] = p.z;
  }
  // The graph's vertex ids change every frame, so the kept hints are arbitrary vertices: a far one
  // is dropped for a KD-ANN start.
  WalkCorrespondenceSearch search(std::make_shared<const CallerMetricSearch>(std::move(graph), std::move(xyz),
                                                                             std::vector<std::int32_t>{}),
                                  StartStrategy::PnnOptimized,
                                  4.0 * options_.icp.max_correspondence_distance);
  if (!retired_.empty()) search.setRetired(retiredFlags(ids), options_.icp.max_correspondence_distance);
  stats_.graph_seconds += since(tg);
  IcpOptions icp = options_.icp;
  icp.num_threads = options_.num_threads;
  const IcpResult res = alignIcp(search, nullptr, pts.data(), r.points, guess, icp, workspace_);
  r.iterations = res.iterations;
  r.convergence = res.convergence;
  r.search_seconds = res.search_seconds;
  r.fitness = double(res.correspondences) / double(r.points);
  r.rmse = std::sqrt(res.mse);
  if (res.convergence == IcpConvergence::NoCorrespondences) return finish(FrameStatus::NoCorrespondences);
  r.pose = res.transform;
  if (!(r.fitness >= options_.min_fitness) || !r.pose.allFinite()) return finish(FrameStatus::LostTrack);
  updateMap(pts, r.pose);
  return finish(FrameStatus::Ok);
}

const DynamicDelaunayGraph& SlidingWindowOdometry::map() const {
  if (!retired_.empty()) compact();
  return map_;
}

std::vector<std::uint8_t> SlidingWindowOdometry::retiredFlags(const std::vector<Id>& ids) const {
  std::vector<std::uint8_t> flags(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) flags[i] = retired_.count(ids[i]) != 0;
  return flags;
}

void SlidingWindowOdometry::updateMap(const std::vector<float>& scan_points, const Eigen::Matrix4d& pose) {
  // Out before in, so that freed voxels fill.
  const auto tr = Clock::now();
  retire(pose.topRightCorner<3, 1>());
  stats_.remove_seconds += since(tr);
  const auto ti = Clock::now();
  std::vector<float> in;
  std::vector<VoxelKey> keys;
  selectNewPoints(scan_points, pose, in, keys);
  if (!keys.empty()) {
    const std::vector<Id> ids = map_.insert(PointView::fromFloat(in.data(), keys.size()));
    for (std::size_t i = 0; i < ids.size(); ++i) {
      voxels_[keys[i]] = ids[i];
      points_[ids[i]] = MapPoint{keys[i], frame_, {in[3 * i], in[3 * i + 1], in[3 * i + 2]}};
    }
  }
  stats_.inserted += keys.size();
  stats_.insert_seconds += since(ti);
  const auto tc = Clock::now();
  if (!retired_.empty() && double(retired_.size()) > options_.compact_ratio * double(points_.size()))
    compact();
  stats_.remove_seconds += since(tc);
}

void SlidingWindowOdometry::retire(const Eigen::Vector3d& sensor) {
  const double r2 = options_.max_range * options_.max_range;
  std::vector<Id> out;
  for (const auto& [id, mp] : points_) {
    const Eigen::Vector3d p(mp.xyz[0], mp.xyz[1], mp.xyz[2]);
    const bool old = options_.max_age != 0 && frame_ - mp.frame >= options_.max_age;
    if (old || (p - sensor).squaredNorm() > r2) out.push_back(id);
  }
  if (options_.compact_ratio == 0 && !out.empty()) map_.remove(out);
  for (Id id : out) {
    const auto it = points_.find(id);
    voxels_.erase(it->second.voxel);
    if (options_.compact_ratio != 0) retired_.emplace(id, it->second);
    points_.erase(it);
  }
  stats_.removed += out.size();
}

void SlidingWindowOdometry::selectNewPoints(const std::vector<float>& scan_points,
                                            const Eigen::Matrix4d& pose, std::vector<float>& in,
                                            std::vector<VoxelKey>& keys) {
  const std::size_t n = scan_points.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    const float* s = &scan_points[3 * i];
    float p[3];
    for (int c = 0; c < 3; ++c)
      p[c] = static_cast<float>(pose(c, 0) * s[0] + pose(c, 1) * s[1] + pose(c, 2) * s[2] + pose(c, 3));
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
    const VoxelKey key = voxelOf(p);
    if (!voxels_.emplace(key, DynamicDelaunayGraph::kNoId).second) continue;
    // Distinct voxels mean distinct live points; a retired point at this very position is still in
    // the triangulation, so it comes back instead of a duplicate going in.
    const Id back = retired_.empty() ? DynamicDelaunayGraph::kNoId : map_.idAt(Vec3f{p[0], p[1], p[2]});
    if (back != DynamicDelaunayGraph::kNoId) {
      MapPoint mp = retired_.at(back);
      mp.frame = frame_;
      retired_.erase(back);
      points_.emplace(back, mp);
      voxels_[key] = back;
      continue;
    }
    in.insert(in.end(), p, p + 3);
    keys.push_back(key);
  }
}

void SlidingWindowOdometry::compact() const {
  std::vector<float> xyz;
  std::vector<MapPoint> live;
  xyz.reserve(3 * points_.size());
  live.reserve(points_.size());
  for (const auto& kv : points_) {
    xyz.insert(xyz.end(), kv.second.xyz, kv.second.xyz + 3);
    live.push_back(kv.second);
  }
  DynamicDelaunayGraph fresh(std::array<double, 3>{{0.0, 0.0, 0.0}});
  const std::vector<Id> ids = fresh.insert(PointView::fromFloat(xyz.data(), live.size()));
  points_.clear();
  voxels_.clear();
  for (std::size_t i = 0; i < ids.size(); ++i) {
    points_.emplace(ids[i], live[i]);
    voxels_.emplace(live[i].voxel, ids[i]);
  }
  map_ = std::move(fresh);
  retired_.clear();
  ++stats_.compactions;
}

}  // namespace dw
