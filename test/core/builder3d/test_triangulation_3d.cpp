// The Bowyer-Watson kernel on its own: structural validity (adjacency, orientation, local Delaunay
// under the perturbation), independence of insertion order and thread count, incremental insertion,
// and clear errors on inputs outside its contract.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numeric>
#include <random>

#include "builder3d_test_util.h"
#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "core/util/parallel_sort.h"
#include "core/util/space_filling_curve.h"

namespace {

using b3d_test::Edges;
using dw::builder3d::Triangulation3D;

using b3d_test::kernelEdges;

Edges buildWithOrder(const std::vector<dw::Vec3f>& pts, const std::vector<dw::index_t>& order,
                     bool check = true) {
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  k.build(order.data(), order.size());
  if (check) k.validate();
  EXPECT_EQ(k.numVertices(), pts.size());
  return kernelEdges(k, 1);
}

std::vector<dw::index_t> identity(std::size_t n) {
  std::vector<dw::index_t> o(n);
  std::iota(o.begin(), o.end(), 0u);
  return o;
}

TEST(InsertionOrder, SameOrderWhateverTheIdsOrder) {
  // The order is one sort by (round, Morton code, id). Ids in Morton order take the fast path (a
  // partition by round, then insertion sort), a few swapped neighbours make it move entries, and a
  // shuffle exceeds its budget and sorts: all must give the very same order.
  const auto pts = dw::mortonSortedDistinct(b3d_test::uniformCube(20000, 4));
  std::vector<dw::index_t> ascending(pts.size());
  std::iota(ascending.begin(), ascending.end(), 0u);
  using dw::builder3d::BrioGrowth;
  for (BrioGrowth growth : {BrioGrowth::kDoubling, BrioGrowth::kFourfold}) {
    const auto reference = dw::builder3d::brioOrder(pts, ascending, 0, growth);
    auto sorted_copy = reference;
    std::sort(sorted_copy.begin(), sorted_copy.end());
    ASSERT_EQ(sorted_copy, ascending) << "not a permutation";
    auto nearly = ascending;
    for (std::size_t i = 0; i + 1 < nearly.size(); i += 97) std::swap(nearly[i], nearly[i + 1]);
    EXPECT_EQ(dw::builder3d::brioOrder(pts, nearly, 0, growth), reference);
    auto shuffled = ascending;
    std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(7));
    EXPECT_EQ(dw::builder3d::brioOrder(pts, shuffled, 0, growth), reference);
    if (growth == BrioGrowth::kDoubling) continue;
    // The whole-build forms grow fourfold: the last round holds about 3/4 of the points, the one
    // before about 3/16.
    EXPECT_EQ(dw::builder3d::brioOrder(pts), reference);
    std::vector<std::size_t> rounds;
    EXPECT_EQ(dw::builder3d::brioOrder(pts, rounds, 0, 2), reference);
    ASSERT_GE(rounds.size(), 3u);
    const double last = double(pts.size() - rounds.back()) / pts.size();
    const double before = double(rounds.back() - rounds[rounds.size() - 2]) / pts.size();
    EXPECT_NEAR(last, 0.75, 0.02);
    EXPECT_NEAR(before, 0.1875, 0.02);
  }
  // Subsets double by default.
  const auto doubling = dw::builder3d::brioOrder(pts, ascending);
  EXPECT_EQ(doubling, dw::builder3d::brioOrder(pts, ascending, 0, dw::builder3d::BrioGrowth::kDoubling));
  EXPECT_NE(doubling, dw::builder3d::brioOrder(pts));
}

TEST(InsertionOrder, AdaptiveSortSortsAnyInput) {
  // The kernel's batches arrive nearly sorted; anything else must still come out sorted.
  std::mt19937 rng(11);
  std::vector<std::vector<dw::index_t>> inputs = {{}, {7}, {3, 3, 1, 3}};
  std::vector<dw::index_t> v(20000);
  std::iota(v.begin(), v.end(), 0u);
  inputs.push_back(v);  // sorted
  for (std::size_t i = 0; i + 1 < v.size(); i += 37) std::swap(v[i], v[i + 1]);
  inputs.push_back(v);  // nearly sorted
  std::reverse(v.begin(), v.end());
  inputs.push_back(v);  // reversed: the budget runs out
  std::shuffle(v.begin(), v.end(), rng);
  inputs.push_back(v);  // shuffled
  for (auto& x : v) x %= 50;
  inputs.push_back(v);  // many repeats
  for (auto in : inputs) {
    auto expected = in;
    std::sort(expected.begin(), expected.end());
    dw::detail::sortAdaptive(in);
    EXPECT_EQ(in, expected) << in.size() << " ids";
  }
}

