// Sliding-window odometry: it follows a known trajectory, its window keeps to the range and age
// bounds, and the dynamic map after N frames has the edges of a fresh build of the same points.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "pcl_delaunay_walk/core/registration/sliding_window_odometry.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"
#include "sequence.h"

namespace {

using Id = dw::DynamicDelaunayGraph::PointId;

dw::OdometryOptions sceneOptions() {
  dw::OdometryOptions o;
  o.voxel = 0.15;
  o.max_range = 9.0;
  o.icp.max_correspondence_distance = 0.5;
  o.icp.max_iterations = 50;
  o.num_threads = 2;
  return o;
}

/// The poses relative to the first frame's: odometry's map frame is the first sensor frame.
std::vector<Eigen::Matrix4d> relative(const std::vector<Eigen::Matrix4d>& truth) {
  std::vector<Eigen::Matrix4d> out;
  for (const auto& t : truth) out.push_back(truth[0].inverse() * t);
  return out;
}

TEST(SlidingWindowOdometry, FollowsAKnownTrajectory) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(25, 0.25, 0.015);
  const auto rel = relative(truth);
  dw::SlidingWindowOdometry odo(sceneOptions());
  double worst = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const std::vector<float> scan = dw_test::cutScan(scene, truth[k], 8.0, unsigned(k + 11));
    const dw::FrameResult r = odo.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3));
    ASSERT_EQ(r.status, dw::FrameStatus::Ok) << "frame " << k;
    worst = std::max(worst, dw_test::translationError(r.pose, rel[k]));
  }
  // 25 frames, 6 m travelled: drift stays within a few centimetres.
  EXPECT_LT(worst, 0.06);
  EXPECT_GT(odo.mapStats().inserted, 0u);
  EXPECT_GT(odo.mapStats().removed, 0u);  // the range bound was active
}

TEST(SlidingWindowOdometry, WindowKeepsToRangeAndAge) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(6);
  dw::OdometryOptions o = sceneOptions();
  o.max_age = 3;
  o.max_range = 6.0;
  dw::SlidingWindowOdometry odo(o);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const std::vector<float> scan = dw_test::cutScan(scene, truth[k], 8.0, unsigned(k + 1));
    odo.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3));
    const Eigen::Vector3d sensor = odo.pose().topRightCorner<3, 1>();
    for (Id id : odo.map().liveIds()) {
      const auto p = odo.map().position(id);
      // Points arrive after the range cut, so a new one may lie up to the scan radius away.
      EXPECT_LT((Eigen::Vector3d(p[0], p[1], p[2]) - sensor).norm(), 8.5);
    }
  }
  odo.map().validate();
  EXPECT_GT(odo.mapStats().removed, 0u);
}

/// Undirected edges as pairs of ids (graph input i is ids[i]).
std::set<std::pair<Id, Id>> idEdges(const dw::DelaunayGraph& g, const std::vector<Id>& ids) {
  std::set<std::pair<Id, Id>> e;
  for (dw::index_t v = 0; v < g.numVertices(); ++v)
    for (dw::index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const Id a = ids[g.representative(v)], b = ids[g.representative(g.edges[k].j)];
      e.emplace(std::min(a, b), std::max(a, b));
    }
  return e;
}

TEST(SlidingWindowOdometry, MapAfterNFramesEqualsAFreshBuildOfTheWindow) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(8);
  dw::OdometryOptions o = sceneOptions();
  o.max_age = 3;
  dw::SlidingWindowOdometry odo(o);
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const std::vector<float> scan = dw_test::cutScan(scene, truth[k], 8.0, unsigned(k + 21));
    ASSERT_EQ(odo.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3)).status,
              dw::FrameStatus::Ok);
  }
  std::vector<Id> ids;
  const dw::DelaunayGraph live = odo.map().graph(&ids);
  ASSERT_TRUE(odo.map().triangulated());
  ASSERT_GT(ids.size(), 1000u);
  // The window's points built from scratch in one batch, in the same frame (origin 0) and so from the
  // same float coordinates. (buildDelaunayGraph recentres the points, and the rounding of the moved
  // coordinates flipped 1 of 134k edges of a near-cospherical set here: both graphs are exact for
  // the walk, but only equal coordinates give equal edges.)
  std::vector<float> xyz;
  for (Id id : ids) {
    const auto p = odo.map().position(id);
    xyz.insert(xyz.end(), {float(p[0]), float(p[1]), float(p[2])});
  }
  dw::DynamicDelaunayGraph fresh(std::array<double, 3>{{0.0, 0.0, 0.0}});
  const std::vector<Id> fresh_ids = fresh.insert(dw::PointView::fromFloat(xyz.data(), ids.size()));
  std::map<Id, Id> to_window;
  for (std::size_t i = 0; i < ids.size(); ++i) to_window[fresh_ids[i]] = ids[i];
  std::vector<Id> fresh_inputs;
  const dw::DelaunayGraph fresh_graph = fresh.graph(&fresh_inputs);
  for (Id& id : fresh_inputs) id = to_window.at(id);
  EXPECT_EQ(fresh_graph.numVertices(), live.numVertices());
  EXPECT_EQ(idEdges(fresh_graph, fresh_inputs), idEdges(live, ids));
  // And the live graph answers exact nearest neighbours.
  auto shared = std::make_shared<const dw::DelaunayGraph>(live);
  dw::NeighbourSearch search(shared);
  std::mt19937 rng(9);
  std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1);
  std::normal_distribution<float> off(0.f, 0.3f);
  for (int q = 0; q < 200; ++q) {
    const std::size_t a = pick(rng);
    const dw::Vec3f p{xyz[3 * a] + off(rng), xyz[3 * a + 1] + off(rng), xyz[3 * a + 2] + off(rng)};
    double best = 1e300;
    for (const dw::Vec3f& v : live.points) best = std::min(best, dw::squaredDistanceD(p, v));
    EXPECT_EQ(dw::squaredDistanceD(p, live.points[search.nearest(p).vertex]), best);
  }
}

