// dw::gpu::IterativeClosestPoint against the host reference that follows PCL's rules, on real data
// (dragon, bunny scans, a LiDAR frame pair), plus the batched form, PCL's edge semantics and bad input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <fstream>
#include <memory>

#include "gpu_test_support.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "reference_icp.h"

namespace {

using dw::gpu::ConvergenceState;
using dw::gpu::DelaunayWalk;
using dw::gpu::IcpParameters;
using dw::gpu::IterativeClosestPoint;
using dwgpu_test::fromEigen;
using dwgpu_test::toEigen;

struct Target {
  std::shared_ptr<const dw::DelaunayGraph> graph;
  std::unique_ptr<dw::NeighbourSearch> cpu;
  DelaunayWalk::Ptr gpu;
  explicit Target(const std::vector<double>& xyz) {
    graph = std::make_shared<const dw::DelaunayGraph>(
        dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3)));
    cpu = std::make_unique<dw::NeighbourSearch>(graph);
    gpu = std::make_shared<DelaunayWalk>(*graph);
  }
};

std::vector<double> transformed(const std::vector<double>& xyz, const Eigen::Matrix4d& m) {
  std::vector<double> out(xyz.size());
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    const Eigen::Vector3d p =
        m.topLeftCorner<3, 3>() * Eigen::Vector3d(xyz[i], xyz[i + 1], xyz[i + 2]) + m.topRightCorner<3, 1>();
    out[i] = p.x();
    out[i + 1] = p.y();
    out[i + 2] = p.z();
  }
  return out;
}

