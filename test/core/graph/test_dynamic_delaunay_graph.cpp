// DynamicDelaunayGraph: a sliding window of points kept without re-triangulating. Every round the walk
// graph equals a fresh build, walk NN and kNN equal brute force, bad input changes nothing, and sets
// that stop spanning 3D (and start again) are handled.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <tuple>

#include "core/builder3d/builder3d_test_util.h"
#include "pcl_delaunay_walk/core/graph/dynamic_delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"

namespace {

using dw::DynamicDelaunayGraph;
using Id = DynamicDelaunayGraph::PointId;
using IdEdges = std::vector<std::pair<Id, Id>>;

dw::PointView view(const std::vector<dw::Vec3f>& p) {
  return dw::PointView::fromFloat(p.empty() ? nullptr : &p[0].x, p.size(), sizeof(dw::Vec3f));
}

// Undirected edges of a graph as pairs of caller ids (input i is ids[i]).
IdEdges idEdges(const dw::DelaunayGraph& g, const std::vector<Id>& ids) {
  IdEdges e;
  for (dw::index_t v = 0; v < g.numVertices(); ++v)
    for (dw::index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const Id a = ids[g.representative(v)], b = ids[g.representative(g.edges[k].j)];
      if (a < b) e.emplace_back(a, b);
    }
  std::sort(e.begin(), e.end());
  return e;
}

// Nearest and 8-NN distances from the graph equal brute force over the live points.
void expectExactSearch(const dw::DelaunayGraph& graph, const DynamicDelaunayGraph& dyn, unsigned seed) {
  auto g = std::make_shared<dw::DelaunayGraph>(graph);
  dw::NeighbourSearch search(g);
  std::vector<dw::Vec3f> live;
  for (Id id : dyn.liveIds()) {
    const auto p = dyn.position(id);
    live.push_back(g->toLocal(p[0], p[1], p[2]));
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.3f, 1.3f);
  std::vector<dw::index_t> idx;
  std::vector<float> d2;
  for (int it = 0; it < 150; ++it) {
    const auto w = dyn.position(dyn.liveIds()[rng() % live.size()]);
    const dw::Vec3f q = it % 2 ? g->toLocal(u(rng), u(rng), u(rng))
                               : g->toLocal(w[0] + 0.01 * u(rng), w[1] + 0.01 * u(rng), w[2]);
    std::vector<float> all(live.size());
    for (std::size_t i = 0; i < live.size(); ++i) all[i] = dw::squaredDistance(q, live[i]);
    std::sort(all.begin(), all.end());
    for (dw::StartStrategy s : {dw::StartStrategy::Zero, dw::StartStrategy::KdAnn}) {
      const dw::WalkResult nn = search.nearest(q, s);
      ASSERT_NEAR(nn.dist2, all[0], 1e-5f * all[0] + 1e-12f) << "query " << it;
    }
    const std::size_t k = 8;
    ASSERT_EQ(search.knn(q, k, search.nearest(q), idx, d2), std::min(k, live.size()));
    for (std::size_t j = 0; j < d2.size(); ++j) ASSERT_NEAR(d2[j], all[j], 1e-5f * all[j] + 1e-12f) << it;
  }
}

// The kept triangulation equals a fresh build over the live slots (the same ids, so the same ties).
void expectKernelEqualsFreshBuild(const DynamicDelaunayGraph& dyn, std::size_t round) {
  std::vector<dw::index_t> slots;
  for (Id id : dyn.liveIds()) slots.push_back(dyn.slotOf(id));
  dw::builder3d::Triangulation3D fresh;
  fresh.setPoints(dyn.slotPoints().data(), dyn.slotPoints().size());
  fresh.build(slots.data(), slots.size());
  ASSERT_EQ(b3d_test::kernelEdges(dyn.kernel()), b3d_test::kernelEdges(fresh)) << "round " << round;
}

TEST(DynamicDelaunayGraph, SlidingWindowEqualsBuildDelaunayGraph) {
  // Two far corners stay for good: buildDelaunayGraph then centres on 0 and sees the same floats, so
  // on input in general position its edge set must be exactly ours.
  const std::size_t window = 3000, step = window / 10, rounds = 5;
  auto stream = b3d_test::uniformCube(window + rounds * step + 100, 21);
  DynamicDelaunayGraph dyn(std::array<double, 3>{0.0, 0.0, 0.0});
  const std::vector<dw::Vec3f> corners = {{-1.5f, -1.5f, -1.5f}, {1.5f, 1.5f, 1.5f}};
  dyn.insert(view(corners));
  std::vector<Id> fifo;
  const std::vector<dw::Vec3f> first(stream.begin(), stream.begin() + window);
  for (Id id : dyn.insert(view(first))) fifo.push_back(id);
  EXPECT_TRUE(dyn.triangulated());
  for (std::size_t r = 0; r <= rounds; ++r) {
    if (r > 0) {
      dyn.remove(std::vector<Id>(fifo.begin(), fifo.begin() + step));  // the oldest 10 %
      fifo.erase(fifo.begin(), fifo.begin() + step);
      const std::vector<dw::Vec3f> next(stream.begin() + window + (r - 1) * step,
                                        stream.begin() + window + r * step);
      for (Id id : dyn.insert(view(next))) fifo.push_back(id);
    }
    dyn.validate();
    std::vector<Id> ids;
    const dw::DelaunayGraph g = dyn.graph(&ids, 2);
    g.validate();
    ASSERT_EQ(ids, dyn.liveIds());
    ASSERT_EQ(g.numVertices(), window + 2);
    std::vector<dw::Vec3f> live;
    for (Id id : ids) {
      const auto p = dyn.position(id);
      live.push_back({float(p[0]), float(p[1]), float(p[2])});
    }
    dw::BuildOptions opt;
    opt.builder = dw::BuilderType::Incremental;
    opt.num_threads = 1;
    const dw::DelaunayGraph fresh = dw::buildDelaunayGraph(view(live), opt);
    ASSERT_EQ(fresh.origin, g.origin);
    ASSERT_EQ(idEdges(g, ids), idEdges(fresh, ids)) << "round " << r;
    expectExactSearch(g, dyn, static_cast<unsigned>(r));
  }
}

TEST(DynamicDelaunayGraph, DegenerateWindowIsExact) {
  // Quantised points with a georeferenced offset: many cospherical ties, so the check is against a
  // fresh kernel with the same slot ids (unique perturbed triangulation) plus exact search.
  const std::size_t window = 1200, step = 120;
  auto stream = b3d_test::quantised(window + 5 * step + 300, 22, 0.1f);
  for (auto& p : stream) p.z *= 0.5f;
  std::vector<double> xyz;
  for (const auto& p : stream) xyz.insert(xyz.end(), {p.x + 6.0e5, p.y + 5.2e6, p.z + 300.0});
  DynamicDelaunayGraph dyn;  // origin from the first batch
  std::vector<Id> fifo = dyn.insert(dw::PointView::fromDouble(xyz.data(), window));
  Id added_last = fifo.back();
  for (std::size_t r = 1; r <= 5; ++r) {
    std::mt19937 rng(static_cast<unsigned>(r));
    std::shuffle(fifo.begin(), fifo.end(), rng);  // remove a random 10 %, not the oldest
    dyn.remove(std::vector<Id>(fifo.end() - step, fifo.end()));
    fifo.resize(fifo.size() - step);
    const auto added =
        dyn.insert(dw::PointView::fromDouble(xyz.data() + 3 * (window + (r - 1) * step), step));
    fifo.insert(fifo.end(), added.begin(), added.end());
    added_last = added.back();
    dyn.validate();
    ASSERT_NO_FATAL_FAILURE(expectKernelEqualsFreshBuild(dyn, r));
    const dw::DelaunayGraph g = dyn.graph();
    g.validate();
    expectExactSearch(g, dyn, static_cast<unsigned>(10 + r));
  }
  // Float relative to the origin: caller coordinates come back to well within a millimetre.
  const std::size_t last = window + 5 * step - 1;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(dyn.position(added_last)[k], xyz[3 * last + k], 1e-3);
}

TEST(DynamicDelaunayGraph, SyntheticLidarStream) {
  // Airborne LiDAR in acquisition order: 1 cm quantisation, flat roofs and terrain (many coplanar and
  // cospherical groups, hull vertices of high degree), UTM-like offsets. The window slides along the
  // flight line, as a map does.
  dw::las::LidarGenOptions opt;
  opt.num_points = 9000;
  opt.swath = 60.0;
  std::vector<double> xyz;
  std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> seen;  // the kernel wants distinct points
  dw::las::generateLidar(opt, [&](const dw::las::LasRecord& r) {
    if (seen.insert({r.X, r.Y, r.Z}).second)
      xyz.insert(xyz.end(), {r.X * opt.scale + opt.offset_x, r.Y * opt.scale + opt.offset_y,
                             r.Z * opt.scale + opt.offset_z});
  });
  const std::size_t n = xyz.size() / 3, window = n / 2, step = window / 10;
  ASSERT_GT(n, 8000u);
  DynamicDelaunayGraph dyn;
  std::vector<Id> fifo = dyn.insert(dw::PointView::fromDouble(xyz.data(), window));
  for (std::size_t r = 1; r <= 5; ++r) {
    dyn.remove(std::vector<Id>(fifo.begin(), fifo.begin() + step));
    fifo.erase(fifo.begin(), fifo.begin() + step);
    const auto added =
        dyn.insert(dw::PointView::fromDouble(xyz.data() + 3 * (window + (r - 1) * step), step));
    fifo.insert(fifo.end(), added.begin(), added.end());
    dyn.validate();
    ASSERT_NO_FATAL_FAILURE(expectKernelEqualsFreshBuild(dyn, r));
  }
  expectExactSearch(dyn.graph(), dyn, 7);
}

TEST(DynamicDelaunayGraph, SetsThatStopAndStartSpanning3D) {
  // Planar sets go to buildDelaunayGraph's 2D path (the exact 2D engine of dw::tin), with or without Qhull.
  DynamicDelaunayGraph dyn(std::array<double, 3>{0.0, 0.0, 0.0});
  EXPECT_EQ(dyn.graph().numVertices(), 0u);
  const auto ids3 = dyn.insert(view({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_FALSE(dyn.triangulated());
  EXPECT_EQ(dyn.graph().numDirectedEdges(), 6u);
  // A flat 10 x 10 roof: still no 3D triangulation, the planar graph is used.
  std::vector<dw::Vec3f> roof;
  for (int x = 0; x < 10; ++x)
    for (int y = 0; y < 10; ++y)
      if (x > 1 || y > 1) roof.push_back({float(x), float(y), 0.f});
  dyn.insert(view(roof));
  EXPECT_FALSE(dyn.triangulated());
  dyn.validate();
  EXPECT_EQ(dyn.graph().dimension, 2);
  expectExactSearch(dyn.graph(), dyn, 1);
  // One point above the roof: 3D.
  const auto apex = dyn.insert(view({{4.5f, 4.5f, 2.f}}));
  EXPECT_TRUE(dyn.triangulated());
  dyn.validate();
  expectExactSearch(dyn.graph(), dyn, 2);
  // Removing it leaves a flat set: the triangulation is dropped, search stays exact.
  dyn.remove(apex);
  EXPECT_FALSE(dyn.triangulated());
  dyn.validate();
  EXPECT_EQ(dyn.graph().dimension, 2);
  expectExactSearch(dyn.graph(), dyn, 3);
  // A batch that removes the last off-plane point and more.
  dyn.insert(view({{1.5f, 1.5f, -1.f}, {7.5f, 2.5f, 1.f}}));
  EXPECT_TRUE(dyn.triangulated());
  std::vector<Id> batch = {ids3[0], ids3[1]};
  for (Id id : dyn.liveIds())
    if (dyn.position(id)[2] != 0.0) batch.push_back(id);
  dyn.remove(batch);
  EXPECT_FALSE(dyn.triangulated());
  dyn.validate();
  expectExactSearch(dyn.graph(), dyn, 4);
}

// Per point id: its neighbours as (neighbour id, direction, half length), sorted, and its safe radius;
// graphs of the same points compare equal whatever their vertex numbering.
using Neighbourhoods = std::map<Id, std::pair<std::vector<std::tuple<Id, float, float, float, float>>, float>>;
Neighbourhoods neighbourhoods(const dw::DelaunayGraph& g, const std::vector<Id>& ids) {
  Neighbourhoods out;
  for (dw::index_t v = 0; v < g.numVertices(); ++v) {
    auto& [list, safe] = out[ids[g.representative(v)]];
    for (dw::index_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k) {
      const dw::EdgeRecord& e = g.edges[k];
      list.emplace_back(ids[g.representative(e.j)], e.ex, e.ey, e.ez, e.m);
    }
    std::sort(list.begin(), list.end());
    safe = g.safe_radius2.empty() ? -1.f : g.safe_radius2[v];
  }
  return out;
}

TEST(DynamicDelaunayGraph, WalkGraphKeptUpToDateEqualsAFreshExtraction) {
  // A window sliding along x: each frame removes the points behind and inserts new ones ahead, in one
  // or two batches between walkGraph() calls; the kept graph must equal graph()'s fresh extraction.
  const std::size_t window = 4000, step = 400, frames = 8;
  const std::size_t small_rounds = 5, small_step = 4;
  auto stream = b3d_test::uniformCube(window + frames * step + small_rounds * small_step, 31);
  std::sort(stream.begin(), stream.end(), [](const dw::Vec3f& a, const dw::Vec3f& b) { return a.x < b.x; });
  DynamicDelaunayGraph dyn(std::array<double, 3>{0.0, 0.0, 0.0});
  std::vector<Id> fifo = dyn.insert(view(std::vector<dw::Vec3f>(stream.begin(), stream.begin() + window)));
  std::vector<Id> ids;
  auto held = dyn.walkGraph(&ids);  // the first call reads every point
  EXPECT_EQ(dyn.lastRefreshed(), window);
  for (std::size_t f = 0; f < frames; ++f) {
    const dw::DelaunayGraph before = *held;  // a graph handed out must not change under later updates
    const std::size_t out = f % 3 == 2 ? step / 2 : step;
    dyn.remove(std::vector<Id>(fifo.begin(), fifo.begin() + out));
    fifo.erase(fifo.begin(), fifo.begin() + out);
    const auto first = stream.begin() + window + f * step;
    for (std::size_t half = 0; half < 2; ++half) {  // two batches, the second after removing one point
      const std::vector<dw::Vec3f> batch(first + half * step / 2, first + (half + 1) * step / 2);
      for (Id id : dyn.insert(view(batch))) fifo.push_back(id);
      if (half == 0) {
        dyn.remove({fifo[fifo.size() / 2]});
        fifo.erase(fifo.begin() + fifo.size() / 2);
      }
    }
    std::vector<Id> kept_ids, fresh_ids;
    const auto kept = f % 2 ? dyn.walkGraph(&kept_ids) : (held = dyn.walkGraph(&kept_ids));
    EXPECT_GT(dyn.lastRefreshed(), 0u);
    EXPECT_LT(dyn.lastRefreshed(), dyn.size()) << "frame " << f << ": only changed stars are re-read";
    kept->validate();
    ASSERT_EQ(kept->numVertices(), dyn.size());
    const dw::DelaunayGraph fresh = dyn.graph(&fresh_ids);
    ASSERT_EQ(neighbourhoods(*kept, kept_ids), neighbourhoods(fresh, fresh_ids)) << "frame " << f;
    expectExactSearch(*kept, dyn, static_cast<unsigned>(100 + f));
    if (f % 2) {
      EXPECT_EQ(neighbourhoods(*held, ids), neighbourhoods(before, ids)) << "frame " << f;
    } else {
      ids = kept_ids;
    }
  }
  // Small updates: few stars change, so they are re-read one by one instead of in a pass over all
  // tetrahedra; the result must be the same.
  for (std::size_t r = 0; r < small_rounds; ++r) {
    dyn.remove(std::vector<Id>(fifo.begin(), fifo.begin() + small_step));
    fifo.erase(fifo.begin(), fifo.begin() + small_step);
    const auto first = stream.begin() + window + frames * step + r * small_step;
    for (Id id : dyn.insert(view(std::vector<dw::Vec3f>(first, first + small_step)))) fifo.push_back(id);
    std::vector<Id> kept_ids, fresh_ids;
    const auto kept = dyn.walkGraph(&kept_ids);
    EXPECT_GT(dyn.lastRefreshed(), 0u);
    EXPECT_LT(8 * dyn.lastRefreshed(), dyn.size()) << "round " << r;
    kept->validate();
    const dw::DelaunayGraph fresh = dyn.graph(&fresh_ids);
    ASSERT_EQ(neighbourhoods(*kept, kept_ids), neighbourhoods(fresh, fresh_ids)) << "round " << r;
  }
}

TEST(DynamicDelaunayGraph, BadInputChangesNothing) {
  DynamicDelaunayGraph dyn(std::array<double, 3>{0.0, 0.0, 0.0});
  const auto pts = b3d_test::uniformCube(500, 23);
  const auto ids = dyn.insert(view(pts));
  std::vector<Id> before_ids;
  const auto before = idEdges(dyn.graph(&before_ids), before_ids);
  auto unchanged = [&] {
    dyn.validate();
    std::vector<Id> now_ids;
    const auto now = idEdges(dyn.graph(&now_ids), now_ids);
    EXPECT_EQ(now_ids, before_ids);
    EXPECT_EQ(now, before);
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(dyn.insert(view({{0.1f, 0.2f, 0.3f}, {0.5f, nan, 0.f}})), dw::Error);
  unchanged();
  EXPECT_THROW(dyn.insert(view({{0.1f, 0.2f, 0.3f}, pts[17]})), dw::Error);  // repeats a live point
  unchanged();
  EXPECT_THROW(dyn.insert(view({{0.1f, 0.2f, 0.3f}, {0.1f, 0.2f, 0.3f}})), dw::Error);  // within the batch
  unchanged();
  const std::vector<double> far = {1e40, 0.0, 0.0};
  EXPECT_THROW(dyn.insert(dw::PointView::fromDouble(far.data(), 1)), dw::Error);  // beyond float
  unchanged();
  EXPECT_THROW(dyn.remove({ids[3], 999999}), dw::Error);  // unknown id
  unchanged();
  EXPECT_THROW(dyn.remove({ids[3], ids[4], ids[3]}), dw::Error);  // listed twice
  unchanged();
  EXPECT_THROW(dyn.position(999999), dw::Error);
  // A removed id is gone for good; its slot is recycled but the id is not.
  dyn.remove({ids[3]});
  EXPECT_THROW(dyn.remove({ids[3]}), dw::Error);
  const auto again = dyn.insert(view({pts[3]}));  // the same position may come back under a new id
  EXPECT_NE(again[0], ids[3]);
  EXPECT_EQ(dyn.slotOf(again[0]), dw::index_t(3));  // ids[3]'s slot, recycled
  EXPECT_EQ(dyn.size(), pts.size());
  dyn.validate();
}

}  // namespace
