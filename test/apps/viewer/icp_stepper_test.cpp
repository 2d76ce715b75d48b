// dw_viewer's step-wise ICP: every correspondence is the exact nearest target point, stepping to the
// end gives stock pcl::IterativeClosestPoint's result, and the walk statistics behave as the seed says.

// GCC 12 -Warray-bounds false positives inside Eigen's umeyama (see apps/dw_viewer.cpp).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#endif

#include "viewer/icp_stepper.h"

#include <gtest/gtest.h>
#include <pcl/common/transforms.h>
#include <pcl/registration/icp.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "viewer/cloud_input.h"
#include "viewer/walk_path.h"

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/// Every `every`-th point of a bundled cloud: small enough for brute force in every iteration.
Cloud::Ptr bundled(const std::string& name, std::size_t every) {
  const auto pts = dw_viewer::loadXyz(std::string(DW_TEST_DATA_DIR) + "/" + name);
  dw_viewer::XyzPoints sub;
  for (std::size_t i = 0; i < pts.size(); i += every)
    sub.xyz.insert(sub.xyz.end(), pts.xyz.begin() + 3 * i, pts.xyz.begin() + 3 * i + 3);
  return dw_viewer::toCloud(sub, {{0, 0, 0}});
}

/// Brute-force nearest squared distance in the caller's float metric (FLANN's order of operations).
float bruteNearest(const Cloud& target, const pcl::PointXYZ& q) {
  float best = std::numeric_limits<float>::infinity();
  for (const auto& p : target) {
    const float dx = q.x - p.x, dy = q.y - p.y, dz = q.z - p.z;
    float d = 0.f;
    d += dx * dx;
    d += dy * dy;
    d += dz * dz;
    best = std::min(best, d);
  }
  return best;
}

/// Stock ICP with its iteration count visible.
class StockIcp : public pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> {
 public:
  int iterations() const { return nr_iterations_; }
};

class IcpStepperTest : public ::testing::Test {
 protected:
  void SetUp() override {
    target_ = bundled("bun000.ply", 8);
    source_ = bundled("bun045.ply", 8);
  }
  Cloud::Ptr target_, source_;
};

TEST_F(IcpStepperTest, CorrespondencesAreExactNearestForEveryStartStrategy) {
  for (auto strategy : {dw::StartStrategy::Zero, dw::StartStrategy::KdAnn, dw::StartStrategy::Pnn,
                        dw::StartStrategy::PnnOptimized}) {
    dw_viewer::IcpSettings s;
    s.max_iterations = 4;
    s.start = strategy;
    s.threads = 2;
    dw_viewer::IcpStepper icp(source_, target_, s);
    for (int it = 0; it <= 4; ++it) {
      const auto& corr = icp.correspondences();
      ASSERT_EQ(corr.size(), source_->size()) << "no distance limit: every point corresponds";
      for (const auto& c : corr) {
        const auto& q = icp.source()[c.index_query];
        ASSERT_EQ(c.distance, bruteNearest(*target_, q))
            << dw::toString(strategy) << " iteration " << it << " source " << c.index_query;
        const auto& t = (*target_)[c.index_match];
        const float dx = q.x - t.x, dy = q.y - t.y, dz = q.z - t.z;
        float d = 0.f;
        d += dx * dx;
        d += dy * dy;
        d += dz * dz;
        ASSERT_EQ(d, c.distance) << "the reported distance is the match's";
      }
      if (!icp.step()) break;
    }
  }
}

TEST_F(IcpStepperTest, SteppingToTheEndGivesStockIcp) {
  for (double max_distance : {std::sqrt(std::numeric_limits<double>::max()), 0.01}) {
    dw_viewer::IcpSettings s;
    s.max_iterations = 12;
    s.max_correspondence_distance = max_distance;
    s.transformation_epsilon = 1e-10;
    dw_viewer::IcpStepper icp(source_, target_, s);
    int steps = 0;
    while (icp.step()) ++steps;
    EXPECT_TRUE(icp.finished());
    EXPECT_EQ(steps, icp.iteration());

    StockIcp stock;
    stock.setInputSource(source_);
    stock.setInputTarget(target_);
    stock.setMaximumIterations(12);
    stock.setMaxCorrespondenceDistance(max_distance);
    stock.setTransformationEpsilon(1e-10);
    Cloud aligned;
    stock.align(aligned);
    EXPECT_EQ(icp.iteration(), stock.iterations()) << "max distance " << max_distance;
    EXPECT_EQ(icp.state(), stock.getConvergeCriteria()->getConvergenceState());
    EXPECT_TRUE(icp.finalTransformation().isApprox(stock.getFinalTransformation(), 1e-5f))
        << "stepper\n"
        << icp.finalTransformation() << "\nstock\n"
        << stock.getFinalTransformation();
    // The stepper's moved source is stock ICP's aligned output.
    ASSERT_EQ(aligned.size(), icp.source().size());
    for (std::size_t i = 0; i < aligned.size(); i += 97) EXPECT_NEAR(aligned[i].x, icp.source()[i].x, 1e-5f);
  }
}

TEST_F(IcpStepperTest, PnnWalksAreShorterThanTheFirstSearch) {
  // Seed §4: after the first iteration each walk starts at the previous correspondence.
  dw_viewer::IcpSettings s;
  s.max_iterations = 6;
  s.start = dw::StartStrategy::Pnn;  // Zero in the first search: long walks from one vertex
  dw_viewer::IcpStepper icp(source_, target_, s);
  const double first = icp.stats().meanWalk();
  EXPECT_GT(first, 3.0);
  std::uint64_t sum = 0;
  for (auto w : icp.walkLengths()) sum += w;
  EXPECT_EQ(sum, icp.stats().walk_steps);
  ASSERT_TRUE(icp.step());
  ASSERT_TRUE(icp.step());
  EXPECT_LT(icp.stats().meanWalk(), 0.5 * first);
  EXPECT_EQ(icp.stats().queries, source_->size());
}

