// The ICP loop: it recovers known motions (point-to-point, point-to-plane, robust kernels), gives the
// poses of the same loop over brute-force nearest neighbours, and the same bits on any thread count.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <memory>
#include <random>
#include <thread>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/registration/icp.h"
#include "pcl_delaunay_walk/core/registration/map_normals.h"
#include "pcl_delaunay_walk/core/registration/walk_correspondence_search.h"
#include "sequence.h"

namespace {

/// Nearest neighbours by scanning every map point in the caller's float metric, ties by index.
class BruteForceSearch final : public dw::CorrespondenceSearch {
 public:
  explicit BruteForceSearch(std::vector<float> xyz) : xyz_(std::move(xyz)) {}
  std::size_t size() const override { return xyz_.size() / 3; }
  const float* point(std::size_t i) const override { return &xyz_[3 * i]; }
  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2]) || xyz_.empty()) return false;
    float best = std::numeric_limits<float>::infinity();
    std::int32_t bi = -1;
    for (std::size_t i = 0; i < size(); ++i) {
      const float* p = point(i);
      const float dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2];
      float r = 0.f;
      r += dx * dx;
      r += dy * dy;
      r += dz * dz;
      if (r < best) best = r, bi = std::int32_t(i);
    }
    index = bi;
    dist2 = best;
    return true;
  }

 private:
  std::vector<float> xyz_;
};

std::shared_ptr<dw::WalkCorrespondenceSearch> walkSearch(const std::vector<float>& xyz) {
  dw::BuildOptions opt;
  opt.num_threads = 2;
  auto g = std::make_shared<const dw::DelaunayGraph>(
      dw::buildDelaunayGraph(dw::PointView::fromFloat(xyz.data(), xyz.size() / 3), opt));
  return std::make_shared<dw::WalkCorrespondenceSearch>(
      std::make_shared<const dw::CallerMetricSearch>(g, xyz, std::vector<std::int32_t>{}));
}

Eigen::Matrix4d motion(double yaw, double pitch, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

/// The scene's points moved by `m^-1`: registering them back onto the scene must give m.
std::vector<float> movedBy(const std::vector<float>& xyz, const Eigen::Matrix4d& m, std::size_t every = 1) {
  const Eigen::Matrix4d inv = m.inverse();
  std::vector<float> out;
  for (std::size_t i = 0; i < xyz.size() / 3; i += every) {
    const Eigen::Vector4d p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 1.0);
    const Eigen::Vector4d s = inv * p;
    out.insert(out.end(), {float(s(0)), float(s(1)), float(s(2))});
  }
  return out;
}

TEST(IcpLoop, PointToPointRecoversAKnownMotion) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  const Eigen::Matrix4d truth = motion(0.05, 0.02, {0.3, -0.2, 0.1});
  const std::vector<float> scan = movedBy(scene, truth, 3);
  dw::IcpOptions o;
  o.max_iterations = 100;
  o.max_correspondence_distance = 2.0;
  dw::IcpWorkspace ws;
  const dw::IcpResult r =
      dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
  EXPECT_TRUE(r.converged) << dw::toString(r.convergence);
  EXPECT_LT(dw_test::translationError(r.transform, truth), 1e-4);
  EXPECT_LT(dw_test::rotationError(r.transform, truth), 1e-5);
  EXPECT_LT(r.mse, 1e-8);
  EXPECT_EQ(r.correspondences, scan.size() / 3);
}

TEST(IcpLoop, PointToPlaneRecoversAKnownMotion) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  const std::vector<float> normals = dw::computeMapNormals(search->callerSearch(), 10, 2);
  const Eigen::Matrix4d truth = motion(-0.04, 0.03, {-0.2, 0.25, 0.05});
  const std::vector<float> scan = movedBy(scene, truth, 3);
  dw::IcpOptions o;
  o.metric = dw::IcpMetric::PointToPlane;
  o.max_iterations = 50;
  o.max_correspondence_distance = 2.0;
  dw::IcpWorkspace ws;
  const dw::IcpResult r =
      dw::alignIcp(*search, normals.data(), scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
  EXPECT_TRUE(r.converged) << dw::toString(r.convergence);
  EXPECT_LT(dw_test::translationError(r.transform, truth), 1e-4);
  EXPECT_LT(dw_test::rotationError(r.transform, truth), 1e-5);
  EXPECT_LT(r.iterations, 50);
}

