// What PCL 1.13's test/search/test_search.cpp checks of a pcl::search::Search, run for every search
// class we ship: each overload (point, index, cloud + index, the batch vector forms), input index
// subsets, sorted and unsorted results, k beyond the cloud, radius with max_nn, dense and sparse
// (NaN) clouds, organized clouds; answers held to pcl::search::KdTree and to brute force, ties aside.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "compat_util.h"

namespace {

using namespace dw_compat;

class SearchCompat : public ::testing::TestWithParam<Backend> {};

/// Brute force in x, y, z.
std::vector<std::pair<float, int>> brute(const Cloud& c, const P& q, const pcl::Indices* subset = nullptr) {
  static const pcl::DefaultPointRepresentation<P> xyz;
  return bruteAll(c, q, xyz, subset);
}

void knnRef(const std::vector<std::pair<float, int>>& all, int k, pcl::Indices& i, std::vector<float>& d) {
  i.clear();
  d.clear();
  for (std::size_t r = 0; r < all.size() && static_cast<int>(r) < k; ++r) {
    d.push_back(all[r].first);
    i.push_back(all[r].second);
  }
}

void radiusRef(const std::vector<std::pair<float, int>>& all, double radius, unsigned max_nn, pcl::Indices& i,
               std::vector<float>& d) {
  i.clear();
  d.clear();
  const float r2 = static_cast<float>(radius * radius);
  for (std::size_t r = 0; r < all.size() && all[r].first < r2; ++r) {
    if (max_nn > 0 && i.size() == max_nn) break;
    d.push_back(all[r].first);
    i.push_back(all[r].second);
  }
}

/// Every point query against brute force and PCL's KdTree: k in {1, 3, 10, n + 3}, radius with
/// max_nn in {0, 1, 5}.
void checkPointQueries(pcl::search::Search<P>& s, const Cloud::Ptr& c, const pcl::IndicesPtr& subset,
                       const std::vector<P>& queries, bool sorted, const std::string& what) {
  pcl::search::KdTree<P> ref(sorted);
  ref.setInputCloud(c, subset);
  pcl::Indices gi, ri, bi;
  std::vector<float> gd, rd, bd;
  const int n = static_cast<int>(subset ? subset->size() : c->size());
  for (std::size_t qi = 0; qi < queries.size(); ++qi) {
    const P& q = queries[qi];
    const auto all = brute(*c, q, subset.get());
    for (int k : {1, 3, 10, n + 3}) {
      const int found = s.nearestKSearch(q, k, gi, gd);
      ASSERT_EQ(found, static_cast<int>(gi.size())) << what;
      knnRef(all, k, bi, bd);
      expectSameAnswer(gi, gd, bi, bd, true, what + " knn k=" + std::to_string(k));  // kNN always sorted
      if (k <= n) {
        ref.nearestKSearch(q, k, ri, rd);
        EXPECT_EQ(gd, rd) << what << " knn k=" << k << " vs KdTree";
      }
    }
    for (double radius : {0.05, 0.2}) {
      for (unsigned max_nn : {0u, 1u, 5u}) {
        s.radiusSearch(q, radius, gi, gd, max_nn);
        radiusRef(all, radius, max_nn, bi, bd);
        expectSameAnswer(gi, gd, bi, bd, sorted || max_nn > 0,
                         what + " radius " + std::to_string(radius) + " max_nn " + std::to_string(max_nn));
        ref.radiusSearch(q, radius, ri, rd, max_nn);
        std::sort(rd.begin(), rd.end());
        std::vector<float> g = gd;
        std::sort(g.begin(), g.end());
        EXPECT_EQ(g, rd) << what << " radius vs KdTree";
      }
    }
  }
}

TEST_P(SearchCompat, DenseCloudEveryPointQuery) {
  auto c = randomCloud(3000, 11);
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  EXPECT_EQ(s->getInputCloud(), c);
  checkPointQueries(*s, c, nullptr, queriesNear(*c, 60, 1), true, backendName(GetParam()) + " dense");
}

TEST_P(SearchCompat, SparseCloudWithNaNsNeverAnswersThem) {
  auto c = randomCloud(2000, 12);
  for (std::size_t i = 0; i < c->size(); i += 17) (*c)[i].x = std::numeric_limits<float>::quiet_NaN();
  c->is_dense = false;
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  checkPointQueries(*s, c, nullptr, queriesNear(*c, 60, 2), true, backendName(GetParam()) + " sparse");
}

TEST_P(SearchCompat, OrganizedCloudWithNaNs) {
  // A 64 x 48 depth image: a tilted plane with holes, like PCL's organized test frames.
  Cloud::Ptr c(new Cloud(64, 48));
  for (std::uint32_t v = 0; v < c->height; ++v)
    for (std::uint32_t u = 0; u < c->width; ++u) {
      P& p = c->at(u, v);
      const float z = 1.f + 0.003f * u + 0.001f * v + 0.0005f * std::sin(0.7f * u * v);
      p = P((u - 32.f) * z / 60.f, (v - 24.f) * z / 60.f, z);
      if ((u * 7 + v * 3) % 23 == 0) p.z = std::numeric_limits<float>::quiet_NaN();
    }
  c->is_dense = false;
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  checkPointQueries(*s, c, nullptr, queriesNear(*c, 45, 3), true, backendName(GetParam()) + " organized");
}

TEST_P(SearchCompat, InputIndicesSubsetAnswersOnlyFromTheSubset) {
  auto c = randomCloud(2500, 13);
  pcl::IndicesPtr subset(new pcl::Indices);
  for (int i = 0; i < 2500; i += 3) subset->push_back(i);
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c, subset);
  EXPECT_EQ(s->getIndices(), subset);
  checkPointQueries(*s, c, subset, queriesNear(*c, 45, 4), true, backendName(GetParam()) + " subset");
}

