// The walk in ICP gives the same final transformation as stock pcl::IterativeClosestPoint with its
// KdTree (element-wise within 1e-6, same iteration count), through both ways of installing it: stock
// ICP + CorrespondenceEstimationDelaunayWalk + KdTreeDelaunayWalk, and IterativeClosestPointDelaunayWalk.
// PCL's SVD transformation estimation, instantiated here, trips GCC 12 false positives inside Eigen.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#include <gtest/gtest.h>
#include <pcl/common/transforms.h>
#include <pcl/features/normal_3d.h>
#include <pcl/filters/filter.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_point_to_plane_lls.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"
#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"

namespace {

using P = pcl::PointXYZ;
using Cloud = pcl::PointCloud<P>;
using Matrix4 = Eigen::Matrix4f;

std::string shared(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}

Cloud::Ptr load(const std::string& rel) {
  const std::string path = shared(rel);
  if (!std::ifstream(path).good()) return nullptr;
  Cloud::Ptr c(new Cloud);
  if (path.substr(path.size() - 4) == ".pcd") {
    if (pcl::io::loadPCDFile(path, *c) < 0) return nullptr;
    return c;
  }
  const auto xyz = dw::readPointsXyz(path);
  for (std::size_t i = 0; i < xyz.size() / 3; ++i)
    c->push_back(P(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2])));
  return c;
}

Cloud::Ptr voxel(const Cloud::Ptr& c, float leaf) {
  Cloud::Ptr out(new Cloud);
  pcl::VoxelGrid<P> vg;
  vg.setInputCloud(c);
  vg.setLeafSize(leaf, leaf, leaf);
  vg.filter(*out);
  return out;
}

Matrix4 rpy(double roll_deg, double pitch_deg, double yaw_deg, Eigen::Vector3f t = Eigen::Vector3f::Zero()) {
  const double d = M_PI / 180.0;
  Eigen::Affine3f a = Eigen::Translation3f(t) *
                      Eigen::AngleAxisf(float(yaw_deg * d), Eigen::Vector3f::UnitZ()) *
                      Eigen::AngleAxisf(float(pitch_deg * d), Eigen::Vector3f::UnitY()) *
                      Eigen::AngleAxisf(float(roll_deg * d), Eigen::Vector3f::UnitX());
  return a.matrix();
}

struct IcpSetup {
  int max_iterations = 100;
  double transformation_epsilon = 1e-11;
  double max_correspondence_distance = std::numeric_limits<double>::max();
  bool reciprocal = false;
  Matrix4 guess = Matrix4::Identity();
};

template <typename Icp>
void configure(Icp& icp, const IcpSetup& s) {
  icp.setMaximumIterations(s.max_iterations);
  icp.setTransformationEpsilon(s.transformation_epsilon);
  icp.setMaxCorrespondenceDistance(s.max_correspondence_distance);
  icp.setUseReciprocalCorrespondences(s.reciprocal);
}

struct Outcome {
  Matrix4 transform;
  int iterations;
  bool converged;
  double fitness;
};

template <typename Icp>
Outcome run(Icp& icp, const Cloud::Ptr& source, const Cloud::Ptr& target, const IcpSetup& s) {
  configure(icp, s);
  icp.setInputSource(source);
  icp.setInputTarget(target);
  Cloud out;
  icp.align(out, s.guess);
  return {icp.getFinalTransformation(), icp.nr_iterations_, icp.hasConverged(), icp.getFitnessScore()};
}

// nr_iterations_ is protected; these expose it for the comparison.
struct StockIcp : pcl::IterativeClosestPoint<P, P> {
  using pcl::IterativeClosestPoint<P, P>::nr_iterations_;
};
struct WalkIcp : pcl::IterativeClosestPointDelaunayWalk<P, P> {
  using pcl::IterativeClosestPointDelaunayWalk<P, P>::nr_iterations_;
};

