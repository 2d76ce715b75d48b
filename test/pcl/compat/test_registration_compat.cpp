// What PCL 1.13's test/registration/test_registration.cpp checks of ICP, run through both ways we
// ship the walk into registration: IterativeClosestPointDelaunayWalk, and a stock ICP class with
// CorrespondenceEstimationDelaunayWalk + KdTreeDelaunayWalk installed. Variants: point-to-point,
// WithNormals (point-to-plane), NonLinear (Levenberg-Marquardt), rejectors, reciprocal
// correspondences, point representations (2-D and 4-D), getFitnessScore. Each must follow stock
// ICP's trajectory: the same iteration count, the same convergence, transforms within 1e-6.
// PCL's SVD and LM estimators, instantiated here, trip GCC 12 false positives inside Eigen.
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <gtest/gtest.h>
#include <pcl/common/transforms.h>
#include <pcl/features/normal_3d.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/correspondence_rejection_median_distance.h>
#include <pcl/registration/correspondence_rejection_one_to_one.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/icp_nl.h>

#include <Eigen/Geometry>

#include "compat_util.h"
#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"
#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"

namespace {

using namespace dw_compat;
using PN = pcl::PointNormal;
using Matrix4 = Eigen::Matrix4f;

/// nr_iterations_ is protected: this exposes it for the comparison.
template <typename Icp>
struct Exposed : Icp {
  using Icp::nr_iterations_;
};

struct Outcome {
  Matrix4 transform;
  int iterations = 0;
  bool converged = false;
  double fitness = 0.0;
};

template <typename Icp, typename Cloud>
Outcome alignOnce(Icp& icp, const Cloud& source, const Cloud& target, const Matrix4& guess) {
  icp.setInputSource(source);
  icp.setInputTarget(target);
  typename Icp::PointCloudSource out;
  icp.align(out, guess);
  EXPECT_EQ(out.size(), source->size());
  return {icp.getFinalTransformation(), icp.nr_iterations_, icp.hasConverged(), icp.getFitnessScore()};
}

void expectSameTrajectory(const Outcome& stock, const Outcome& walk, const std::string& what) {
  EXPECT_EQ(walk.iterations, stock.iterations) << what;
  EXPECT_EQ(walk.converged, stock.converged) << what;
  const float diff = (walk.transform - stock.transform).cwiseAbs().maxCoeff();
  EXPECT_LE(diff, 1e-6f) << what << ": max |T_walk - T_stock| = " << diff;
  EXPECT_NEAR(walk.fitness, stock.fitness, 1e-9 + 1e-6 * stock.fitness) << what << ": getFitnessScore";
}

/// The stock class with the walk installed by hand (the route for any ICP variant).
template <typename Icp, typename PointT>
void installWalk(Icp& icp) {
  auto tree = std::make_shared<pcl::search::KdTreeDelaunayWalk<PointT>>();
  auto ce = std::make_shared<pcl::registration::CorrespondenceEstimationDelaunayWalk<PointT, PointT>>();
  icp.setSearchMethodTarget(tree);
  icp.setCorrespondenceEstimation(ce);
}

/// PCL's registration pair: bun4 onto bun0 (data/pcl_bun*.pcd, PCL's own test files).
struct BunnyPair {
  Cloud::Ptr source = loadData("pcl_bun4.pcd");
  Cloud::Ptr target = loadData("pcl_bun0.pcd");
};

template <typename Icp>
void configurePcl(Icp& icp) {
  // test_registration.cpp's settings for this pair.
  icp.setMaximumIterations(50);
  icp.setTransformationEpsilon(1e-8);
  icp.setMaxCorrespondenceDistance(0.05);
}

TEST(RegistrationCompat, IterativeClosestPointBothRoutes) {
  BunnyPair d;
  for (const double max_distance : {0.05, 1e10}) {
    Exposed<pcl::IterativeClosestPoint<P, P>> stock, installed;
    Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> subclass;
    configurePcl(stock), configurePcl(installed), configurePcl(subclass);
    for (auto* icp : std::initializer_list<pcl::IterativeClosestPoint<P, P>*>{&stock, &installed, &subclass})
      icp->setMaxCorrespondenceDistance(max_distance);
    installWalk<decltype(installed), P>(installed);
    const Outcome ref = alignOnce(stock, d.source, d.target, Matrix4::Identity());
    const std::string what = "max distance " + std::to_string(max_distance);
    expectSameTrajectory(ref, alignOnce(installed, d.source, d.target, Matrix4::Identity()),
                         what + " installed");
    expectSameTrajectory(ref, alignOnce(subclass, d.source, d.target, Matrix4::Identity()),
                         what + " subclass");
    // A second align() from a guess, as test_registration does: the graph is kept, the path the same.
    Matrix4 guess = Matrix4::Identity();
    guess.block<3, 1>(0, 3) << 0.01f, -0.005f, 0.002f;
    const Outcome ref2 = alignOnce(stock, d.source, d.target, guess);
    expectSameTrajectory(ref2, alignOnce(subclass, d.source, d.target, guess), what + " guess");
    EXPECT_EQ(subclass.getSearchMethodWalk()->getNumberOfBuilds(), 1u);
  }
}

TEST(RegistrationCompat, ReciprocalCorrespondences) {
  BunnyPair d;
  Exposed<pcl::IterativeClosestPoint<P, P>> stock;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> subclass;
  for (auto* icp : std::initializer_list<pcl::IterativeClosestPoint<P, P>*>{&stock, &subclass}) {
    configurePcl(*icp);
    icp->setUseReciprocalCorrespondences(true);
  }
  expectSameTrajectory(alignOnce(stock, d.source, d.target, Matrix4::Identity()),
                       alignOnce(subclass, d.source, d.target, Matrix4::Identity()), "reciprocal");
}

TEST(RegistrationCompat, CorrespondenceEstimatorsAgreeForwardAndReciprocal) {
  BunnyPair d;
  pcl::registration::CorrespondenceEstimation<P, P> stock;
  pcl::registration::CorrespondenceEstimationDelaunayWalk<P, P> walk;
  for (auto* ce :
       std::initializer_list<pcl::registration::CorrespondenceEstimationBase<P, P>*>{&stock, &walk}) {
    ce->setInputSource(d.source);
    ce->setInputTarget(d.target);
  }
  for (const double max_distance : {0.004, 0.05, 1e10}) {
    pcl::Correspondences a, b;
    stock.determineCorrespondences(a, max_distance);
    walk.determineCorrespondences(b, max_distance);
    ASSERT_EQ(a.size(), b.size()) << max_distance;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].index_query, b[i].index_query);
      EXPECT_EQ(a[i].index_match, b[i].index_match);
      EXPECT_EQ(a[i].distance, b[i].distance);
    }
    stock.determineReciprocalCorrespondences(a, max_distance);
    walk.determineReciprocalCorrespondences(b, max_distance);
    ASSERT_EQ(a.size(), b.size()) << "reciprocal " << max_distance;
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].index_match, b[i].index_match);
  }
}