TEST_P(SearchCompat, UnsortedResultsAreTheSameSets) {
  auto c = randomCloud(2000, 14);
  auto s = makeSearch<P>(GetParam(), nullptr, false);
  s->setInputCloud(c);
  checkPointQueries(*s, c, nullptr, queriesNear(*c, 45, 5), false, backendName(GetParam()) + " unsorted");
}

TEST_P(SearchCompat, IndexAndCloudIndexForms) {
  auto c = randomCloud(1500, 15);
  pcl::IndicesPtr subset(new pcl::Indices);
  for (int i = 1; i < 1500; i += 2) subset->push_back(i);
  for (const bool with_subset : {false, true}) {
    auto s = makeSearch<P>(GetParam());
    pcl::search::KdTree<P> ref;
    s->setInputCloud(c, with_subset ? subset : nullptr);
    ref.setInputCloud(c, with_subset ? subset : nullptr);
    const auto n = static_cast<pcl::index_t>(with_subset ? subset->size() : c->size());
    pcl::Indices gi, ri;
    std::vector<float> gd, rd;
    for (pcl::index_t i = 0; i < n; i += 37) {
      // Index form: a position in the input (in the subset if one was given), as Search defines.
      s->nearestKSearch(i, 7, gi, gd);
      ref.nearestKSearch(i, 7, ri, rd);
      ASSERT_EQ(gd, rd) << "index form, position " << i;
      ASSERT_EQ(gi, ri) << "index form, position " << i;
      s->radiusSearch(i, 0.15, gi, gd, 4);
      ref.radiusSearch(i, 0.15, ri, rd, 4);
      ASSERT_EQ(gd, rd) << "radius index form, position " << i;
      // Cloud + index form: cloud[index] of any cloud, here the input itself and a stranger.
      s->nearestKSearch(*c, i, 5, gi, gd);
      ref.nearestKSearch(*c, i, 5, ri, rd);
      ASSERT_EQ(gd, rd);
      ASSERT_EQ(gi, ri);
      const Cloud other = *randomCloud(n, 16);
      s->radiusSearch(other, i, 0.2, gi, gd, 0);
      ref.radiusSearch(other, i, 0.2, ri, rd, 0);
      ASSERT_EQ(gd, rd);
      ASSERT_EQ(gi, ri);
    }
  }
}

TEST_P(SearchCompat, BatchVectorFormsEqualKdTree) {
  auto c = randomCloud(2000, 17);
  auto queries = randomCloud(120, 18, 1.1f);
  auto s = makeSearch<P>(GetParam());
  pcl::search::KdTree<P> ref;
  s->setInputCloud(c);
  ref.setInputCloud(c);
  std::vector<pcl::Indices> gi, ri;
  std::vector<std::vector<float>> gd, rd;
  // All queries, then a subset of them (query indices), for kNN and radius.
  for (const pcl::Indices& which : {pcl::Indices(), pcl::Indices{0, 5, 7, 119, 64}}) {
    s->nearestKSearch(*queries, which, 9, gi, gd);
    ref.nearestKSearch(*queries, which, 9, ri, rd);
    ASSERT_EQ(gi.size(), which.empty() ? queries->size() : which.size());
    EXPECT_EQ(gd, rd);
    EXPECT_EQ(gi, ri);
    s->radiusSearch(*queries, which, 0.25, gi, gd, 0);
    ref.radiusSearch(*queries, which, 0.25, ri, rd, 0);
    EXPECT_EQ(gd, rd);
    EXPECT_EQ(gi, ri);
    s->radiusSearch(*queries, which, 0.25, gi, gd, 3);
    ref.radiusSearch(*queries, which, 0.25, ri, rd, 3);
    EXPECT_EQ(gd, rd);
  }
}

TEST_P(SearchCompat, BundledScansEqualKdTree) {
  for (const char* name : {"pcl_bun0.pcd", "teapot_points.ply", "fastgicp_251370668.pcd"}) {
    auto full = loadData(name);
    auto c = full->size() > 20000 ? everyNth(*full, 8) : full;
    auto s = makeSearch<P>(GetParam());
    s->setInputCloud(c);
    checkPointQueries(*s, c, nullptr, queriesNear(*c, 30, 6), true, backendName(GetParam()) + " " + name);
  }
}

TEST_P(SearchCompat, DegenerateArgumentsGiveNothing) {
  auto c = randomCloud(300, 19);
  auto s = makeSearch<P>(GetParam());
  s->setInputCloud(c);
  pcl::Indices i{1, 2};
  std::vector<float> d{1.f, 2.f};
  EXPECT_EQ(s->nearestKSearch(P(0, 0, 0), 0, i, d), 0);
  EXPECT_TRUE(i.empty() && d.empty());
  EXPECT_EQ(s->radiusSearch(P(0, 0, 0), -1.0, i, d), 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(s->nearestKSearch(P(nan, 0, 0), 3, i, d), 0);
  // Radius 0 finds nothing, even a query on a point (FLANN's strict d < r).
  EXPECT_EQ(s->radiusSearch((*c)[4], 0.0, i, d), 0);
  // A huge radius finds every point, and max_nn keeps the nearest.
  EXPECT_EQ(s->radiusSearch((*c)[4], 1e10, i, d), 300);
  EXPECT_EQ(s->radiusSearch((*c)[4], 1e10, i, d, 10), 10);
  EXPECT_EQ(i[0], 4);
}

INSTANTIATE_TEST_SUITE_P(Backends, SearchCompat,
                         ::testing::Values(Backend::DelaunayWalk, Backend::KdTreeDelaunayWalk),
                         [](const ::testing::TestParamInfo<Backend>& info) {
                           return backendName(info.param);
                         });

}  // namespace