Eigen::Matrix4d motion(double angle, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

/// GPU result against the host reference: element-wise within 1e-4 (the module's bar, docs/gpu.md).
void expectSameAsReference(const Target& target, const std::vector<double>& source, const IcpParameters& p,
                           const Eigen::Matrix4d& guess, const char* what) {
  const auto ref = dwgpu_test::referenceIcp(*target.cpu, source, p, guess);
  IterativeClosestPoint icp(target.gpu);
  icp.setParameters(p);
  icp.setInputSource(dw::PointView::fromDouble(source.data(), source.size() / 3));
  const auto res = icp.align(fromEigen(guess));
  const Eigen::Matrix4d got = toEigen(res.transformation);
  std::printf(
      "[%s] reference: %d iterations (%s); GPU: %d iterations (%s), %u correspondences, MSE %.3g; "
      "max |diff| %.2e\n",
      what, ref.iterations, dw::gpu::toString(ref.state), res.iterations, dw::gpu::toString(res.state),
      res.correspondences, res.mse, (got - ref.transformation).cwiseAbs().maxCoeff());
  EXPECT_TRUE(got.isApprox(got, 0.0));
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(got(r, c), ref.transformation(r, c), 1e-4) << what << " element (" << r << "," << c << ")";
  EXPECT_EQ(res.converged, ref.converged) << what;
  EXPECT_NEAR(res.iterations, ref.iterations, 1) << what;
}

class GpuIcp : public ::testing::Test {
 protected:
  void SetUp() override { DW_REQUIRE_CUDA_DEVICE(); }
};

TEST_F(GpuIcp, DragonMatchesReferenceAndRecoversTheMotion) {
  const std::string tp = dwgpu_test::dataPath("models/dragon_vrip_res3.ply");
  const std::string sp = dwgpu_test::dataPath("models/dragon_vrip_res4.ply");
  DW_REQUIRE_DATA(tp);
  DW_REQUIRE_DATA(sp);
  Target target(dwgpu_test::readXyz(tp));
  const Eigen::Matrix4d m = motion(0.07, {0.3, 1.0, 0.2}, {0.004, -0.003, 0.002});
  const auto source = transformed(dwgpu_test::readXyz(sp), m);
  IcpParameters p;
  p.max_iterations = 50;
  p.max_correspondence_distance = 0.02;
  p.transformation_epsilon = 1e-12;
  p.euclidean_fitness_epsilon = 1e-7;
  expectSameAsReference(target, source, p, Eigen::Matrix4d::Identity(), "dragon 5k->23k");

  IterativeClosestPoint icp(target.gpu);
  icp.setParameters(p);
  icp.setInputSource(dw::PointView::fromDouble(source.data(), source.size() / 3));
  const Eigen::Matrix4d got = toEigen(icp.align().transformation);
  // res4 and res3 are different decimations of one surface: the motion comes back to ~1e-3.
  EXPECT_LT((got * m - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(), 5e-3);
}

TEST_F(GpuIcp, BunnyScansMatchReference) {
  const std::string tp = dwgpu_test::dataPath("models/bun000.ply");
  const std::string sp = dwgpu_test::dataPath("models/bun045.ply");
  DW_REQUIRE_DATA(tp);
  DW_REQUIRE_DATA(sp);
  Target target(dwgpu_test::readXyz(tp));
  const auto source = dwgpu_test::readXyz(sp);
  // Ground truth from bun.conf (p_000 = R^T p_045 + t, data/README.md), perturbed as a rough guess.
  const Eigen::Quaterniond q(0.955586, 0.00548449, -0.294635, -0.0038555);
  Eigen::Matrix4d gt = Eigen::Matrix4d::Identity();
  gt.topLeftCorner<3, 3>() = q.toRotationMatrix().transpose();
  gt.topRightCorner<3, 1>() = Eigen::Vector3d(-0.0520211, -0.000383981, -0.0109223);
  const Eigen::Matrix4d guess = motion(0.03, {1, 0, 0}, {0.003, 0.002, -0.002}) * gt;
  IcpParameters p;
  p.max_iterations = 40;
  p.max_correspondence_distance = 0.01;
  p.transformation_epsilon = 1e-12;
  p.euclidean_fitness_epsilon = 1e-7;
  expectSameAsReference(target, source, p, guess, "bunny bun045->bun000");
}

TEST_F(GpuIcp, LidarFramePairMatchesReference) {
  const std::string tp = dwgpu_test::dataPath("scans/fastgicp_251370668.pcd");
  const std::string sp = dwgpu_test::dataPath("scans/fastgicp_251371071.pcd");
  DW_REQUIRE_DATA(tp);
  DW_REQUIRE_DATA(sp);
  Target target(dwgpu_test::readXyz(tp));
  const auto source = dwgpu_test::readXyz(sp);
  IcpParameters p;
  p.max_iterations = 40;
  p.max_correspondence_distance = 1.0;
  p.transformation_epsilon = 1e-10;
  p.euclidean_fitness_epsilon = 1e-7;
  expectSameAsReference(target, source, p, Eigen::Matrix4d::Identity(), "LiDAR 251371071->251370668");
}

TEST_F(GpuIcp, BatchEqualsOneByOne) {
  const std::string tp = dwgpu_test::dataPath("models/dragon_vrip_res3.ply");
  const std::string sp = dwgpu_test::dataPath("models/dragon_vrip_res4.ply");
  DW_REQUIRE_DATA(tp);
  DW_REQUIRE_DATA(sp);
  Target target(dwgpu_test::readXyz(tp));
  const auto base = dwgpu_test::readXyz(sp);
  std::vector<std::vector<double>> sources;
  for (int s = 0; s < 5; ++s)
    sources.push_back(
        transformed(base, motion(0.02 * (s + 1), {1.0, 0.5 * s, 0.3}, {0.001 * s, 0.002, -0.001 * s})));
  sources.emplace_back();  // an empty source: no correspondences, as PCL reports it
  IcpParameters p;
  p.max_iterations = 30;
  p.max_correspondence_distance = 0.02;
  p.transformation_epsilon = 1e-12;
  p.euclidean_fitness_epsilon = 1e-7;
  // Both ways of moving the source: each moved point depends on its own source's steps only.
  for (bool moved : {false, true}) {
    p.move_source_in_float = moved;
    IterativeClosestPoint batch(target.gpu);
    batch.setParameters(p);
    for (const auto& s : sources) batch.addSource(dw::PointView::fromDouble(s.data(), s.size() / 3));
    std::vector<dw::gpu::Matrix4d> guesses(sources.size(), dw::gpu::identityMatrix4d());
    guesses[1][3] = 0.001;  // one non-identity guess
    const auto all = batch.alignAll(guesses);
    ASSERT_EQ(all.size(), sources.size());
    for (std::size_t s = 0; s + 1 < sources.size(); ++s) {
      IterativeClosestPoint one(target.gpu);
      one.setParameters(p);
      one.setInputSource(dw::PointView::fromDouble(sources[s].data(), sources[s].size() / 3));
      const auto r = one.align(guesses[s]);
      // same arithmetic, same order
      EXPECT_EQ(r.transformation, all[s].transformation) << "source " << s << " moved " << moved;
      EXPECT_EQ(r.iterations, all[s].iterations);
      EXPECT_EQ(r.state, all[s].state);
      EXPECT_GT(r.iterations, 1);
    }
    EXPECT_EQ(all.back().state, ConvergenceState::NoCorrespondences);
    EXPECT_FALSE(all.back().converged);
    EXPECT_EQ(all.back().iterations, 0);
    EXPECT_EQ(all.back().transformation, dw::gpu::identityMatrix4d());
  }
}

TEST_F(GpuIcp, PclLoopSemantics) {
  Target target(dwgpu_test::randomCloud(3000, 8));
  const auto source = transformed(dwgpu_test::randomCloud(1000, 9), motion(0.05, {0, 0, 1}, {0.01, 0, 0}));
  IterativeClosestPoint icp(target.gpu);
  icp.setInputSource(dw::PointView::fromDouble(source.data(), source.size() / 3));
  IcpParameters p;
  p.max_iterations = 0;  // PCL's loop is do-while: one iteration still runs
  icp.setParameters(p);
  auto r = icp.align();
  EXPECT_EQ(r.iterations, 1);
  EXPECT_EQ(r.state, ConvergenceState::Iterations);
  EXPECT_TRUE(r.converged);
  p.max_iterations = 3;
  p.failure_after_max_iterations = true;
  icp.setParameters(p);
  r = icp.align();
  EXPECT_EQ(r.iterations, 3);
  EXPECT_EQ(r.state, ConvergenceState::FailureAfterMaxIterations);
  EXPECT_FALSE(r.converged);
  p.failure_after_max_iterations = false;
  p.max_correspondence_distance = 1e-9;  // nothing within reach
  icp.setParameters(p);
  r = icp.align();
  EXPECT_EQ(r.state, ConvergenceState::NoCorrespondences);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_FALSE(r.converged);
  // Same settings through the reference: identical semantics.
  for (int it : {1, 4}) {
    p.max_iterations = it;
    p.max_correspondence_distance = 0.2;
    expectSameAsReference(target, source, p, Eigen::Matrix4d::Identity(), "random cloud, capped iterations");
  }
}

TEST_F(GpuIcp, BadInputThrows) {
  Target target(dwgpu_test::randomCloud(200, 3));
  IterativeClosestPoint icp(target.gpu);
  EXPECT_THROW(icp.align(), dw::Error);  // no source
  const auto s = dwgpu_test::randomCloud(100, 4);
  icp.addSource(dw::PointView::fromDouble(s.data(), 100));
  icp.addSource(dw::PointView::fromDouble(s.data(), 100));
  EXPECT_THROW(icp.align(), dw::Error);                                  // two sources: use alignAll
  EXPECT_THROW(icp.alignAll({dw::gpu::identityMatrix4d()}), dw::Error);  // one guess for two sources
  auto bad = dw::gpu::identityMatrix4d();
  bad[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(icp.alignAll({bad, bad}), dw::Error);
  IcpParameters p;
  p.move_source_in_float = true;  // the sources were added centred: align refuses until re-added
  icp.setParameters(p);
  EXPECT_THROW(icp.alignAll(), dw::Error);
  icp.clearSources();
  icp.addSource(dw::PointView::fromDouble(s.data(), 100));
  EXPECT_NO_THROW(icp.align());
  p.max_correspondence_distance = -1.0;
  EXPECT_THROW(icp.setParameters(p), dw::Error);
  EXPECT_THROW(IterativeClosestPoint(nullptr), dw::Error);
}

}  // namespace
