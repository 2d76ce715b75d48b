// pcl::search::DelaunayWalk and KdTreeDelaunayWalk behave like pcl::search::KdTree through the whole
// Search interface: index/subset semantics, batch forms, k > n, NaN queries, graph reuse and files.
#include <pcl/search/kdtree.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <thread>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"
#include "search_test_util.h"

using namespace dw_pcl_test;
using Walk = pcl::search::DelaunayWalk<pcl::PointXYZ>;

namespace {

std::string tempPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_search_" + std::to_string(::getpid()) + "_" + name;
}

}  // namespace

TEST(DelaunayWalkApi, NameAndSorting) {
  Walk w;
  EXPECT_EQ(w.getName(), "DelaunayWalk");
  pcl::search::KdTreeDelaunayWalk<pcl::PointXYZ> t;
  EXPECT_EQ(t.getName(), "KdTreeDelaunayWalk");
}

TEST(DelaunayWalkApi, ErrorsAreClear) {
  Walk w;
  pcl::Indices idx;
  std::vector<float> d2;
  EXPECT_THROW(w.nearestKSearch(pcl::PointXYZ(0, 0, 0), 1, idx, d2), dw::Error);  // no cloud yet
  EXPECT_THROW(w.setInputCloud(nullptr), dw::Error);
  auto c = uniformCloud(50, 1);
  pcl::IndicesPtr bad(new pcl::Indices{1, 2, 50});
  EXPECT_THROW(w.setInputCloud(c, bad), dw::Error);
  bad->back() = -1;
  EXPECT_THROW(w.setInputCloud(c, bad), dw::Error);
  EXPECT_THROW(w.saveGraph(tempPath("never.graph")), dw::Error);
}

TEST(DelaunayWalkApi, DegenerateQueriesReturnNothing) {
  auto c = uniformCloud(200, 2);
  Walk w;
  w.setInputCloud(c);
  pcl::Indices idx{1, 2};
  std::vector<float> d2{1.f};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(w.nearestKSearch(pcl::PointXYZ(nan, 0, 0), 3, idx, d2), 0);
  EXPECT_TRUE(idx.empty() && d2.empty());
  EXPECT_EQ(w.radiusSearch(pcl::PointXYZ(0, nan, 0), 1.0, idx, d2), 0);
  EXPECT_EQ(w.nearestKSearch(pcl::PointXYZ(0, 0, 0), 0, idx, d2), 0);
  EXPECT_EQ(w.nearestKSearch(pcl::PointXYZ(0, 0, 0), -3, idx, d2), 0);
  EXPECT_EQ(w.radiusSearch(pcl::PointXYZ(0, 0, 0), -1.0, idx, d2), 0);
  EXPECT_EQ(w.radiusSearch(pcl::PointXYZ(0, 0, 0), 0.0, idx, d2), 0);
  EXPECT_EQ(w.nearestKSearch(static_cast<pcl::index_t>(200), 1, idx, d2), 0);  // out of range
  EXPECT_EQ(w.nearestKSearch(static_cast<pcl::index_t>(-1), 1, idx, d2), 0);
  // k > n gives all n points, nearest first, as KdTreeFLANN.
  EXPECT_EQ(w.nearestKSearch(pcl::PointXYZ(0, 0, 0), 1000, idx, d2), 200);
  EXPECT_TRUE(std::is_sorted(d2.begin(), d2.end()));
  // A query exactly on a point finds it at distance 0; radius 0 does not (FLANN's strict d < r).
  EXPECT_EQ(w.nearestKSearch((*c)[17], 1, idx, d2), 1);
  EXPECT_EQ(idx[0], 17);
  EXPECT_EQ(d2[0], 0.f);
}

