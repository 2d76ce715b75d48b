// detail::bucketThenSort (the graph build's Morton sort): the same sequence as std::sort for any
// thread count, whether the buckets are even, skewed past the fallback to parallelSort (a cloud with
// a far outlier fills few cells), or empty; and a real cloud with a far outlier builds the same graph
// on one and on three threads.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "core/util/parallel_sort.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"

using namespace dw;

namespace {

struct Item {
  std::uint64_t key;  // 40 bits: the top 12 pick the bucket
  std::uint32_t id;   // breaks ties, so the order is total
};

bool before(const Item& a, const Item& b) {
  return a.key != b.key ? a.key < b.key : a.id < b.id;
}

std::vector<Item> sortedByBuckets(std::vector<Item> v, unsigned threads) {
  detail::bucketThenSort(
      v, 1u << 12, [](const Item& it) { return static_cast<unsigned>(it.key >> 28); }, before, threads);
  return v;
}

void expectSameSequence(const std::vector<Item>& want, const std::vector<Item>& got, const char* what) {
  ASSERT_EQ(want.size(), got.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k)
    ASSERT_TRUE(want[k].key == got[k].key && want[k].id == got[k].id) << what << ": position " << k;
}

TEST(BucketThenSort, EqualsStdSortForEvenSkewedAndEmptyBuckets) {
  std::mt19937_64 rng(17);
  const std::uint32_t n = 300000;
  std::vector<Item> even(n), skewed(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint64_t key = rng() >> 24;                        // 40 bits
    even[i] = {key % 50000 == 7 ? (key & ~0xFFFFFull) : key, i};  // some equal keys too
    // Nine in ten share one bucket: past the quarter that sends it to parallelSort.
    skewed[i] = {i % 10 == 0 ? key : (std::uint64_t(5) << 28) | (key & 0xFFFFFFF), i};
  }
  for (const auto* input : {&even, &skewed}) {
    std::vector<Item> want = *input;
    std::sort(want.begin(), want.end(), before);
    for (const unsigned threads : {1u, 2u, 3u, 8u})
      expectSameSequence(want, sortedByBuckets(*input, threads), input == &even ? "even" : "skewed");
  }
  EXPECT_TRUE(sortedByBuckets({}, 4).empty());
  expectSameSequence({{3, 1}, {3, 2}}, sortedByBuckets({{3, 2}, {3, 1}}, 2), "two equal keys");
}

TEST(BucketThenSort, CloudWithAFarOutlierBuildsTheSameGraphOnAnyThreadCount) {
  // 60k points in a 10 m cube and one 1e5 m away: the cube fits in one of the Morton key's top cells,
  // so the build's sort takes the fallback.
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  std::vector<double> xyz;
  for (int i = 0; i < 60000; ++i) xyz.insert(xyz.end(), {u(rng), u(rng), u(rng)});
  xyz.insert(xyz.end(), {1e5, 2e5, 1e5});
  const PointView view = PointView::fromDouble(xyz.data(), xyz.size() / 3);
  BuildOptions one;
  one.num_threads = 1;
  const DelaunayGraph a = buildDelaunayGraph(view, one);
  a.validate();
  BuildOptions three;
  three.num_threads = 3;
  const DelaunayGraph b = buildDelaunayGraph(view, three);
  ASSERT_EQ(a.points.size(), b.points.size());
  EXPECT_EQ(0, std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(Vec3f)));
  EXPECT_EQ(a.input_to_vertex, b.input_to_vertex);
  EXPECT_EQ(a.offsets, b.offsets);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  EXPECT_EQ(0, std::memcmp(a.edges.data(), b.edges.data(), a.edges.size() * sizeof(EdgeRecord)));
}

}  // namespace