TEST(IcpLoop, RobustKernelsRecoverTheMotionDespiteOutliers) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  const Eigen::Matrix4d truth = motion(0.03, 0.0, {0.2, 0.1, 0.0});
  std::vector<float> scan = movedBy(scene, truth, 4);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-10.f, 10.f);
  const std::size_t outliers = scan.size() / 3 / 5;  // 20 % clutter within the correspondence distance
  for (std::size_t i = 0; i < outliers; ++i) scan.insert(scan.end(), {u(rng), u(rng), u(rng)});
  for (dw::RobustKernel k : {dw::RobustKernel::Huber, dw::RobustKernel::Cauchy}) {
    dw::IcpOptions o;
    o.max_iterations = 100;
    o.max_correspondence_distance = 1.0;
    o.kernel = k;
    o.kernel_scale = 0.05;
    dw::IcpWorkspace ws;
    const dw::IcpResult r =
        dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
    EXPECT_LT(dw_test::translationError(r.transform, truth), 5e-3) << int(k);
    EXPECT_LT(dw_test::rotationError(r.transform, truth), 5e-4) << int(k);
  }
}

TEST(IcpLoop, EqualsTheSameLoopOverBruteForceNeighbours) {
  std::vector<float> scene = dw_test::dragonScene();
  scene.resize(3 * 3000);  // brute force stays fast
  const auto walk = walkSearch(scene);
  const BruteForceSearch brute(scene);
  const std::vector<float> scan = movedBy(scene, motion(0.1, -0.05, {0.5, 0.2, -0.3}), 2);
  dw::IcpOptions o;
  o.max_iterations = 40;
  o.max_correspondence_distance = 1.5;
  dw::IcpWorkspace w1, w2;
  const dw::IcpResult a =
      dw::alignIcp(*walk, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, w1);
  const dw::IcpResult b =
      dw::alignIcp(brute, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, w2);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.convergence, b.convergence);
  EXPECT_EQ(a.correspondences, b.correspondences);
  EXPECT_EQ(a.transform, b.transform);  // same correspondences, same sums: the same bits
}

TEST(IcpLoop, SameBitsOnEveryThreadCount) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  const std::vector<float> scan = movedBy(scene, motion(0.02, 0.01, {0.1, 0.1, 0.1}), 2);
  Eigen::Matrix4d first;
  for (unsigned threads : {1u, 2u, 3u}) {
    dw::IcpOptions o;
    o.max_correspondence_distance = 1.0;
    o.num_threads = threads;
    dw::IcpWorkspace ws;
    const dw::IcpResult r =
        dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
    if (threads == 1)
      first = r.transform;
    else
      EXPECT_EQ(r.transform, first) << threads << " threads";
  }
}

TEST(IcpLoop, AWorkspaceKeepsItsThreadsAcrossCalls) {
  // The passes run on the workspace's team, so the workers' search scratch outlives a call; one
  // workspace reused with another thread count, or from another thread, gives the same poses.
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  const std::vector<float> scan = movedBy(scene, motion(0.02, 0.01, {0.1, 0.1, 0.1}), 2);
  dw::IcpOptions o;
  o.max_correspondence_distance = 1.0;
  auto align = [&](dw::IcpWorkspace& ws, unsigned threads) {
    o.num_threads = threads;
    return dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws)
        .transform;
  };
  dw::IcpWorkspace one;
  const Eigen::Matrix4d reference = align(one, 1);
  EXPECT_FALSE(one.team) << "one thread needs no team";
  dw::IcpWorkspace ws;
  EXPECT_EQ(align(ws, 3), reference);
  ASSERT_TRUE(ws.team);
  const dw::ThreadTeam* const team = ws.team.get();
  EXPECT_EQ(align(ws, 3), reference);
  EXPECT_EQ(ws.team.get(), team) << "the same thread count keeps the team";
  EXPECT_EQ(align(ws, 2), reference);
  EXPECT_EQ(ws.team_threads, 2u);
  Eigen::Matrix4d from_other;
  std::thread([&]() { from_other = align(ws, 2); }).join();
  EXPECT_EQ(from_other, reference);
}

