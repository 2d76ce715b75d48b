// One Delaunay graph shared by several pcl::search::DelaunayWalk objects and a multi-threaded
// correspondence estimation, queried from many threads while another thread rebuilds an unrelated
// search. Run under ThreadSanitizer by scripts/sanitize.sh (its name matches the concurrency regex).
// Every answer must equal pcl::search::KdTree (FLANN) computed beforehand on one thread.
#include <gtest/gtest.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <atomic>
#include <random>
#include <thread>
#include <vector>

#include "pcl_delaunay_walk/registration/correspondence_estimation_delaunay_walk.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Walk = pcl::search::DelaunayWalk<pcl::PointXYZ>;
using Estimation = pcl::registration::CorrespondenceEstimationDelaunayWalk<pcl::PointXYZ, pcl::PointXYZ>;

namespace {

Cloud::Ptr randomCloud(std::size_t n, unsigned seed, float lo, float hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Cloud::Ptr c(new Cloud);
  for (std::size_t i = 0; i < n; ++i) c->push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
  return c;
}

/// FLANN's answers for every query, computed once before any thread starts.
struct Expected {
  std::vector<std::vector<float>> knn;     // k nearest squared distances
  std::vector<std::vector<float>> radius;  // squared distances within the radius, ascending
  std::vector<float> nearest;              // nearest squared distance
};

Expected kdTreeAnswers(const Cloud::Ptr& cloud, const Cloud& queries, int k, double radius) {
  pcl::search::KdTree<pcl::PointXYZ> kd;
  kd.setInputCloud(cloud);
  Expected e;
  pcl::Indices idx;
  e.knn.resize(queries.size());
  e.radius.resize(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    kd.nearestKSearch(queries[i], k, idx, e.knn[i]);
    kd.radiusSearch(queries[i], radius, idx, e.radius[i]);
    std::sort(e.radius[i].begin(), e.radius[i].end());
    e.nearest.push_back(e.knn[i].front());
  }
  return e;
}

/// Distances equal up to FLANN's float rounding (4 ulps, as ASSERT_FLOAT_EQ).
bool sameDistances(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!::testing::internal::FloatingPoint<float>(a[i]).AlmostEquals(
            ::testing::internal::FloatingPoint<float>(b[i])))
      return false;
  return true;
}

}  // namespace

TEST(PclConcurrency, SharedGraphAcrossSearchesAndCorrespondenceEstimationWhileRebuilding) {
  // Duplicated points: originals of one collapsed vertex must all come back, from every thread.
  auto cloud = randomCloud(2500, 21, -1.f, 1.f);
  for (int i = 0; i < 200; i += 7) cloud->push_back((*cloud)[i]);
  const auto queries = randomCloud(240, 22, -1.1f, 1.1f);
  const int k = 6;
  const double radius = 0.15;
  const Expected expect = kdTreeAnswers(cloud, *queries, k, radius);

  // Three searches over ONE graph object: PNN (thread-local hints), KD-ANN, and the estimator's own.
  auto pnn = std::make_shared<Walk>();
  pnn->setStartStrategy(dw::StartStrategy::Pnn);
  pnn->setInputCloud(cloud);
  auto kd_ann = std::make_shared<Walk>();
  kd_ann->setStartStrategy(dw::StartStrategy::KdAnn);
  kd_ann->setInputCloudAndGraph(cloud, pnn->getGraph());
  auto for_estimation = std::make_shared<Walk>();
  for_estimation->setInputCloudAndGraph(cloud, pnn->getGraph());
  ASSERT_EQ(kd_ann->getGraph(), pnn->getGraph());
  ASSERT_EQ(for_estimation->getGraph(), pnn->getGraph());
  const std::size_t builds_before = pnn->getNumberOfBuilds() + kd_ann->getNumberOfBuilds();

  std::atomic<bool> stop{false};
  std::atomic<int> rebuild_bad{0};
  std::thread rebuilder([&] {
    Walk other;
    for (unsigned round = 0; !stop.load() || round < 2; ++round) {
      auto oc = randomCloud(150 + 100 * (round % 4), 300 + round, -5.f, 5.f);
      other.setInputCloud(oc);
      pcl::Indices oi;
      std::vector<float> od;
      if (other.nearestKSearch((*oc)[round % oc->size()], 1, oi, od) != 1 || od[0] != 0.f) ++rebuild_bad;
    }
  });

  // Each querying thread alternates kNN and radius searches on one of the two shared searches.
  const int query_threads = 4;
  std::vector<int> bad(query_threads, 0);
  std::vector<std::thread> pool;
  for (int t = 0; t < query_threads; ++t)
    pool.emplace_back([&, t] {
      const Walk& search = t % 2 ? *kd_ann : *pnn;
      pcl::Indices idx;
      std::vector<float> d2;
      for (int rep = 0; rep < 2; ++rep)
        for (std::size_t i = t; i < queries->size(); i += 2) {
          search.nearestKSearch((*queries)[i], k, idx, d2);
          bad[t] += !sameDistances(d2, expect.knn[i]);
          search.radiusSearch((*queries)[i], radius, idx, d2);
          std::sort(d2.begin(), d2.end());
          bad[t] += !sameDistances(d2, expect.radius[i]);
        }
    });

  // Meanwhile a correspondence estimation with its own worker threads, twice (the second round
  // starts from the PNN cache of the first).
  Estimation estimation(for_estimation);
  estimation.setNumberOfThreads(3);
  estimation.setInputSource(queries);
  estimation.setInputTarget(cloud);
  int estimation_bad = 0;
  for (int round = 0; round < 2; ++round) {
    pcl::Correspondences corr;
    estimation.determineCorrespondences(corr, 10.0);
    estimation_bad += corr.size() != queries->size();
    for (const auto& c : corr) {
      const auto q = static_cast<std::size_t>(c.index_query);
      estimation_bad += !sameDistances({c.distance}, {expect.nearest[q]});
    }
  }

  for (auto& th : pool) th.join();
  stop = true;
  rebuilder.join();
  for (int t = 0; t < query_threads; ++t) EXPECT_EQ(bad[t], 0) << "query thread " << t;
  EXPECT_EQ(estimation_bad, 0) << "correspondence estimation";
  EXPECT_EQ(rebuild_bad.load(), 0) << "rebuilding thread";
  // Sharing means sharing: neither the searches nor the estimator built a graph of their own.
  EXPECT_EQ(pnn->getNumberOfBuilds() + kd_ann->getNumberOfBuilds(), builds_before);
  EXPECT_EQ(for_estimation->getGraph(), pnn->getGraph());
}