TEST(Triangulation3D, UniformIsValidAndEdgesAreUnique) {
  const auto pts = b3d_test::uniformCube(3000, 1);
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  const auto order = dw::builder3d::brioOrder(pts);
  k.build(order.data(), order.size());
  k.validate();
  const Edges e = kernelEdges(k, 1);
  EXPECT_EQ(b3d_test::normalise(e).size(), e.size()) << "an edge was emitted twice";
  for (const auto& p : e) ASSERT_LT(p.first, p.second);
  // Volumetric Delaunay: about 7.7 undirected edges per vertex (mean degree ~15.5).
  EXPECT_GT(e.size(), 6 * pts.size());
  EXPECT_LT(e.size(), 9 * pts.size());
  EXPECT_EQ(k.stats().fallback_locations, 0u);
}

TEST(Triangulation3D, SameGraphForAnyThreadCount) {
  const auto pts = b3d_test::uniformCube(4000, 2);
  Triangulation3D k;
  k.setPoints(pts.data(), pts.size());
  const auto order = dw::builder3d::brioOrder(pts);
  k.build(order.data(), order.size());
  const Edges one = b3d_test::normalise(kernelEdges(k, 1));
  for (unsigned t : {2u, 3u, 8u}) EXPECT_EQ(b3d_test::normalise(kernelEdges(k, t)), one) << t << " threads";
}

TEST(Triangulation3D, ReleasingExtractionGivesTheSameEdgesOnAnyThreadCount) {
  // releaseIntoEdgeChunks lists into the adjacency's storage when it is big enough and into a new
  // array when not (tiny inputs on many threads: most tetrahedra span several ranges and are listed
  // up to three times), and writes one list: on one thread appended range by range, on several each
  // range at the end of the one before, published while the ranges run at once. Each way must give
  // edgeChunks()' edges, each once, in the same sequence (ascending smaller endpoint).
  for (std::size_t n : {std::size_t(5), std::size_t(9), std::size_t(40), std::size_t(300), std::size_t(5000)})
    for (unsigned t : {1u, 2u, 16u}) {
      const auto pts = b3d_test::mortonSorted(b3d_test::uniformCube(n, 50 + static_cast<unsigned>(n)));
      Triangulation3D k;
      k.setPoints(pts.data(), pts.size());
      const auto order = dw::builder3d::brioOrder(pts);
      k.build(order.data(), order.size());
      const Edges expected = kernelEdges(k, 1);
      Edges sequence;  // the per-range chunks of the same thread count, in order
      for (const auto& c : k.edgeChunks(t)) sequence.insert(sequence.end(), c.begin(), c.end());
      const auto chunks = k.releaseIntoEdgeChunks(t);
      Edges got;
      for (const auto& c : chunks) got.insert(got.end(), c.begin(), c.end());
      EXPECT_TRUE(std::is_sorted(got.begin(), got.end(),
                                 [](const auto& a, const auto& b) { return a.first < b.first; }))
          << n << " points, " << t << " threads";
      const Edges unique = b3d_test::normalise(got);
      EXPECT_EQ(unique.size(), got.size()) << n << " points, " << t << " threads: an edge twice";
      EXPECT_EQ(unique, expected) << n << " points, " << t << " threads";
      EXPECT_EQ(got, sequence) << n << " points, " << t << " threads";
      EXPECT_EQ(chunks.size(), 1u) << n << " points, " << t << " threads";
      EXPECT_FALSE(k.built());
    }
}

TEST(Triangulation3D, InsertionOrderDoesNotChangeTheGraph) {
  // With simulation of simplicity the perturbed Delaunay triangulation is unique, so even fully
  // degenerate input (a grid: all cells cospherical) gives the same edges whatever the order.
  for (const auto& pts : {b3d_test::uniformCube(1500, 3), b3d_test::grid(6, 5, 4)}) {
    const Edges a = b3d_test::normalise(buildWithOrder(pts, identity(pts.size())));
    const Edges b = b3d_test::normalise(buildWithOrder(pts, dw::builder3d::brioOrder(pts, 1)));
    auto rev = identity(pts.size());
    std::reverse(rev.begin(), rev.end());
    const Edges c = b3d_test::normalise(buildWithOrder(pts, rev));
    EXPECT_EQ(a, b);
    EXPECT_EQ(a, c);
  }
}

TEST(Triangulation3D, DegenerateInputsGiveValidTriangulations) {
  const std::vector<std::vector<dw::Vec3f>> sets = {
      b3d_test::grid(7, 7, 7),               // cospherical cells, coplanar faces
      b3d_test::latticeSphere(11 * 11 * 9),  // every point on one sphere
      b3d_test::quantised(3000, 4, 0.1f),    // LAS-like quantisation
      b3d_test::grid(30, 30, 2, 0.5f),       // two layers: nearly flat
  };
  for (const auto& pts : sets) {
    ASSERT_GE(pts.size(), 5u);
    const Edges e = buildWithOrder(pts, dw::builder3d::brioOrder(pts));
    EXPECT_GE(e.size(), pts.size());
  }
}