TEST(DelaunayWalkApi, AllOverloadsMatchKdTreeWithSubset) {
  auto c = uniformCloud(1200, 3);
  (*c)[5].x = std::numeric_limits<float>::quiet_NaN();
  pcl::IndicesPtr subset(new pcl::Indices);
  for (int i = 0; i < 1200; i += 3) subset->push_back(i);
  subset->push_back(5);
  Walk w;
  pcl::search::KdTree<pcl::PointXYZ> t;
  w.setInputCloud(c, subset);
  t.setInputCloud(c, subset);
  EXPECT_EQ(w.getInputCloud(), c);
  EXPECT_EQ(w.getIndices(), subset);
  pcl::Indices wi, ti;
  std::vector<float> wd, td;
  // Index form: the index is a position in the subset; results are cloud indices.
  for (pcl::index_t i = 0; i < static_cast<pcl::index_t>(subset->size()); i += 7) {
    if (i == static_cast<pcl::index_t>(subset->size()) - 1) continue;  // the NaN point
    const int nw = w.nearestKSearch(i, 6, wi, wd);
    t.nearestKSearch(i, 6, ti, td);
    ASSERT_EQ(nw, 6);
    ASSERT_EQ(wd, td);
    const Ref ref = bruteKnn(*c, (*c)[(*subset)[i]], 6, subset.get());
    expectSameNeighbours(*c, (*c)[(*subset)[i]], ref, wi, wd, "index form");
    w.radiusSearch(i, 0.15, wi, wd, 5);
    t.radiusSearch(i, 0.15, ti, td, 5);
    ASSERT_EQ(wd, td);
    // Cloud + index form on the input cloud itself, and on another cloud.
    w.nearestKSearch(*c, (*subset)[i], 4, wi, wd);
    t.nearestKSearch(*c, (*subset)[i], 4, ti, td);
    ASSERT_EQ(wd, td);
    w.radiusSearch(*c, (*subset)[i] + 1, 0.1, wi, wd);
    t.radiusSearch(*c, (*subset)[i] + 1, 0.1, ti, td);
    ASSERT_EQ(wd, td);
  }
  // Batch forms.
  auto queries = uniformCloud(100, 4, -1.2f, 1.2f);
  std::vector<pcl::Indices> wbi, tbi;
  std::vector<std::vector<float>> wbd, tbd;
  w.nearestKSearch(*queries, pcl::Indices(), 5, wbi, wbd);
  t.nearestKSearch(*queries, pcl::Indices(), 5, tbi, tbd);
  ASSERT_EQ(wbd, tbd);
  w.radiusSearch(*queries, pcl::Indices{1, 3, 5, 99}, 0.2, wbi, wbd, 0);
  t.radiusSearch(*queries, pcl::Indices{1, 3, 5, 99}, 0.2, tbi, tbd, 0);
  ASSERT_EQ(wbd, tbd);
  for (std::size_t q = 0; q < wbi.size(); ++q) {
    std::sort(wbi[q].begin(), wbi[q].end());
    std::sort(tbi[q].begin(), tbi[q].end());
    ASSERT_EQ(wbi[q], tbi[q]);  // no ties among random floats: same indices too
  }
}

TEST(DelaunayWalkApi, GraphIsKeptForUnchangedContentAndRebuiltOtherwise) {
  auto c = uniformCloud(500, 5);
  Walk w;
  w.setInputCloud(c);
  EXPECT_EQ(w.getNumberOfBuilds(), 1u);
  const auto g = w.getGraph();
  Cloud::Ptr same(new Cloud(*c));  // another object, same coordinates
  w.setInputCloud(same);
  EXPECT_EQ(w.getNumberOfBuilds(), 1u);
  EXPECT_EQ(w.getGraph(), g);
  EXPECT_EQ(w.getLastBuildSeconds(), 0.0);
  (*same)[3].z += 0.5f;
  w.setInputCloud(same);
  EXPECT_EQ(w.getNumberOfBuilds(), 2u);
  pcl::Indices idx;
  std::vector<float> d2;
  ASSERT_EQ(w.nearestKSearch((*same)[3], 1, idx, d2), 1);
  EXPECT_EQ(idx[0], 3);
  EXPECT_EQ(d2[0], 0.f);
  // The same coordinates through a different subset are different content.
  pcl::IndicesPtr sub(new pcl::Indices{0, 1, 2, 3, 4, 5});
  w.setInputCloud(same, sub);
  EXPECT_EQ(w.getNumberOfBuilds(), 3u);
  EXPECT_EQ(w.nearestKSearch(pcl::PointXYZ(5, 5, 5), 100, idx, d2), 6);
}

TEST(DelaunayWalkApi, GraphFileRoundTripAndMismatch) {
  auto c = uniformCloud(800, 6);
  Walk w;
  w.setInputCloud(c);
  const std::string path = tempPath("roundtrip.graph");
  w.saveGraph(path);
  Walk loaded;
  loaded.loadGraph(path);
  loaded.setInputCloud(c);
  EXPECT_EQ(loaded.getNumberOfBuilds(), 0u);  // adopted, not built
  pcl::Indices a, b;
  std::vector<float> da, db;
  for (const auto& q : queriesFor(*c, 50, 3)) {
    w.nearestKSearch(q, 9, a, da);
    loaded.nearestKSearch(q, 9, b, db);
    ASSERT_EQ(a, b);
    ASSERT_EQ(da, db);
  }
  // A graph of another cloud is refused, and the search keeps its previous state.
  Walk other;
  other.loadGraph(path);
  auto moved = uniformCloud(800, 7);
  EXPECT_THROW(other.setInputCloud(moved), dw::Error);
  EXPECT_FALSE(other.getGraph());
  EXPECT_THROW(other.setInputCloudAndGraph(moved, w.getGraph()), dw::Error);
  auto shorter = subsample(*c, 2);
  EXPECT_THROW(other.setInputCloudAndGraph(shorter, w.getGraph()), dw::Error);
  other.setInputCloudAndGraph(c, w.getGraph());
  EXPECT_EQ(other.getGraph(), w.getGraph());
  // A damaged file is a GraphFileError, never a crash or a wrong graph.
  {
    std::ofstream f(tempPath("junk.graph"), std::ios::binary);
    f << "this is not a graph file";
  }
  EXPECT_THROW(other.loadGraph(tempPath("junk.graph")), dw::GraphFileError);
  EXPECT_THROW(other.loadGraph(tempPath("does_not_exist.graph")), dw::Error);
  std::remove(path.c_str());
  std::remove(tempPath("junk.graph").c_str());
}