TEST(SlidingWindowOdometry, BadFramesLeaveTheMapAlone) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(2);
  dw::SlidingWindowOdometry odo(sceneOptions());
  const std::vector<float> first = dw_test::cutScan(scene, truth[0], 8.0, 1);
  odo.registerScan(dw::PointView::fromFloat(first.data(), first.size() / 3));
  const std::size_t size = odo.map().size();
  const std::vector<float> nans(30, std::numeric_limits<float>::quiet_NaN());
  EXPECT_EQ(odo.registerScan(dw::PointView::fromFloat(nans.data(), 10)).status,
            dw::FrameStatus::NoFinitePoints);
  EXPECT_EQ(odo.registerScan(dw::PointView::fromFloat(nans.data(), 0)).status, dw::FrameStatus::EmptyScan);
  std::vector<float> far = first;
  for (std::size_t i = 0; i < far.size(); i += 3) far[i] += 500.f;
  EXPECT_EQ(odo.registerScan(dw::PointView::fromFloat(far.data(), far.size() / 3)).status,
            dw::FrameStatus::NoCorrespondences);
  EXPECT_EQ(odo.map().size(), size);
  EXPECT_THROW(
      [] {
        dw::OdometryOptions bad;
        bad.voxel = 0;
        dw::SlidingWindowOdometry x(bad);
      }(),
      dw::Error);
  EXPECT_THROW(
      [] {
        dw::OdometryOptions bad;
        bad.compact_ratio = -1;
        dw::SlidingWindowOdometry x(bad);
      }(),
      dw::Error);
}

TEST(SlidingWindowOdometry, RetiringGivesTheTrajectoryOfDeletingEveryFrame) {
  // Retired points stay in the triangulation until a compaction but are never a correspondence, so
  // every policy finds the same exact neighbours and so the same poses.
  const std::vector<float> scene = dw_test::dragonScene();
  const auto truth = dw_test::arcTrajectory(7, 0.25, 0.015);
  std::vector<std::vector<Eigen::Matrix4d>> poses;
  std::vector<std::size_t> sizes;
  for (double ratio : {0.0, 1.0, 0.02}) {
    dw::OdometryOptions o = sceneOptions();
    o.max_range = 6.0;
    o.max_age = 4;
    o.compact_ratio = ratio;
    dw::SlidingWindowOdometry odo(o);
    poses.emplace_back();
    for (std::size_t k = 0; k < truth.size(); ++k) {
      const std::vector<float> scan = dw_test::cutScan(scene, truth[k], 8.0, unsigned(k + 31));
      const dw::FrameResult r = odo.registerScan(dw::PointView::fromFloat(scan.data(), scan.size() / 3));
      ASSERT_EQ(r.status, dw::FrameStatus::Ok) << "ratio " << ratio << " frame " << k;
      poses.back().push_back(r.pose);
    }
    if (ratio == 0.0) {
      EXPECT_EQ(odo.retiredSize(), 0u);
    } else if (ratio == 0.02) {
      EXPECT_GT(odo.mapStats().compactions, 1u);
    }
    EXPECT_GT(odo.mapStats().removed, 0u);
    sizes.push_back(odo.mapSize());
    EXPECT_EQ(odo.map().size(), odo.mapSize());  // map() compacts: the live points only
    EXPECT_EQ(odo.retiredSize(), 0u);
    odo.map().validate();
  }
  for (std::size_t p = 1; p < poses.size(); ++p) {
    EXPECT_EQ(sizes[p], sizes[0]);
    for (std::size_t k = 0; k < truth.size(); ++k)
      EXPECT_LT((poses[p][k] - poses[0][k]).cwiseAbs().maxCoeff(), 1e-9) << "policy " << p << " frame " << k;
  }
}

}  // namespace