void expectSame(const Outcome& a, const Outcome& b, const std::string& what) {
  EXPECT_EQ(a.iterations, b.iterations) << what;
  EXPECT_EQ(a.converged, b.converged) << what;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(a.transform(r, c), b.transform(r, c), 1e-6) << what << " (" << r << "," << c << ")";
  EXPECT_NEAR(a.fitness, b.fitness, 1e-6 * std::max(1.0, a.fitness)) << what;
}

/// Stock ICP vs the two ways of installing the walk, on one problem.
void compareAll(const Cloud::Ptr& source, const Cloud::Ptr& target, const IcpSetup& s,
                const std::string& what) {
  StockIcp stock;
  const Outcome ref = run(stock, source, target, s);

  StockIcp with_ce;  // stock class, walk estimator and walk tree installed by the user
  auto tree = std::make_shared<pcl::search::KdTreeDelaunayWalk<P>>();
  auto ce = std::make_shared<pcl::registration::CorrespondenceEstimationDelaunayWalk<P, P>>();
  with_ce.setSearchMethodTarget(tree);
  with_ce.setCorrespondenceEstimation(ce);
  expectSame(ref, run(with_ce, source, target, s), what + " [stock ICP + walk estimator]");
  EXPECT_EQ(ce->getSearchMethodWalk(), tree->getDelaunayWalk()) << "estimator should share the tree's graph";

  WalkIcp walk;
  expectSame(ref, run(walk, source, target, s), what + " [IterativeClosestPointDelaunayWalk]");
  EXPECT_EQ(walk.getIterationStatistics().size(), static_cast<std::size_t>(walk.nr_iterations_)) << what;
}

Matrix4 bunny045ToBun000(std::istream& conf) {
  std::string line;
  while (std::getline(conf, line)) {
    std::istringstream ls(line);
    std::string kw, file;
    double t[3], q[4];
    if (ls >> kw >> file >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3] && file == "bun045.ply") {
      // p_common = R^T p + t with R from the quaternion (x, y, z, w) as written (data/README.md).
      const Eigen::Quaternionf rq{float(q[3]), float(q[0]), float(q[1]), float(q[2])};
      Matrix4 m = Matrix4::Identity();
      m.block<3, 3>(0, 0) = rq.toRotationMatrix().transpose();
      m.block<3, 1>(0, 3) = Eigen::Vector3f(float(t[0]), float(t[1]), float(t[2]));
      return m;
    }
  }
  return Matrix4::Zero();
}

double rotationErrorDeg(const Matrix4& a, const Matrix4& b) {
  const Eigen::Matrix3f r = a.block<3, 3>(0, 0).transpose() * b.block<3, 3>(0, 0);
  return std::acos(std::min(1.f, std::max(-1.f, (r.trace() - 1.f) / 2.f))) * 180.0 / M_PI;
}

}  // namespace

TEST(IcpDelaunayWalk, PclBunnyPair) {
  auto target = load("models/pcl_bun0.pcd"), source = load("models/pcl_bun4.pcd");
  if (!target || !source) GTEST_SKIP() << "shared data models/pcl_bun0.pcd / pcl_bun4.pcd absent";
  IcpSetup s;
  s.max_iterations = 50;
  s.transformation_epsilon = 1e-8;
  compareAll(source, target, s, "pcl_bun4->pcl_bun0");
}