TEST(RegistrationCompat, WithRejectors) {
  BunnyPair d;
  Exposed<pcl::IterativeClosestPoint<P, P>> stock;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> subclass;
  for (auto* icp : std::initializer_list<pcl::IterativeClosestPoint<P, P>*>{&stock, &subclass}) {
    configurePcl(*icp);
    auto median = pcl::make_shared<pcl::registration::CorrespondenceRejectorMedianDistance>();
    median->setMedianFactor(3.0);
    icp->addCorrespondenceRejector(median);
    icp->addCorrespondenceRejector(pcl::make_shared<pcl::registration::CorrespondenceRejectorOneToOne>());
  }
  expectSameTrajectory(alignOnce(stock, d.source, d.target, Matrix4::Identity()),
                       alignOnce(subclass, d.source, d.target, Matrix4::Identity()), "rejectors");
}

TEST(RegistrationCompat, NonLinearInstalled) {
  BunnyPair d;
  Exposed<pcl::IterativeClosestPointNonLinear<P, P>> stock, installed;
  configurePcl(stock), configurePcl(installed);
  installWalk<decltype(installed), P>(installed);
  expectSameTrajectory(alignOnce(stock, d.source, d.target, Matrix4::Identity()),
                       alignOnce(installed, d.source, d.target, Matrix4::Identity()), "non-linear");
}

/// bun0 / bun4 with normals (PCL's point-to-plane tests estimate them the same way).
pcl::PointCloud<PN>::Ptr withNormals(const Cloud::Ptr& c) {
  pcl::NormalEstimation<P, PN> ne;
  ne.setInputCloud(c);
  ne.setSearchMethod(pcl::make_shared<pcl::search::KdTree<P>>());
  ne.setKSearch(15);
  pcl::PointCloud<PN>::Ptr out(new pcl::PointCloud<PN>);
  ne.compute(*out);
  for (std::size_t i = 0; i < c->size(); ++i)
    (*out)[i].x = (*c)[i].x, (*out)[i].y = (*c)[i].y, (*out)[i].z = (*c)[i].z;
  return out;
}

TEST(RegistrationCompat, WithNormalsPointToPlaneInstalled) {
  BunnyPair d;
  const auto source = withNormals(d.source), target = withNormals(d.target);
  for (const bool symmetric : {false, true}) {
    Exposed<pcl::IterativeClosestPointWithNormals<PN, PN>> stock, installed;
    for (auto* icp : {&stock, &installed}) {
      configurePcl(*icp);
      icp->setUseSymmetricObjective(symmetric);
    }
    installWalk<decltype(installed), PN>(installed);
    expectSameTrajectory(alignOnce(stock, source, target, Matrix4::Identity()),
                         alignOnce(installed, source, target, Matrix4::Identity()),
                         symmetric ? "point-to-plane symmetric" : "point-to-plane");
  }
}

