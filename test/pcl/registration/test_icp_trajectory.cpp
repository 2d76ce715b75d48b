// The walk ICP follows stock ICP's trajectory on the bundled pairs: the same number of iterations and
// final transforms within 1e-6, for the README's demo pair (bun045 onto bun000, whose scans share the
// scanner's grid, so the first iteration has exact ties between equidistant targets) and PCL's own
// bun4 onto bun0. The ties are reported, and breaking them by lowest index instead is what used to
// take the walk off stock's path.
// PCL's SVD transformation estimation, instantiated here, trips GCC 12 false positives inside Eigen.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/registration/icp.h>

#include <string>

#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"

namespace {

using P = pcl::PointXYZ;
using Cloud = pcl::PointCloud<P>;

Cloud::Ptr bundled(const std::string& name) {
  const std::string path = std::string(DW_TEST_DATA_DIR) + "/" + name;
  Cloud::Ptr c(new Cloud);
  if (name.size() > 4 && name.substr(name.size() - 4) == ".pcd") {
    EXPECT_EQ(pcl::io::loadPCDFile(path, *c), 0) << path;
    return c;
  }
  const std::vector<double> xyz = dw::readPointsXyz(path);
  for (std::size_t i = 0; i < xyz.size() / 3; ++i)
    c->push_back(P(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2])));
  return c;
}

template <typename Icp>
struct Exposed : Icp {
  using Icp::nr_iterations_;
};

struct Run {
  Eigen::Matrix4f transform;
  int iterations;
};

/// apps/dw_icp's settings (scripts/demo.sh: --max-iterations 50).
template <typename Icp>
Run align(Icp& icp, const Cloud::Ptr& source, const Cloud::Ptr& target, int max_iterations, double epsilon) {
  icp.setMaximumIterations(max_iterations);
  icp.setTransformationEpsilon(epsilon);
  icp.setEuclideanFitnessEpsilon(-std::numeric_limits<double>::max());
  icp.setInputSource(source);
  icp.setInputTarget(target);
  Cloud out;
  icp.align(out);
  return {icp.getFinalTransformation(), icp.nr_iterations_};
}

void expectStockTrajectory(const std::string& source_name, const std::string& target_name, int max_iterations,
                           double epsilon, std::size_t expected_ties_at_least) {
  const Cloud::Ptr source = bundled(source_name), target = bundled(target_name);
  Exposed<pcl::IterativeClosestPoint<P, P>> stock;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> walk;
  const Run a = align(stock, source, target, max_iterations, epsilon);
  const Run b = align(walk, source, target, max_iterations, epsilon);
  const std::string what = source_name + " -> " + target_name;
  EXPECT_EQ(b.iterations, a.iterations) << what;
  const float diff = (a.transform - b.transform).cwiseAbs().maxCoeff();
  EXPECT_LE(diff, 1e-6f) << what << ": max |T_walk - T_stock| = " << diff;
  const auto& ties = walk.getCorrespondenceEstimationWalk()->getTies();
  EXPECT_GE(ties.size(), expected_ties_at_least) << what;
  std::size_t stats_ties = 0;
  for (const auto& s : walk.getIterationStatistics()) stats_ties += s.ties;
  EXPECT_EQ(stats_ties, ties.size()) << what;
  // The walk's own answer is the lowest index among the tied targets; the kept one is one of them.
  for (const auto& t : ties) EXPECT_LE(t.lowest, t.chosen) << what;
}

TEST(IcpTrajectory, DemoPairBun045OntoBun000FollowsStock) {
  // 234 queries of the first iteration lie exactly midway between two target points.
  expectStockTrajectory("bun045.ply", "bun000.ply", 50, 1e-11, 200);
}

TEST(IcpTrajectory, PclBun4OntoBun0FollowsStock) {
  expectStockTrajectory("pcl_bun4.pcd", "pcl_bun0.pcd", 50, 1e-8, 0);
  expectStockTrajectory("pcl_bun4.pcd", "pcl_bun0.pcd", 100, 1e-11, 0);
}

TEST(IcpTrajectory, LowestIndexTiesLeaveTheTrajectoryAndAreReported) {
  // The rule the walk used before breaking ties as FLANN does: the same ties are found, other
  // targets are kept for some of them.
  const Cloud::Ptr source = bundled("bun045.ply"), target = bundled("bun000.ply");
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> walk;
  walk.getCorrespondenceEstimationWalk()->setTieBreak(pcl::registration::DelaunayWalkTieBreak::LowestIndex);
  align(walk, source, target, 1, 1e-11);
  const auto& ties = walk.getCorrespondenceEstimationWalk()->getTies();
  ASSERT_GE(ties.size(), 200u);
  for (const auto& t : ties) EXPECT_EQ(t.chosen, t.lowest);
  // Each reported tie is real: a second target at exactly the same FLANN distance.
  pcl::search::KdTree<P> tree;
  tree.setInputCloud(target);
  pcl::Indices idx;
  std::vector<float> d2;
  std::size_t other_pick = 0;
  for (const auto& t : ties) {
    ASSERT_EQ(tree.nearestKSearch((*source)[t.query], 1, idx, d2), 1);
    EXPECT_EQ(d2[0], t.sqr_distance);
    other_pick += idx[0] != t.lowest ? 1 : 0;
  }
  EXPECT_GT(other_pick, 0u) << "FLANN picks another of the tied targets for some of them";
}

}  // namespace