TEST(IcpDelaunayWalk, StanfordBunnyScansAgainstTruePose) {
  auto target = load("models/bun000.ply"), source = load("models/bun045.ply");
  std::ifstream conf(shared("models/bun.conf"));
  if (!target || !source || !conf)
    GTEST_SKIP() << "shared data models/bun000.ply, bun045.ply, bun.conf absent";
  const Matrix4 truth = bunny045ToBun000(conf);
  ASSERT_FALSE(truth.isZero());
  target = voxel(target, 0.002f);
  source = voxel(source, 0.002f);
  IcpSetup s;
  s.max_correspondence_distance = 0.003;  // the scans overlap in part: far pairs would bias the pose
  s.guess = rpy(1.0, -1.0, 1.0, Eigen::Vector3f(0.002f, -0.001f, 0.001f)) * truth;  // a perturbed truth
  compareAll(source, target, s, "bun045->bun000");
  WalkIcp icp;
  const Outcome o = run(icp, source, target, s);
  std::printf("bunny: guess %.3f deg, result %.3f deg %.5f m, iterations %d\n",
              rotationErrorDeg(s.guess, truth), rotationErrorDeg(o.transform, truth),
              (o.transform.block<3, 1>(0, 3) - truth.block<3, 1>(0, 3)).norm(), o.iterations);
  auto within = [&](const Matrix4& m) {
    Cloud moved;
    pcl::transformPointCloud(*source, moved, m);
    pcl::search::KdTree<P> t;
    t.setInputCloud(target);
    pcl::Indices i;
    std::vector<float> d;
    std::size_t n = 0;
    for (const auto& p : moved) n += (t.nearestKSearch(p, 1, i, d) == 1 && d[0] < 1e-6f) ? 1 : 0;
    return double(n) / moved.size();
  };
  std::printf("within 1mm: truth %.3f result %.3f\n", within(truth), within(o.transform));
  // bun.conf's pose is itself a registration result; ICP lands within half a degree of it and fits
  // the data at least as well.
  EXPECT_GE(within(o.transform), within(truth) - 0.02);
  EXPECT_LT(rotationErrorDeg(o.transform, truth), 1.0);
  EXPECT_LT((o.transform.block<3, 1>(0, 3) - truth.block<3, 1>(0, 3)).norm(), 0.002);
}

TEST(IcpDelaunayWalk, DragonToItselfSeedProtocol) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  // Seed protocol: the model against itself rotated by -20..20 degrees in 10 degree steps about each
  // axis; max 100 iterations, transformation epsilon 1e-11 (all 125 combinations: the next test).
  for (int axis = 0; axis < 3; ++axis)
    for (int deg = -20; deg <= 20; deg += 10) {
      if (deg == 0 && axis > 0) continue;
      const Matrix4 m = rpy(axis == 0 ? deg : 0, axis == 1 ? deg : 0, axis == 2 ? deg : 0);
      Cloud::Ptr source(new Cloud);
      pcl::transformPointCloud(*dragon, *source, m);
      compareAll(source, dragon, IcpSetup(),
                 "dragon axis " + std::to_string(axis) + " " + std::to_string(deg) + " deg");
    }
}

TEST(IcpDelaunayWalk, DragonToItselfAllRotationCombinations) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  // The seed protocol's full grid: every (roll, pitch, yaw) in {-20, -10, 0, 10, 20} degrees, 125 runs
  // of stock ICP and of the subclass (every second point of res4, to keep ctest quick).
  Cloud::Ptr model(new Cloud);
  for (std::size_t i = 0; i < dragon->size(); i += 2) model->push_back((*dragon)[i]);
  for (int r = -20; r <= 20; r += 10)
    for (int p = -20; p <= 20; p += 10)
      for (int y = -20; y <= 20; y += 10) {
        Cloud::Ptr source(new Cloud);
        pcl::transformPointCloud(*model, *source, rpy(r, p, y));
        StockIcp stock;
        WalkIcp walk;
        const Outcome a = run(stock, source, model, IcpSetup()), b = run(walk, source, model, IcpSetup());
        const std::string what =
            "rpy " + std::to_string(r) + " " + std::to_string(p) + " " + std::to_string(y);
        EXPECT_EQ(a.converged, b.converged) << what;
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) EXPECT_NEAR(a.transform(i, j), b.transform(i, j), 1e-6) << what;
        // Exact ties between equidistant targets are broken as FLANN breaks them (docs/registration.md,
        // "Exactness and ties"), so even at epsilon 1e-11 the runs stop at the same iteration.
        EXPECT_EQ(a.iterations, b.iterations) << what;
      }
}

TEST(IcpDelaunayWalk, DragonWithNoisyTarget) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  Cloud::Ptr noisy(new Cloud(*dragon));
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.f, 0.0005f);  // ~0.2% of the model's extent
  for (auto& p : *noisy) p.x += g(rng), p.y += g(rng), p.z += g(rng);
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(10, -10, 10, Eigen::Vector3f(0.01f, 0.f, -0.005f)));
  compareAll(source, noisy, IcpSetup(), "dragon noisy target");
}

