// pcl::search::DelaunayWalk and the walk ICP on hostile clouds and files, and under concurrency:
// the answer equals pcl::search::KdTree (FLANN) on the same cloud, or a clear dw::Error.
#include <gtest/gtest.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <thread>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/registration/icp_delaunay_walk.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Walk = pcl::search::DelaunayWalk<pcl::PointXYZ>;

namespace {

Cloud::Ptr randomCloud(std::size_t n, unsigned seed, float lo = -1.f, float hi = 1.f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Cloud::Ptr c(new Cloud);
  for (std::size_t i = 0; i < n; ++i) c->push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
  return c;
}

/// kNN distances of the walk equal FLANN's at `queries` (distances, so exact ties may swap indices).
void expectSameAsKdTree(const Cloud::Ptr& cloud, const Cloud& queries, int k, const std::string& what) {
  Walk walk;
  walk.setInputCloud(cloud);
  pcl::search::KdTree<pcl::PointXYZ> kd;
  kd.setInputCloud(cloud);
  pcl::Indices wi, ki;
  std::vector<float> wd, kdd;
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const int nw = walk.nearestKSearch(queries[i], k, wi, wd);
    const int nk = kd.nearestKSearch(queries[i], k, ki, kdd);
    ASSERT_EQ(nw, nk) << what << ", query " << i;
    for (int r = 0; r < nw; ++r) ASSERT_FLOAT_EQ(wd[r], kdd[r]) << what << ", query " << i << " rank " << r;
  }
}

}  // namespace

TEST(PclBadInput, EmptyAndAllNaNClouds) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t n : {std::size_t(0), std::size_t(5)}) {
    Cloud::Ptr c(new Cloud);
    for (std::size_t i = 0; i < n; ++i) c->push_back(pcl::PointXYZ(nan, nan, nan));
    c->is_dense = false;
    Walk w;
    ASSERT_NO_THROW(w.setInputCloud(c)) << n << " points";
    pcl::Indices idx{3};
    std::vector<float> d2{1.f};
    EXPECT_EQ(w.nearestKSearch(pcl::PointXYZ(0, 0, 0), 4, idx, d2), 0);
    EXPECT_TRUE(idx.empty() && d2.empty());
    EXPECT_EQ(w.radiusSearch(pcl::PointXYZ(0, 0, 0), 10.0, idx, d2), 0);
  }
}

TEST(PclBadInput, DegenerateAndHugeCloudsMatchKdTree) {
  const auto queries = randomCloud(60, 2, -1.5f, 1.5f);
  Cloud::Ptr plane = randomCloud(800, 3);
  for (auto& p : *plane) p.z = 0.f;
  expectSameAsKdTree(plane, *queries, 6, "z = 0 plane");
  Cloud::Ptr line(new Cloud);
  for (int i = 0; i < 300; ++i) line->push_back(pcl::PointXYZ(0.01f * i, 0.02f * i, -0.01f * i));
  expectSameAsKdTree(line, *queries, 4, "line");
  Cloud::Ptr dups(new Cloud);
  const Cloud::Ptr base = randomCloud(200, 4);  // kept alive: a range-for over *temporary would dangle
  for (int rep = 0; rep < 4; ++rep)
    for (const auto& p : *base) dups->push_back(p);
  expectSameAsKdTree(dups, *queries, 9, "every point four times");
  // A georeferenced cloud in float (what PCL users load from UTM data): 0.5 m float resolution, so
  // many points coincide; the walk must still agree with FLANN on the float values.
  Cloud::Ptr utm = randomCloud(500, 5, 0.f, 200.f);
  for (auto& p : *utm) p.x += 512345.f, p.y += 6001234.f;
  Cloud utm_queries;
  for (const auto& q : *queries)
    utm_queries.push_back(pcl::PointXYZ(512445.f + 100 * q.x, 6001334.f + 100 * q.y, 100 * q.z));
  expectSameAsKdTree(utm, utm_queries, 5, "UTM float cloud");
}