TEST(DelaunayWalkApi, KdTreeSubclassAnswersWithTheWalk) {
  auto c = uniformCloud(900, 8);
  pcl::search::KdTreeDelaunayWalk<pcl::PointXYZ>::Ptr tree(
      new pcl::search::KdTreeDelaunayWalk<pcl::PointXYZ>);
  pcl::search::KdTree<pcl::PointXYZ>::Ptr as_kdtree = tree;  // what Registration holds
  as_kdtree->setInputCloud(c);
  EXPECT_EQ(tree->getDelaunayWalk()->getNumberOfBuilds(), 1u);
  as_kdtree->setInputCloud(c);
  EXPECT_EQ(tree->getDelaunayWalk()->getNumberOfBuilds(), 1u);
  pcl::search::KdTree<pcl::PointXYZ> flann;
  flann.setInputCloud(c);
  pcl::Indices a, b;
  std::vector<float> da, db;
  for (const auto& q : queriesFor(*c, 60, 9)) {
    as_kdtree->nearestKSearch(q, 5, a, da);
    flann.nearestKSearch(q, 5, b, db);
    ASSERT_EQ(a, b);
    ASSERT_EQ(da, db);
    as_kdtree->radiusSearch(q, 0.2, a, da, 3);
    flann.radiusSearch(q, 0.2, b, db, 3);
    ASSERT_EQ(a, b);
  }
  for (pcl::index_t i = 0; i < 900; i += 50) {
    as_kdtree->nearestKSearch(i, 3, a, da);
    flann.nearestKSearch(i, 3, b, db);
    ASSERT_EQ(a, b);
  }
  // Sharing one walk between two trees shares the graph.
  pcl::search::KdTreeDelaunayWalk<pcl::PointXYZ> twin(tree->getDelaunayWalk());
  EXPECT_EQ(twin.getDelaunayWalk()->getGraph(), tree->getDelaunayWalk()->getGraph());
}

TEST(DelaunayWalkApi, OtherPointTypes) {
  pcl::PointCloud<pcl::PointXYZRGBNormal>::Ptr c(new pcl::PointCloud<pcl::PointXYZRGBNormal>);
  auto base = uniformCloud(300, 10);
  for (const auto& p : *base) {
    pcl::PointXYZRGBNormal q;
    q.x = p.x, q.y = p.y, q.z = p.z;
    q.normal_x = 1.f;
    c->push_back(q);
  }
  pcl::search::DelaunayWalk<pcl::PointXYZRGBNormal> w;
  w.setInputCloud(c);
  pcl::Indices idx;
  std::vector<float> d2;
  for (std::size_t i = 0; i < 300; i += 10) {
    ASSERT_EQ(w.nearestKSearch((*c)[i], 4, idx, d2), 4);
    const Ref ref = bruteKnn(*base, (*base)[i], 4);
    expectSameNeighbours(*base, (*base)[i], ref, idx, d2, "PointXYZRGBNormal");
  }
}

TEST(DelaunayWalkApi, ConcurrentQueriesAreExact) {
  auto c = uniformCloud(4000, 12);
  Walk w;
  w.setStartStrategy(dw::StartStrategy::PnnOptimized);  // per-thread hints must not leak across threads
  w.setInputCloud(c);
  const auto queries = queriesFor(*c, 400, 13);
  std::vector<std::vector<float>> expect(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) expect[i] = bruteKnn(*c, queries[i], 7).d2;
  std::vector<int> bad(4, 0);
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t)
    pool.emplace_back([&, t] {
      pcl::Indices idx;
      std::vector<float> d2;
      for (int rep = 0; rep < 5; ++rep)
        for (std::size_t i = t; i < queries.size(); i += 2) {
          w.nearestKSearch(queries[i], 7, idx, d2);
          if (d2 != expect[i]) ++bad[t];
        }
    });
  for (auto& th : pool) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
}