TEST(IcpDelaunayWalk, LidarFramePairAgainstGroundTruth) {
  auto target = load("scans/fastgicp_251370668.pcd"), source = load("scans/fastgicp_251371071.pcd");
  std::ifstream rel(shared("scans/fastgicp_relative.txt"));
  if (!target || !source || !rel) GTEST_SKIP() << "shared data scans/fastgicp_* absent";
  Matrix4 truth;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) rel >> truth(r, c);
  target = voxel(target, 0.5f);
  source = voxel(source, 0.5f);
  IcpSetup s;
  s.max_correspondence_distance = 1.0;
  s.transformation_epsilon = 1e-8;
  compareAll(source, target, s, "fastgicp pair");
  WalkIcp icp;
  const Outcome o = run(icp, source, target, s);
  EXPECT_LT(rotationErrorDeg(o.transform, truth), 0.5);
  EXPECT_LT((o.transform.block<3, 1>(0, 3) - truth.block<3, 1>(0, 3)).norm(), 0.1);
}

TEST(IcpDelaunayWalk, ReciprocalCorrespondences) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(0, 10, -10));
  IcpSetup s;
  s.reciprocal = true;
  s.max_correspondence_distance = 0.02;
  compareAll(source, dragon, s, "reciprocal");
}

TEST(IcpDelaunayWalk, SourceWithNaNs) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(10, 0, 10));
  Cloud::Ptr with_nan(new Cloud(*source));
  with_nan->is_dense = false;
  for (std::size_t i = 0; i < with_nan->size(); i += 13)
    (*with_nan)[i].x = std::numeric_limits<float>::quiet_NaN();
  Cloud::Ptr clean(new Cloud);
  pcl::Indices kept;
  pcl::removeNaNFromPointCloud(*with_nan, *clean, kept);
  // NaN source points get no correspondence, which is what stock ICP gives on the NaN-free cloud.
  StockIcp stock;
  const Outcome ref = run(stock, clean, dragon, IcpSetup());
  WalkIcp walk;
  expectSame(ref, run(walk, with_nan, dragon, IcpSetup()), "NaN source");
  EXPECT_EQ(walk.getIterationStatistics().front().queries, clean->size());
}

TEST(IcpDelaunayWalk, TargetChangesBetweenAligns) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  Cloud::Ptr source(new Cloud), other(new Cloud), copy(new Cloud(*dragon));
  pcl::transformPointCloud(*dragon, *source, rpy(5, 5, 5));
  pcl::transformPointCloud(*dragon, *other, rpy(0, 0, 30, Eigen::Vector3f(0.02f, 0.f, 0.f)));
  WalkIcp walk;
  StockIcp stock;
  expectSame(run(stock, source, dragon, IcpSetup()), run(walk, source, dragon, IcpSetup()), "first target");
  const auto& search = walk.getSearchMethodWalk();
  EXPECT_EQ(search->getNumberOfBuilds(), 1u);
  expectSame(run(stock, source, copy, IcpSetup()), run(walk, source, copy, IcpSetup()),
             "same content, new object");
  EXPECT_EQ(search->getNumberOfBuilds(), 1u) << "an unchanged target must keep its graph";
  EXPECT_EQ(walk.getGraphBuildSeconds(), 0.0);
  expectSame(run(stock, source, other, IcpSetup()), run(walk, source, other, IcpSetup()), "changed target");
  EXPECT_EQ(search->getNumberOfBuilds(), 2u);
  (*copy)[0].x += 1.f;  // mutated in place: same object, new content
  expectSame(run(stock, source, copy, IcpSetup()), run(walk, source, copy, IcpSetup()), "mutated target");
  EXPECT_EQ(search->getNumberOfBuilds(), 3u);
}