TEST(Triangulation3D, ACavityOfTheWholeBallLinksLikeAnyOther) {
  // The centre of a sphere inserted last destroys every tetrahedron: its cavity's boundary is the
  // hull, ~2n triangles, more directed edges than the link table's first size holds, so the table
  // grows during that insertion. The result must be valid and the same as with the centre first.
  auto pts = b3d_test::latticeSphere(2609);  // 1008 points
  const std::size_t n = pts.size();
  // 2n - 4 boundary triangles with 3 directed edges each: more than the 4096 entries the table starts
  // with could hold at all.
  ASSERT_GT(3 * (2 * n - 4), std::size_t(4096));
  pts.push_back({0, 0, 0});
  auto last = identity(n);
  last.push_back(static_cast<dw::index_t>(n));
  std::vector<dw::index_t> first{static_cast<dw::index_t>(n)};
  first.insert(first.end(), last.begin(), last.end() - 1);
  const Edges a = b3d_test::normalise(buildWithOrder(pts, last));
  const Edges b = b3d_test::normalise(buildWithOrder(pts, first));
  EXPECT_EQ(a, b);
  // Every point is a neighbour of the centre.
  EXPECT_EQ(std::count_if(a.begin(), a.end(), [&](const auto& e) { return e.second == n || e.first == n; }),
            static_cast<std::ptrdiff_t>(n));
}

TEST(Triangulation3D, IncrementalInsertionEqualsFreshBuild) {
  for (const auto& pts : {b3d_test::uniformCube(3000, 5), b3d_test::grid(8, 6, 5)}) {
    const std::size_t half = pts.size() / 2;
    // The reference cloud grows: the first half exists first, the array grows, the rest arrives.
    std::vector<dw::Vec3f> growing(pts.begin(), pts.begin() + half);
    Triangulation3D k;
    k.setPoints(growing.data(), growing.size());
    const auto order = dw::builder3d::brioOrder(growing);
    k.build(order.data(), order.size());
    growing = pts;
    k.setPoints(growing.data(), growing.size());
    for (std::size_t i = half; i < pts.size(); ++i) k.insert(static_cast<dw::index_t>(i));
    k.validate();
    const Edges fresh = b3d_test::normalise(buildWithOrder(pts, dw::builder3d::brioOrder(pts)));
    EXPECT_EQ(b3d_test::normalise(kernelEdges(k, 2)), fresh);
  }
}

TEST(Triangulation3D, InputsOutsideTheContractThrow) {
  Triangulation3D k;
  const auto flat = b3d_test::grid(5, 5, 1);
  k.setPoints(flat.data(), flat.size());
  auto o = identity(flat.size());
  EXPECT_THROW(k.build(o.data(), o.size()), dw::Error);  // coplanar

  const std::vector<dw::Vec3f> line = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}, {4, 4, 4}};
  k.setPoints(line.data(), line.size());
  o = identity(line.size());
  EXPECT_THROW(k.build(o.data(), o.size()), dw::Error);  // collinear

  const std::vector<dw::Vec3f> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  k.setPoints(three.data(), three.size());
  o = identity(three.size());
  EXPECT_THROW(k.build(o.data(), o.size()), dw::Error);  // too few

  auto pts = b3d_test::uniformCube(100, 6);
  pts.push_back(pts[10]);  // a duplicate
  k.setPoints(pts.data(), pts.size());
  o = identity(pts.size());
  EXPECT_THROW(k.build(o.data(), o.size()), dw::Error);

  o = identity(50);
  o.push_back(static_cast<dw::index_t>(pts.size() + 5));  // out of range
  EXPECT_THROW(k.build(o.data(), o.size()), dw::Error);

  Triangulation3D fresh;
  EXPECT_THROW(fresh.insert(0), dw::Error);  // not built
}

TEST(IncrementalBuilder, RejectsNonFiniteInput) {
  auto pts = b3d_test::uniformCube(50, 7);
  pts[3].y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(dw::incrementalDelaunayEdges(pts, {}), dw::Error);
}

TEST(IncrementalBuilder, ReportsProgress) {
  const auto pts = b3d_test::uniformCube(2000, 8);
  dw::BuildOptions opt;
  double last = -1.0;
  bool monotone = true;
  opt.progress = [&](const std::string&, double f) {
    monotone = monotone && f >= last;
    last = f;
  };
  dw::incrementalDelaunayEdges(pts, opt);
  EXPECT_TRUE(monotone);
  EXPECT_EQ(last, 1.0);
}

}  // namespace