TEST(IcpLoop, ConvergenceStatesFollowPcl) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  std::vector<float> scan = movedBy(scene, motion(0.02, 0.0, {0.2, 0.0, 0.0}), 5);
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.f, 0.01f);
  for (float& c : scan) c += noise(rng);  // the MSE levels off, so the relative test can end the loop
  dw::IcpWorkspace ws;
  dw::IcpOptions o;
  o.max_correspondence_distance = 1.0;
  o.max_iterations = 1;
  dw::IcpResult r =
      dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::Iterations);
  EXPECT_EQ(r.iterations, 1);
  o.max_iterations = 200;
  o.transformation_epsilon = 1e-6;
  r = dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::Transform);
  o.transformation_epsilon = 0;
  o.euclidean_fitness_epsilon = 0.2;
  r = dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, Eigen::Matrix4d::Identity(), o, ws);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::RelativeMse);
  // Far from the map: nothing within the distance, the guess comes back unchanged.
  Eigen::Matrix4d far = Eigen::Matrix4d::Identity();
  far(0, 3) = 500;
  r = dw::alignIcp(*search, nullptr, scan.data(), scan.size() / 3, far, o, ws);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::NoCorrespondences);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.transform, far);
}

TEST(IcpLoop, BadInputGivesStatusesOrErrors) {
  const std::vector<float> scene = dw_test::dragonScene();
  const auto search = walkSearch(scene);
  dw::IcpWorkspace ws;
  dw::IcpOptions o;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> bad = {nan, 0, 0, 1, nan, 2, std::numeric_limits<float>::infinity(), 0, 0};
  const dw::IcpResult r = dw::alignIcp(*search, nullptr, bad.data(), 3, Eigen::Matrix4d::Identity(), o, ws);
  EXPECT_EQ(r.valid_points, 0u);
  EXPECT_EQ(r.convergence, dw::IcpConvergence::NoCorrespondences);
  o.metric = dw::IcpMetric::PointToPlane;
  EXPECT_THROW(dw::alignIcp(*search, nullptr, bad.data(), 3, Eigen::Matrix4d::Identity(), o, ws), dw::Error);
  o.metric = dw::IcpMetric::PointToPoint;
  o.max_iterations = 0;
  EXPECT_THROW(dw::alignIcp(*search, nullptr, bad.data(), 3, Eigen::Matrix4d::Identity(), o, ws), dw::Error);
}

TEST(WalkCorrespondenceSearch, RetiredPointsAreNeverAnswered) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<float> xyz;
  for (int i = 0; i < 3000; ++i) xyz.insert(xyz.end(), {u(rng), u(rng), 0.2f * u(rng)});
  auto search = walkSearch(xyz);
  // Retire a block (the whole neighbourhood of the queries in it) and a scattering elsewhere.
  std::vector<std::uint8_t> retired(3000);
  std::vector<float> live;
  for (std::size_t i = 0; i < 3000; ++i) {
    retired[i] = (xyz[3 * i] < 0.3f && xyz[3 * i + 1] < 0.3f) || i % 7 == 0;
    if (!retired[i]) live.insert(live.end(), &xyz[3 * i], &xyz[3 * i] + 3);
  }
  search->setRetired(retired, std::numeric_limits<double>::infinity());
  const BruteForceSearch brute(live);
  for (int k = 0; k < 500; ++k) {
    const float q[3] = {u(rng), u(rng), 0.2f * u(rng)};
    dw::index_t hint = dw::kInvalidIndex, none = dw::kInvalidIndex;
    std::int32_t got = -1, want = -1;
    float d2 = 0, want_d2 = 0;
    ASSERT_TRUE(search->nearest(q, hint, got, d2));
    ASSERT_TRUE(brute.nearest(q, none, want, want_d2));
    EXPECT_FALSE(retired[std::size_t(got)]);
    EXPECT_EQ(d2, want_d2) << "query " << k;
  }
  // With a bound: a query in the retired block, whose nearest live point lies beyond the bound, has
  // no answer (the ICP loop drops a match beyond its maximum distance anyway).
  search->setRetired(retired, 0.01);
  const float q[3] = {0.1f, 0.1f, 0.1f};
  dw::index_t hint = dw::kInvalidIndex;
  std::int32_t got = -1;
  float d2 = 0;
  EXPECT_FALSE(search->nearest(q, hint, got, d2));
  EXPECT_THROW(search->setRetired(std::vector<std::uint8_t>(10), 1.0), dw::Error);
}

}  // namespace
