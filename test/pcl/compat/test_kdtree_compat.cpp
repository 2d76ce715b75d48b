// What PCL 1.13's test/kdtree/test_kdtree.cpp checks of KdTreeFLANN, run for every search class we
// ship: radius search and k nearest on a regular grid (ties everywhere) against brute force, epsilon,
// and point representations (x, y only; rescaled; one dimension; more than three, which takes the
// documented k-d tree fallback), each answer held to pcl::KdTreeFLANN with the same representation.
#include <gtest/gtest.h>

#include "compat_util.h"

namespace {

using namespace dw_compat;

class KdTreeCompat : public ::testing::TestWithParam<Backend> {};

/// x and y only, like PCL's MyPointRepresentationXY.
template <typename PointT>
struct RepresentationXY : pcl::PointRepresentation<PointT> {
  RepresentationXY() { this->nr_dimensions_ = 2; }
  void copyToFloatArray(const PointT& p, float* out) const override {
    out[0] = p.x;
    out[1] = p.y;
  }
};

/// z alone.
template <typename PointT>
struct RepresentationZ : pcl::PointRepresentation<PointT> {
  RepresentationZ() { this->nr_dimensions_ = 1; }
  void copyToFloatArray(const PointT& p, float* out) const override { out[0] = p.z; }
};

/// x, y, z and intensity: four dimensions, beyond what the walk searches.
struct RepresentationXYZI : pcl::PointRepresentation<pcl::PointXYZI> {
  RepresentationXYZI() { nr_dimensions_ = 4; }
  void copyToFloatArray(const pcl::PointXYZI& p, float* out) const override {
    out[0] = p.x;
    out[1] = p.y;
    out[2] = p.z;
    out[3] = p.intensity;
  }
};

/// Every query's k nearest and radius neighbours against pcl::KdTreeFLANN with the same
/// representation and against brute force in the represented space.
template <typename PointT>
void expectSameAsFlann(pcl::search::Search<PointT>& s, const typename pcl::PointCloud<PointT>::Ptr& c,
                       const typename pcl::PointRepresentation<PointT>::ConstPtr& rep,
                       const std::vector<PointT>& queries, const std::string& what) {
  pcl::KdTreeFLANN<PointT> flann;
  flann.setPointRepresentation(rep);
  flann.setInputCloud(c);
  pcl::Indices gi, fi, bi;
  std::vector<float> gd, fd, bd;
  for (const PointT& q : queries) {
    const auto all = bruteAll(*c, q, *rep);
    for (int k : {1, 4, 12}) {
      s.nearestKSearch(q, k, gi, gd);
      flann.nearestKSearch(q, k, fi, fd);
      bi.clear();
      bd.clear();
      for (int r = 0; r < k && r < static_cast<int>(all.size()); ++r)
        bi.push_back(all[r].second), bd.push_back(all[r].first);
      expectSameAnswer(gi, gd, fi, fd, true, what + " knn vs KdTreeFLANN, k=" + std::to_string(k));
      expectSameAnswer(gi, gd, bi, bd, true, what + " knn vs brute force, k=" + std::to_string(k));
    }
    const double radius = std::sqrt(all[std::min<std::size_t>(9, all.size() - 1)].first) * 1.01;
    s.radiusSearch(q, radius, gi, gd);
    flann.radiusSearch(q, radius, fi, fd);
    expectSameAnswer(gi, gd, fi, fd, true, what + " radius vs KdTreeFLANN");
  }
}

TEST_P(KdTreeCompat, RadiusSearchOnAGridEqualsBruteForce) {
  // PCL's grid: ties at every distance, so compare as sets (FLANN and the walk order ties apart).
  Cloud::Ptr c(new Cloud);
  for (int z = 0; z < 14; ++z)
    for (int y = 0; y < 14; ++y)
      for (int x = 0; x < 14; ++x) c->push_back(P(0.1f * x, 0.1f * y, 0.1f * z));
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  pcl::Indices gi;
  std::vector<float> gd;
  static const pcl::DefaultPointRepresentation<P> xyz;
  for (const P& q : {P(0.65f, 0.65f, 0.65f), P(0.3f, 0.7f, 0.15f), (*c)[1000], P(-0.2f, 0.5f, 1.5f)}) {
    for (double radius : {0.1, 0.15, 0.31}) {
      s->radiusSearch(q, radius, gi, gd);
      std::vector<int> ref;
      for (const auto& e : bruteAll(*c, q, xyz))
        if (e.first < float(radius * radius)) ref.push_back(e.second);
      std::vector<int> got(gi.begin(), gi.end());
      std::sort(got.begin(), got.end());
      std::sort(ref.begin(), ref.end());
      EXPECT_EQ(got, ref) << "radius " << radius;
      EXPECT_TRUE(std::is_sorted(gd.begin(), gd.end()));
    }
  }
}

TEST_P(KdTreeCompat, NearestKOnAGridHasTheBruteForceDistances) {
  Cloud::Ptr c(new Cloud);
  for (int z = 0; z < 12; ++z)
    for (int y = 0; y < 12; ++y)
      for (int x = 0; x < 12; ++x) c->push_back(P(0.25f * x, 0.25f * y, 0.25f * z));
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  pcl::KdTreeFLANN<P> flann;
  flann.setInputCloud(c);
  pcl::Indices gi, fi;
  std::vector<float> gd, fd;
  for (const P& q : {P(1.4f, 1.4f, 1.4f), P(0.f, 0.f, 0.f), P(1.375f, 0.125f, 2.0f), P(5.f, -1.f, 2.f)}) {
    for (int k : {1, 10, 27, 64}) {
      s->nearestKSearch(q, k, gi, gd);
      flann.nearestKSearch(q, k, fi, fd);
      EXPECT_EQ(gd, fd) << "k " << k;  // ties may name other points, never other distances
      for (std::size_t r = 0; r < gi.size(); ++r) {
        const P& p = (*c)[gi[r]];
        EXPECT_EQ(flannL2({q.x, q.y, q.z}, {p.x, p.y, p.z}), gd[r]);
      }
    }
  }
}

TEST_P(KdTreeCompat, EpsilonNeverMakesAnswersApproximate) {
  auto c = randomCloud(3000, 21);
  pcl::search::KdTreeDelaunayWalk<P> tree;
  tree.setEpsilon(0.5f);  // FLANN may then return neighbours up to 1.5x too far; the walk is exact
  EXPECT_FLOAT_EQ(tree.getEpsilon(), 0.5f);
  auto s = makeSearch<P>(GetParam());
  tree.setInputCloud(c);
  s->setInputCloud(c);
  pcl::KdTreeFLANN<P> exact;
  exact.setInputCloud(c);
  pcl::Indices ti, si, ei;
  std::vector<float> td, sd, ed;
  for (const P& q : queriesNear(*c, 90, 22)) {
    tree.nearestKSearch(q, 6, ti, td);
    s->nearestKSearch(q, 6, si, sd);
    exact.nearestKSearch(q, 6, ei, ed);
    EXPECT_EQ(td, ed);
    EXPECT_EQ(sd, ed);
    EXPECT_EQ(ti, ei);
  }
}

TEST_P(KdTreeCompat, RepresentationXYOnlyEqualsKdTreeFLANN) {
  // PCL's KdTreeFLANN_setPointRepresentation check: with x, y only, neighbours by plan distance.
  Cloud::Ptr c(new Cloud);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.f, 100.f);
  for (int i = 0; i < 10; ++i) c->push_back(P(u(rng), u(rng), u(rng)));
  const P q(50.f, 50.f, 50.f);
  pcl::PointRepresentation<P>::ConstPtr rep(new RepresentationXY<P>);
  auto s = makeSearch<P>(GetParam(), rep);
  s->setInputCloud(c);
  expectSameAsFlann<P>(*s, c, rep, {q}, backendName(GetParam()) + " xy, 10 points");
  // And on a real scan: its plan view, walked as a planar graph.
  auto bunny = loadData("pcl_bun0.pcd");
  auto sb = makeSearch<P>(GetParam(), rep);
  sb->setInputCloud(bunny);
  expectSameAsFlann<P>(*sb, bunny, rep, queriesNear(*bunny, 40, 24), backendName(GetParam()) + " xy bun0");
  auto walk = std::dynamic_pointer_cast<pcl::search::DelaunayWalk<P>>(sb);
  if (!walk) walk = std::dynamic_pointer_cast<pcl::search::KdTreeDelaunayWalk<P>>(sb)->getDelaunayWalk();
  EXPECT_EQ(walk->getRepresentationRoute(), pcl::search::DelaunayWalk<P>::RepresentationRoute::Represented);
  EXPECT_TRUE(walk->getGraph());
}