/// x, y only.
struct RepresentationXY : pcl::PointRepresentation<P> {
  RepresentationXY() { nr_dimensions_ = 2; }
  void copyToFloatArray(const P& p, float* out) const override {
    out[0] = p.x;
    out[1] = p.y;
  }
};

/// PCL's pairwise-registration tutorial representation: x, y, z and curvature (four dimensions).
struct RepresentationXYZCurvature : pcl::PointRepresentation<PN> {
  RepresentationXYZCurvature() { nr_dimensions_ = 4; }
  void copyToFloatArray(const PN& p, float* out) const override {
    out[0] = p.x;
    out[1] = p.y;
    out[2] = p.z;
    out[3] = p.curvature;
  }
};

TEST(RegistrationCompat, PointRepresentationTwoDimensions) {
  BunnyPair d;
  pcl::PointRepresentation<P>::ConstPtr rep(new RepresentationXY);
  Exposed<pcl::IterativeClosestPoint<P, P>> stock, installed;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> subclass, through_base;
  for (auto* icp :
       std::initializer_list<pcl::IterativeClosestPoint<P, P>*>{&stock, &installed, &through_base})
    configurePcl(*icp), icp->setPointRepresentation(rep);  // the Registration method
  configurePcl(subclass);
  subclass.setPointRepresentation(rep);  // the subclass's: one graph build
  installWalk<decltype(installed), P>(installed);
  const Outcome ref = alignOnce(stock, d.source, d.target, Matrix4::Identity());
  expectSameTrajectory(ref, alignOnce(installed, d.source, d.target, Matrix4::Identity()), "xy installed");
  expectSameTrajectory(ref, alignOnce(subclass, d.source, d.target, Matrix4::Identity()), "xy subclass");
  expectSameTrajectory(ref, alignOnce(through_base, d.source, d.target, Matrix4::Identity()), "xy via base");
  EXPECT_EQ(subclass.getSearchMethodWalk()->getRepresentationRoute(),
            pcl::search::DelaunayWalk<P>::RepresentationRoute::Represented);
  EXPECT_EQ(subclass.getSearchMethodWalk()->getNumberOfBuilds(), 1u);
}

TEST(RegistrationCompat, PointRepresentationFourDimensionsTutorial) {
  BunnyPair d;
  const auto source = withNormals(d.source), target = withNormals(d.target);
  auto rep = pcl::make_shared<RepresentationXYZCurvature>();
  const float alpha[4] = {1.f, 1.f, 1.f, 1.f};
  rep->setRescaleValues(alpha);
  Exposed<pcl::IterativeClosestPoint<PN, PN>> stock;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<PN, PN>> subclass;
  configurePcl(stock), configurePcl(subclass);
  stock.setPointRepresentation(rep);
  subclass.setPointRepresentation(rep);
  expectSameTrajectory(alignOnce(stock, source, target, Matrix4::Identity()),
                       alignOnce(subclass, source, target, Matrix4::Identity()), "xyz+curvature");
  EXPECT_EQ(subclass.getSearchMethodWalk()->getRepresentationRoute(),
            pcl::search::DelaunayWalk<PN>::RepresentationRoute::KdTreeFallback);
}

TEST(RegistrationCompat, FitnessScoreWithRangeEqualsStock) {
  BunnyPair d;
  Exposed<pcl::IterativeClosestPoint<P, P>> stock;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> subclass;
  configurePcl(stock), configurePcl(subclass);
  alignOnce(stock, d.source, d.target, Matrix4::Identity());
  alignOnce(subclass, d.source, d.target, Matrix4::Identity());
  for (const double range : {1e-6, 1e-4, 1e-3, std::numeric_limits<double>::max()})
    EXPECT_EQ(subclass.getFitnessScore(range), stock.getFitnessScore(range)) << range;
}

TEST(RegistrationCompat, RandomCloudsUnderAKnownMotion) {
  // A random target and the same points moved by a small rigid motion, plus noise.
  auto target = randomCloud(3000, 41);
  Eigen::Affine3f motion =
      Eigen::Translation3f(0.03f, -0.02f, 0.01f) * Eigen::AngleAxisf(0.05f, Eigen::Vector3f::UnitZ());
  Cloud::Ptr source(new Cloud);
  pcl::transformPointCloud(*target, *source, motion);
  std::mt19937 rng(42);
  std::normal_distribution<float> noise(0.f, 0.002f);
  for (P& p : *source) p.x += noise(rng), p.y += noise(rng), p.z += noise(rng);
  Exposed<pcl::IterativeClosestPoint<P, P>> stock;
  Exposed<pcl::IterativeClosestPointDelaunayWalk<P, P>> subclass;
  for (auto* icp : std::initializer_list<pcl::IterativeClosestPoint<P, P>*>{&stock, &subclass}) {
    icp->setMaximumIterations(40);
    icp->setTransformationEpsilon(1e-10);
  }
  expectSameTrajectory(alignOnce(stock, source, target, Matrix4::Identity()),
                       alignOnce(subclass, source, target, Matrix4::Identity()), "random");
}

}  // namespace