TEST_F(IcpStepperTest, ResetReturnsToTheInitialPoseAndSearch) {
  dw_viewer::IcpSettings s;
  s.max_iterations = 5;
  dw_viewer::IcpStepper icp(source_, target_, s);
  const auto corr0 = icp.correspondences();
  const auto walks0 = icp.walkLengths();
  const double rms0 = icp.stats().rms;
  ASSERT_TRUE(icp.step());
  ASSERT_TRUE(icp.step());
  EXPECT_LT(icp.stats().rms, rms0) << "ICP lowers the error";
  icp.reset();
  EXPECT_EQ(icp.iteration(), 0);
  EXPECT_TRUE(icp.finalTransformation().isIdentity());
  EXPECT_EQ(icp.walkLengths(), walks0) << "the PNN cache is dropped: the first search repeats";
  ASSERT_EQ(icp.correspondences().size(), corr0.size());
  for (std::size_t k = 0; k < corr0.size(); ++k)
    EXPECT_EQ(icp.correspondences()[k].index_match, corr0[k].index_match);
  EXPECT_EQ(icp.stats().rms, rms0);
  for (std::size_t i = 0; i < source_->size(); i += 101) EXPECT_EQ(icp.source()[i].x, (*source_)[i].x);
}

TEST_F(IcpStepperTest, DistanceLimitAndTooFewCorrespondences) {
  dw_viewer::IcpSettings s;
  s.max_correspondence_distance = 0.004;
  dw_viewer::IcpStepper icp(source_, target_, s);
  std::size_t expected = 0;
  for (const auto& q : *source_) expected += bruteNearest(*target_, q) <= 0.004 * 0.004 ? 1 : 0;
  EXPECT_EQ(icp.correspondences().size(), expected);
  EXPECT_GT(expected, 0u);
  EXPECT_LT(expected, source_->size());

  // Move the source far away: no correspondence within the limit, so ICP stops (stock's rule).
  Cloud::Ptr far(new Cloud);
  pcl::transformPointCloud(*source_, *far, Eigen::Affine3f(Eigen::Translation3f(10.f, 0.f, 0.f)));
  dw_viewer::IcpStepper lost(far, target_, s);
  EXPECT_TRUE(lost.correspondences().empty());
  EXPECT_FALSE(lost.step());
  EXPECT_EQ(lost.state(), dw_viewer::IcpStepper::Criteria::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES);
  EXPECT_FALSE(lost.step()) << "stays stopped";
}

TEST_F(IcpStepperTest, BadInputIsAnError) {
  dw_viewer::IcpSettings s;
  EXPECT_THROW(dw_viewer::IcpStepper(Cloud::Ptr(new Cloud), target_, s), dw::Error);
  EXPECT_THROW(dw_viewer::IcpStepper(source_, Cloud::Ptr(), s), dw::Error);
  Cloud::Ptr nan(new Cloud(*source_));
  (*nan)[3].y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(dw_viewer::IcpStepper(nan, target_, s), dw::Error);
  s.max_iterations = 0;
  EXPECT_THROW(dw_viewer::IcpStepper(source_, target_, s), dw::Error);
  s.max_iterations = 3;
  s.max_correspondence_distance = -1;
  EXPECT_THROW(dw_viewer::IcpStepper(source_, target_, s), dw::Error);
}

TEST_F(IcpStepperTest, WalkPathIsTheWalk) {
  dw_viewer::IcpSettings s;
  dw_viewer::IcpStepper icp(source_, target_, s);
  const auto& g = icp.graph();
  const auto& search = icp.targetSearch().getCallerMetricSearch()->neighbourSearch();
  for (std::size_t i = 0; i < source_->size(); i += 13) {
    const auto& p = (*source_)[i];
    const dw::Vec3f q = g.toLocal(p.x, p.y, p.z);
    const dw::index_t start = static_cast<dw::index_t>((i * 7919) % g.numVertices());
    const auto path = dw_viewer::walkPath(g, q, start);
    const dw::WalkResult r = dw::walk(g, q, start);
    ASSERT_FALSE(path.empty());
    EXPECT_EQ(path.front(), start);
    EXPECT_EQ(path.back(), r.vertex);
    EXPECT_EQ(path.size(), r.steps + 1u);
    for (std::size_t k = 1; k < path.size(); ++k) {
      bool adjacent = false;
      for (dw::index_t e = g.offsets[path[k - 1]]; e < g.offsets[path[k - 1] + 1]; ++e)
        adjacent |= g.edges[e].j == path[k];
      EXPECT_TRUE(adjacent) << "each move follows a Delaunay edge";
      EXPECT_LT(dw::squaredDistance(q, g.points[path[k]]), dw::squaredDistance(q, g.points[path[k - 1]]));
    }
    // The walk the viewer draws for a source point ends at that point's correspondence.
    const dw::index_t s0 = search.startVertex(q, icp.startStrategy(), icp.hintsUsed()[i]);
    const auto drawn = dw_viewer::walkPath(g, q, s0);
    const dw::index_t matched = g.input_to_vertex[icp.correspondences()[i].index_match];
    if (matched !=
        drawn.back()) {  // only a near tie may end elsewhere (dw::CallerMetricSearch certifies in float)
      EXPECT_NEAR(dw::squaredDistance(q, g.points[drawn.back()]), dw::squaredDistance(q, g.points[matched]),
                  1e-9f)
          << "source " << i;
    }
    EXPECT_EQ(drawn.size(), icp.walkLengths()[i] + 1u) << "source " << i;
  }
}

}  // namespace