TEST_P(KdTreeCompat, RescaledAndOneDimensionalRepresentations) {
  auto c = randomCloud(1500, 25, 10.f);
  auto rescaled = pcl::make_shared<pcl::DefaultPointRepresentation<P>>();
  const float alpha[3] = {1.f, 2.f, 3.f};
  rescaled->setRescaleValues(alpha);
  const std::vector<P> queries = queriesNear(*c, 40, 26);
  for (const pcl::PointRepresentation<P>::ConstPtr& rep :
       {pcl::PointRepresentation<P>::ConstPtr(rescaled),
        pcl::PointRepresentation<P>::ConstPtr(new RepresentationZ<P>)}) {
    auto s = makeSearch<P>(GetParam(), rep);
    s->setInputCloud(c);
    expectSameAsFlann<P>(*s, c, rep, queries,
                         backendName(GetParam()) + " " + std::to_string(rep->getNumberOfDimensions()) + "-D");
  }
}

TEST_P(KdTreeCompat, RepresentationSetAfterTheCloudRebuilds) {
  auto c = randomCloud(800, 27);
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  pcl::PointRepresentation<P>::ConstPtr rep(new RepresentationXY<P>);
  if (GetParam() == Backend::DelaunayWalk) {
    std::static_pointer_cast<pcl::search::DelaunayWalk<P>>(s)->setPointRepresentation(rep);
  } else {
    pcl::search::KdTree<P>& base = *std::static_pointer_cast<pcl::search::KdTreeDelaunayWalk<P>>(s);
    base.setPointRepresentation(rep);  // not virtual: reaches the walk through the FLANN slot
    EXPECT_EQ(base.getPointRepresentation(), rep);
  }
  expectSameAsFlann<P>(*s, c, rep, queriesNear(*c, 30, 28), backendName(GetParam()) + " set after");
}