TEST(IcpDelaunayWalk, PrebuiltTargetGraph) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(-10, 10, 0));
  pcl::search::DelaunayWalk<P> map_search;
  map_search.setInputCloud(dragon);
  const std::string path = std::string(DW_BINARY_DIR) + "/test_registration_dragon.graph";
  map_search.saveGraph(path);
  WalkIcp walk;
  walk.loadTargetGraph(path);
  StockIcp stock;
  expectSame(run(stock, source, dragon, IcpSetup()), run(walk, source, dragon, IcpSetup()), "loaded graph");
  EXPECT_EQ(walk.getSearchMethodWalk()->getNumberOfBuilds(), 0u);
  // A graph of another cloud is refused with a clear error.
  WalkIcp wrong;
  wrong.setTargetGraph(map_search.getGraph());
  Cloud out;
  wrong.setInputSource(source);
  wrong.setInputTarget(source);
  EXPECT_THROW(wrong.align(out), dw::Error);
  std::remove(path.c_str());
}

TEST(IcpDelaunayWalk, OneVersusManyThreads) {
  auto dragon = load("models/dragon_vrip_res3.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res3.ply absent";
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(15, -5, 10));
  Matrix4 first;
  int first_iterations = 0;
  for (unsigned threads : {1u, 2u, 3u, 8u}) {
    WalkIcp walk;
    walk.setNumberOfThreads(threads);
    const Outcome o = run(walk, source, dragon, IcpSetup());
    if (threads == 1) {
      first = o.transform;
      first_iterations = o.iterations;
    } else {
      EXPECT_TRUE(o.transform == first) << threads << " threads: transformation differs bitwise";
      EXPECT_EQ(o.iterations, first_iterations);
    }
  }
  // The correspondences themselves, with many threads and a PNN cache in use.
  pcl::registration::CorrespondenceEstimationDelaunayWalk<P, P> a, b;
  a.setNumberOfThreads(1);
  b.setNumberOfThreads(4);
  for (auto* ce : {&a, &b}) {
    ce->setInputSource(source);
    ce->setInputTarget(dragon);
  }
  for (int round = 0; round < 2; ++round) {
    pcl::Correspondences ca, cb;
    a.determineCorrespondences(ca, 0.01);
    b.determineCorrespondences(cb, 0.01);
    ASSERT_EQ(ca.size(), cb.size());
    for (std::size_t i = 0; i < ca.size(); ++i) {
      ASSERT_EQ(ca[i].index_query, cb[i].index_query);
      ASSERT_EQ(ca[i].index_match, cb[i].index_match);
      ASSERT_EQ(ca[i].distance, cb[i].distance);
    }
  }
  EXPECT_LT(a.getStatistics()[1].meanWalkSteps(), a.getStatistics()[0].meanWalkSteps() + 1e-9)
      << "PNN starts should not walk further than the first round's KD-ANN starts";
}

TEST(IcpDelaunayWalk, CorrespondencesEqualStockEstimator) {
  auto dragon = load("models/dragon_vrip_res3.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res3.ply absent";
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(3, -4, 5, Eigen::Vector3f(0.002f, 0.f, 0.001f)));
  pcl::registration::CorrespondenceEstimation<P, P> stock;
  pcl::registration::CorrespondenceEstimationDelaunayWalk<P, P> walk;
  for (dw::StartStrategy s : {dw::StartStrategy::Zero, dw::StartStrategy::KdAnn, dw::StartStrategy::Pnn,
                              dw::StartStrategy::PnnOptimized}) {
    walk.setStartStrategy(s);
    for (double max_d : {0.002, 1e9}) {
      pcl::Correspondences a, b;
      stock.setInputSource(source);
      stock.setInputTarget(dragon);
      stock.determineCorrespondences(a, max_d);
      walk.setInputSource(source);
      walk.setInputTarget(dragon);
      walk.determineCorrespondences(b, max_d);
      ASSERT_EQ(a.size(), b.size());
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(a[i].index_query, b[i].index_query);
        ASSERT_EQ(a[i].distance, b[i].distance);
      }
      stock.determineReciprocalCorrespondences(a, max_d);
      walk.determineReciprocalCorrespondences(b, max_d);
      ASSERT_EQ(a.size(), b.size());
    }
  }
  // A target indices subset: correspondences are still indices into the full target.
  pcl::IndicesPtr every_third(new pcl::Indices);
  for (int i = 0; i < static_cast<int>(dragon->size()); i += 3) every_third->push_back(i);
  {
    pcl::Correspondences a, b;
    stock.setInputSource(source);
    stock.setInputTarget(dragon);
    stock.setIndicesTarget(every_third);
    stock.determineCorrespondences(a, 1e9);
    walk.setInputSource(source);
    walk.setInputTarget(dragon);
    walk.setIndicesTarget(every_third);
    walk.determineCorrespondences(b, 1e9);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a[i].index_match, b[i].index_match);
      ASSERT_EQ(a[i].index_match % 3, 0);
      ASSERT_EQ(a[i].distance, b[i].distance);
    }
    walk.setIndicesTarget(nullptr);
  }
  auto copy = walk.clone();
  pcl::Correspondences c1;
  copy->setInputSource(source);
  copy->setInputTarget(dragon);
  copy->determineCorrespondences(c1, 1e9);
  EXPECT_EQ(c1.size(), source->size());
}