TEST(PclBadInput, CorruptGraphFileIsAClearError) {
  const std::string path = std::string(DW_BINARY_DIR) + "/robustness_pcl_corrupt.graph";
  auto c = randomCloud(100, 6);
  Walk w;
  w.setInputCloud(c);
  w.saveGraph(path);
  std::vector<char> bytes;
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  bytes[bytes.size() / 2] ^= 0x10;
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  Walk other;
  EXPECT_THROW(other.loadGraph(path), dw::GraphFileError);
  pcl::IterativeClosestPointDelaunayWalk<pcl::PointXYZ, pcl::PointXYZ> icp;
  EXPECT_THROW(icp.loadTargetGraph(path), dw::GraphFileError);
  // A valid graph of another cloud is refused when the cloud is set.
  Walk builder;
  builder.setInputCloud(randomCloud(100, 7));
  builder.saveGraph(path);
  Walk mismatched;
  mismatched.loadGraph(path);
  EXPECT_THROW(mismatched.setInputCloud(c), dw::Error);
  std::remove(path.c_str());
}

TEST(PclBadInput, IcpWithEmptyOrNaNTargetDoesNotConverge) {
  // Stock PCL reports an empty target with PCL_ERROR and does not converge; the walk ICP must not
  // crash or claim convergence either.
  pcl::IterativeClosestPointDelaunayWalk<pcl::PointXYZ, pcl::PointXYZ> icp;
  Cloud::Ptr empty(new Cloud), nan_cloud(new Cloud);
  for (int i = 0; i < 10; ++i) nan_cloud->push_back(pcl::PointXYZ(NAN, 0, 0));
  nan_cloud->is_dense = false;
  for (const Cloud::Ptr& target : {empty, nan_cloud}) {
    icp.setInputSource(randomCloud(50, 8));
    icp.setInputTarget(target);
    Cloud out;
    try {
      icp.align(out);
      EXPECT_FALSE(icp.hasConverged()) << "target of " << target->size() << " points";
    } catch (const dw::Error&) {
    }
  }
}

TEST(PclConcurrency, QueriesWhileAnotherSearchIsRebuilt) {
  // Threads query one DelaunayWalk while another thread keeps setting new clouds on a second one.
  auto c = randomCloud(3000, 9);
  Walk shared;
  shared.setInputCloud(c);
  pcl::search::KdTree<pcl::PointXYZ> kd;
  kd.setInputCloud(c);
  const auto queries = randomCloud(300, 10, -1.2f, 1.2f);
  std::vector<std::vector<float>> expect(queries->size());
  pcl::Indices idx;
  for (std::size_t i = 0; i < queries->size(); ++i) kd.nearestKSearch((*queries)[i], 8, idx, expect[i]);
  std::atomic<bool> stop{false};
  std::atomic<int> rebuild_bad{0};
  std::thread rebuilder([&] {
    Walk other;
    for (unsigned round = 0; !stop.load() || round < 2; ++round) {
      auto oc = randomCloud(200 + 150 * (round % 5), 100 + round);
      other.setInputCloud(oc);
      pcl::Indices oi;
      std::vector<float> od;
      if (other.nearestKSearch((*oc)[round % oc->size()], 1, oi, od) != 1 || od[0] != 0.f) ++rebuild_bad;
    }
  });
  std::vector<int> bad(4, 0);
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t)
    pool.emplace_back([&, t] {
      pcl::Indices wi;
      std::vector<float> wd;
      for (int rep = 0; rep < 3; ++rep)
        for (std::size_t i = t; i < queries->size(); i += 2) {
          shared.nearestKSearch((*queries)[i], 8, wi, wd);
          bad[t] += wd != expect[i];
        }
    });
  for (auto& th : pool) th.join();
  stop = true;
  rebuilder.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
  EXPECT_EQ(rebuild_bad.load(), 0);
}