TEST_P(KdTreeCompat, FourDimensionalRepresentationTakesTheExactFallback) {
  using PI = pcl::PointXYZI;
  pcl::PointCloud<PI>::Ptr c(new pcl::PointCloud<PI>);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int i = 0; i < 1500; ++i) {
    PI p;
    p.x = u(rng), p.y = u(rng), p.z = u(rng), p.intensity = 0.5f * u(rng);
    c->push_back(p);
  }
  pcl::PointRepresentation<PI>::ConstPtr rep(new RepresentationXYZI);
  auto s = makeSearch<PI>(GetParam(), rep);
  s->setInputCloud(c);
  std::vector<PI> queries;
  for (int i = 0; i < 40; ++i) queries.push_back(i % 2 ? (*c)[i * 31] : c->at(i));
  for (int i = 0; i < 20; ++i) queries[i].intensity += 0.1f * u(rng);
  expectSameAsFlann<PI>(*s, c, rep, queries, backendName(GetParam()) + " 4-D");
  auto walk = std::dynamic_pointer_cast<pcl::search::DelaunayWalk<PI>>(s);
  if (!walk) walk = std::dynamic_pointer_cast<pcl::search::KdTreeDelaunayWalk<PI>>(s)->getDelaunayWalk();
  EXPECT_EQ(walk->getRepresentationRoute(),
            pcl::search::DelaunayWalk<PI>::RepresentationRoute::KdTreeFallback);
  EXPECT_TRUE(walk->getFallbackTree());
  EXPECT_FALSE(walk->getGraph());
  // The index forms and an unchanged re-set (no rebuild) work on the fallback as well.
  pcl::Indices gi, fi;
  std::vector<float> gd, fd;
  pcl::KdTreeFLANN<PI> flann;
  flann.setPointRepresentation(rep);
  flann.setInputCloud(c);
  s->nearestKSearch(static_cast<pcl::index_t>(77), 5, gi, gd);
  flann.nearestKSearch(static_cast<pcl::index_t>(77), 5, fi, fd);
  EXPECT_EQ(gd, fd);
  const std::size_t builds = walk->getNumberOfBuilds();
  s->setInputCloud(c);
  EXPECT_EQ(walk->getNumberOfBuilds(), builds);
}

TEST_P(KdTreeCompat, DefaultRepresentationKeepsTheXyzGraph) {
  auto c = randomCloud(500, 30);
  auto rep = pcl::make_shared<pcl::DefaultPointRepresentation<P>>();
  auto s = makeSearch<P>(GetParam(), rep);
  s->setInputCloud(c);
  auto walk = std::dynamic_pointer_cast<pcl::search::DelaunayWalk<P>>(s);
  if (!walk) walk = std::dynamic_pointer_cast<pcl::search::KdTreeDelaunayWalk<P>>(s)->getDelaunayWalk();
  EXPECT_EQ(walk->getRepresentationRoute(), pcl::search::DelaunayWalk<P>::RepresentationRoute::Xyz);
  // The same graph as without any representation: built from the very same coordinates.
  pcl::search::DelaunayWalk<P> plain;
  plain.setInputCloud(c);
  EXPECT_EQ(walk->getCallerMetricSearch()->inputXyz(), plain.getCallerMetricSearch()->inputXyz());
}

INSTANTIATE_TEST_SUITE_P(Backends, KdTreeCompat,
                         ::testing::Values(Backend::DelaunayWalk, Backend::KdTreeDelaunayWalk),
                         [](const ::testing::TestParamInfo<Backend>& info) {
                           return backendName(info.param);
                         });

}  // namespace