TEST(IcpDelaunayWalk, PointToPlane) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  using PN = pcl::PointNormal;
  pcl::PointCloud<PN>::Ptr target(new pcl::PointCloud<PN>), source(new pcl::PointCloud<PN>);
  pcl::PointCloud<pcl::Normal> normals;
  pcl::NormalEstimation<P, pcl::Normal> ne;
  ne.setInputCloud(dragon);
  ne.setKSearch(12);
  ne.compute(normals);
  pcl::concatenateFields(*dragon, normals, *target);
  pcl::transformPointCloudWithNormals(*target, *source, rpy(5, -10, 5, Eigen::Vector3f(0.005f, 0.f, 0.f)));
  auto runP2P = [&](bool walk) {
    pcl::IterativeClosestPointWithNormals<PN, PN> icp;
    if (walk) {
      auto tree = std::make_shared<pcl::search::KdTreeDelaunayWalk<PN>>();
      icp.setSearchMethodTarget(tree);
      icp.setCorrespondenceEstimation(
          std::make_shared<pcl::registration::CorrespondenceEstimationDelaunayWalk<PN, PN>>());
    }
    icp.setMaximumIterations(60);
    icp.setTransformationEpsilon(1e-10);
    icp.setInputSource(source);
    icp.setInputTarget(target);
    pcl::PointCloud<PN> out;
    icp.align(out);
    return std::make_pair(Matrix4(icp.getFinalTransformation()), icp.hasConverged());
  };
  const auto a = runP2P(false), b = runP2P(true);
  EXPECT_EQ(a.second, b.second);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(a.first(r, c), b.first(r, c), 1e-5);
}

TEST(IcpDelaunayWalk, GeneralizedIcpWithWalkTrees) {
  auto dragon = load("models/dragon_vrip_res4.ply");
  if (!dragon) GTEST_SKIP() << "shared data models/dragon_vrip_res4.ply absent";
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*dragon, *source, rpy(5, 5, -5, Eigen::Vector3f(0.003f, 0.f, 0.f)));
  auto runGicp = [&](bool walk) {
    pcl::GeneralizedIterativeClosestPoint<P, P> gicp;
    if (walk) {
      // GICP searches the target tree directly (correspondences and covariances) and the source tree
      // for the source covariances: both become walks.
      gicp.setSearchMethodTarget(std::make_shared<pcl::search::KdTreeDelaunayWalk<P>>());
      gicp.setSearchMethodSource(std::make_shared<pcl::search::KdTreeDelaunayWalk<P>>());
    }
    gicp.setMaximumIterations(30);
    gicp.setInputSource(source);
    gicp.setInputTarget(dragon);
    Cloud out;
    gicp.align(out);
    return std::make_pair(Matrix4(gicp.getFinalTransformation()), gicp.getFitnessScore());
  };
  const auto a = runGicp(false), b = runGicp(true);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(a.first(r, c), b.first(r, c), 1e-5);
  EXPECT_NEAR(a.second, b.second, 1e-9);
}
