// dw::gpu::DelaunayWalk against brute force (GPU and host): exact NN from every start, kNN, radius,
// degenerate graphs and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "gpu_test_support.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/gpu/delaunay_walk.h"

namespace {

using dw::gpu::DelaunayWalk;
using dw::gpu::DeviceBuffer;
using dwgpu_test::exactDist2;
constexpr std::uint32_t kInv = dw::kInvalidIndex;

dw::DelaunayGraph buildGraph(const std::vector<double>& xyz) {
  return dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3));
}

/// Host brute force over the graph's own float vertices: the minimum distance (the reference value).
std::vector<double> hostMinDist2(const dw::DelaunayGraph& g, const std::vector<float4>& q) {
  std::vector<double> out(q.size(), std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < q.size(); ++i) {
    if (!std::isfinite(q[i].x) || !std::isfinite(q[i].y) || !std::isfinite(q[i].z)) continue;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& p : g.points) best = std::min(best, exactDist2(p.x, p.y, p.z, q[i].x, q[i].y, q[i].z));
    out[i] = best;
  }
  return out;
}

std::vector<float4> randomQueries(std::size_t n, std::uint32_t seed, float lo, float hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float4> q(n);
  for (auto& p : q) p = float4{u(rng), u(rng), u(rng), 0.f};
  return q;
}

struct NnOut {
  std::vector<std::uint32_t> v, steps;
  std::vector<float> d2;
};

NnOut runNearest(const DelaunayWalk& w, const std::vector<float4>& q,
                 const std::vector<std::uint32_t>* hints) {
  DeviceBuffer<float4> dq;
  dq.upload(q);
  DeviceBuffer<std::uint32_t> dh, dv, ds;
  DeviceBuffer<float> dd;
  if (hints) dh.upload(*hints);
  w.nearest(dq, hints ? &dh : nullptr, dv, dd, &ds);
  NnOut o;
  dv.download(o.v);
  dd.download(o.d2);
  ds.download(o.steps);
  return o;
}

/// Every returned vertex must be at the minimum distance, and the reported distance must be its own.
void expectExact(const dw::DelaunayGraph& g, const std::vector<float4>& q, const NnOut& o,
                 const std::vector<double>& ref, const char* what) {
  ASSERT_EQ(o.v.size(), q.size());
  std::size_t bad = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    if (std::isinf(ref[i])) {
      if (o.v[i] != kInv) ++bad;
      continue;
    }
    if (o.v[i] >= g.numVertices()) {
      ++bad;
      continue;
    }
    const auto& p = g.points[o.v[i]];
    const double own = exactDist2(p.x, p.y, p.z, q[i].x, q[i].y, q[i].z);
    if (float(own) != o.d2[i] || own != ref[i]) {
      if (bad < 5)
        ADD_FAILURE() << what << ": query " << i << " got vertex " << o.v[i] << " d2 " << o.d2[i] << " (own "
                      << own << "), brute force " << ref[i];
      ++bad;
    }
  }
  EXPECT_EQ(bad, 0u) << what;
}

class GpuWalk : public ::testing::Test {
 protected:
  void SetUp() override { DW_REQUIRE_CUDA_DEVICE(); }
};

TEST_F(GpuWalk, NearestEqualsBruteForceForEveryGroupSizeAndStart) {
  // Clustered + uniform points: uneven degrees, and queries far outside the hull as well as inside.
  auto xyz = dwgpu_test::randomCloud(6000, 7);
  std::mt19937 rng(3);
  std::normal_distribution<double> nd(0.0, 0.02);
  for (int c = 0; c < 4000; ++c) {
    xyz.push_back(0.3 + nd(rng));
    xyz.push_back(-0.2 + nd(rng));
    xyz.push_back(0.1 + nd(rng));
  }
  const auto g = buildGraph(xyz);
  DelaunayWalk w(g);
  auto q = randomQueries(6000, 11, -1.5f, 1.5f);
  const auto far = randomQueries(500, 12, -1000.f, 1000.f);
  q.insert(q.end(), far.begin(), far.end());
  const auto very_far = randomQueries(50, 13, -1e9f, 1e9f);  // float distances of vertices tie
  q.insert(q.end(), very_far.begin(), very_far.end());
  const auto ref = hostMinDist2(g, q);

  // GPU brute force agrees with the host bit for bit.
  {
    DeviceBuffer<float4> dq;
    dq.upload(q);
    DeviceBuffer<std::uint32_t> dv(q.size());
    DeviceBuffer<float> dd(q.size());
    w.bruteForceNearest(dq.ptr(), q.size(), dv.ptr(), dd.ptr());
    NnOut o;
    dv.download(o.v);
    dd.download(o.d2);
    expectExact(g, q, o, ref, "GPU brute force");
  }
  std::vector<std::uint32_t> random_hints(q.size());
  std::mt19937 hr(5);
  for (auto& h : random_hints) h = hr() % std::uint32_t(g.numVertices());
  for (bool inline_positions : {false, true}) {
    w.setInlineNeighbourPositions(inline_positions);
    ASSERT_EQ(w.inlineNeighbourPositions(), inline_positions);
    for (int lanes : {1, 2, 4, 8, 16, 32}) {
      w.setGroupSize(lanes);
      expectExact(g, q, runNearest(w, q, nullptr), ref, "grid start");
      expectExact(g, q, runNearest(w, q, &random_hints), ref, "random hints");
    }
  }
}

TEST_F(GpuWalk, SafeBallAndNearTiesStayExact) {
  const auto g = buildGraph(dwgpu_test::randomCloud(4000, 31));
  DelaunayWalk w(g);
  ASSERT_TRUE(w.safeBallTest());
  std::vector<float4> q;
  std::vector<std::uint32_t> hints;
  std::mt19937 rng(32);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (std::uint32_t v = 0; v < g.numVertices(); v += 2) {
    const auto& p = g.points[v];
    float nn2 = INFINITY;  // nearest neighbour distance^2 of v (a Delaunay neighbour)
    for (auto e = g.offsets[v]; e < g.offsets[v + 1]; ++e) {
      const auto& o = g.points[g.edges[e].j];
      nn2 = std::min(nn2, (o.x - p.x) * (o.x - p.x) + (o.y - p.y) * (o.y - p.y) + (o.z - p.z) * (o.z - p.z));
    }
    const float s = 0.2f * std::sqrt(nn2);  // well inside the safe ball (radius 0.5 sqrt(nn2))
    q.push_back(float4{p.x + s * u(rng) * 0.5f, p.y + s * u(rng) * 0.5f, p.z + s * u(rng) * 0.5f, 0.f});
    hints.push_back(v);
    // The midpoint of an edge: two vertices (near-)tie, the float comparison cannot decide and the
    // walk must settle it in double.
    const auto& o = g.points[g.edges[g.offsets[v]].j];
    q.push_back(float4{0.5f * (p.x + o.x), 0.5f * (p.y + o.y), 0.5f * (p.z + o.z), 0.f});
    hints.push_back(v);
  }
  const auto ref = hostMinDist2(g, q);
  for (int lanes : {1, 4, 8}) {
    w.setGroupSize(lanes);
    w.setSafeBallTest(true);
    const NnOut on = runNearest(w, q, &hints);
    expectExact(g, q, on, ref, "safe ball on");
    for (std::size_t i = 0; i < q.size(); i += 2) {  // inside the ball of the hint: no step, no scan
      EXPECT_EQ(on.v[i], hints[i]);
      EXPECT_EQ(on.steps[i], 0u);
    }
    w.setSafeBallTest(false);
    const NnOut off = runNearest(w, q, &hints);
    expectExact(g, q, off, ref, "safe ball off");
    EXPECT_EQ(on.v, off.v);
    EXPECT_EQ(on.d2, off.d2);
  }
  w.setSafeBallTest(true);
}

TEST_F(GpuWalk, HintsOutOfRangeFallBackAndPerfectHintsTakeNoStep) {
  const auto g = buildGraph(dwgpu_test::randomCloud(3000, 21));
  DelaunayWalk w(g);
  const auto q = randomQueries(4000, 22, -1.2f, 1.2f);
  const auto ref = hostMinDist2(g, q);
  std::vector<std::uint32_t> hints(q.size());
  const auto nv = std::uint32_t(g.numVertices());
  for (std::size_t i = 0; i < hints.size(); ++i) hints[i] = i % 3 == 0 ? kInv : (i % 3 == 1 ? nv : nv + 1000);
  const NnOut a = runNearest(w, q, &hints);
  expectExact(g, q, a, ref, "out-of-range hints");
  // PNN with the answer as hint: already nearest, zero steps.
  const NnOut b = runNearest(w, q, &a.v);
  expectExact(g, q, b, ref, "perfect hints");
  EXPECT_EQ(std::accumulate(b.steps.begin(), b.steps.end(), 0u), 0u);
  // The grid start is a good start: far fewer steps than from vertex 0 (hint 0 for everyone).
  std::vector<std::uint32_t> zero(q.size(), 0u);
  const NnOut c = runNearest(w, q, &zero);
  expectExact(g, q, c, ref, "start at vertex 0");
  const double grid_steps = std::accumulate(a.steps.begin(), a.steps.end(), 0.0);
  const double zero_steps = std::accumulate(c.steps.begin(), c.steps.end(), 0.0);
  EXPECT_LT(grid_steps * 3.0, zero_steps);
}

TEST_F(GpuWalk, NonFiniteQueriesAndEmptyOrTinyGraphs) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<float4> q = {{nan, 0, 0, 0}, {0, inf, 0, 0}, {0.1f, 0.2f, 0.3f, 0}, {0, 0, -inf, 0}};
  {
    DelaunayWalk w(dw::DelaunayGraph{});
    const NnOut o = runNearest(w, q, nullptr);
    for (std::size_t i = 0; i < q.size(); ++i) {
      EXPECT_EQ(o.v[i], kInv);
      EXPECT_TRUE(std::isinf(o.d2[i]));
    }
  }
  for (std::size_t n : {1u, 2u, 3u, 5u}) {
    const auto g = buildGraph(dwgpu_test::randomCloud(n, 40 + std::uint32_t(n)));
    DelaunayWalk w(g);
    const NnOut o = runNearest(w, q, nullptr);
    expectExact(g, q, o, hostMinDist2(g, q), "tiny graph");
    EXPECT_EQ(o.v[0], kInv);
    EXPECT_EQ(o.v[1], kInv);
    EXPECT_EQ(o.v[3], kInv);
  }
}

TEST_F(GpuWalk, CoplanarCollinearAndDuplicatePoints) {
  std::vector<double> plane, line;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-10, 10);
  for (int i = 0; i < 3000; ++i) {
    plane.insert(plane.end(), {u(rng), u(rng), 0.0});  // height-normalised ground: every z = 0
    // Random t: some pairs ~1e-5 apart, which in float d2 tie for queries ~17 units away (the case
    // that made the walk compare in double).
    const double t = u(rng);
    line.insert(line.end(), {t, 2 * t + 1, -t});
  }
  for (int i = 0; i < 500; ++i)
    plane.insert(plane.end(), {plane[3 * i], plane[3 * i + 1], 0.0});  // duplicates
  for (const auto* xyz : {&plane, &line}) {
    const auto g = buildGraph(*xyz);
    DelaunayWalk w(g);
    const auto q = randomQueries(3000, 77, -12.f, 12.f);
    const auto ref = hostMinDist2(g, q);
    for (bool inline_positions : {false, true})
      for (int lanes : {1, 8}) {
        w.setInlineNeighbourPositions(inline_positions);
        w.setGroupSize(lanes);
        expectExact(g, q, runNearest(w, q, nullptr), ref, "degenerate set");
      }
  }
}

TEST_F(GpuWalk, RealDragonIcpLikeQueries) {
  const std::string path = dwgpu_test::dataPath("models/dragon_vrip_res3.ply");
  DW_REQUIRE_DATA(path);
  const auto g = buildGraph(dwgpu_test::readXyz(path));
  DelaunayWalk w(g);
  // ICP-like: the cloud itself, slightly moved; then moved again with the previous answers as hints.
  std::vector<float4> q0(g.numVertices()), q1(g.numVertices());
  const float c = std::cos(0.02f), s = std::sin(0.02f);
  for (std::size_t i = 0; i < g.numVertices(); ++i) {
    const auto& p = g.points[i];
    q0[i] = float4{c * p.x - s * p.y + 0.002f, s * p.x + c * p.y, p.z + 0.001f, 0.f};
    q1[i] = float4{p.x + 0.0005f, p.y - 0.0003f, p.z, 0.f};
  }
  const NnOut a = runNearest(w, q0, nullptr);
  expectExact(g, q0, a, hostMinDist2(g, q0), "dragon grid start");
  const NnOut b = runNearest(w, q1, &a.v);
  expectExact(g, q1, b, hostMinDist2(g, q1), "dragon PNN");
  const double mean_steps = std::accumulate(b.steps.begin(), b.steps.end(), 0.0) / double(b.steps.size());
  EXPECT_LT(mean_steps, 5.0);  // PNN after a small move: a few steps (seed: ~2)
}

/// Host reference of kNN / radius: every input's distance, sorted.
std::vector<double> hostSortedInputDist2(const dw::DelaunayGraph& g, const float4& q) {
  std::vector<double> d;
  for (std::size_t i = 0; i < g.numInputPoints(); ++i) {
    const auto v = g.input_to_vertex[i];
    if (v == kInv) continue;
    const auto& p = g.points[v];
    d.push_back(exactDist2(p.x, p.y, p.z, q.x, q.y, q.z));
  }
  std::sort(d.begin(), d.end());
  return d;
}

void checkExpansion(const dw::DelaunayGraph& g, const std::vector<float4>& q, unsigned k, double r2,
                    const std::vector<std::uint32_t>& idx, const std::vector<float>& d2,
                    const std::vector<std::uint32_t>& counts, const char* what) {
  std::size_t bad = 0;
  for (std::size_t i = 0; i < q.size() && bad < 5; ++i) {
    const auto ref = hostSortedInputDist2(g, q[i]);
    std::size_t expect = 0;
    while (expect < ref.size() && expect < k && ref[expect] <= r2) ++expect;
    if (counts[i] != expect) {
      ADD_FAILURE() << what << ": query " << i << " count " << counts[i] << " expected " << expect;
      ++bad;
      continue;
    }
    std::vector<std::uint32_t> seen;
    for (std::size_t t = 0; t < k; ++t) {
      const std::uint32_t in = idx[i * k + t];
      if (t >= expect) {
        if (in != kInv) ++bad;
        continue;
      }
      const auto v = in < g.numInputPoints() ? g.input_to_vertex[in] : kInv;
      if (v == kInv) {
        ++bad;
        continue;
      }
      const auto& p = g.points[v];
      const double own = exactDist2(p.x, p.y, p.z, q[i].x, q[i].y, q[i].z);
      if (float(own) != d2[i * k + t] || own != ref[t]) {
        ADD_FAILURE() << what << ": query " << i << " rank " << t << " d2 " << d2[i * k + t] << " own " << own
                      << " expected " << ref[t];
        ++bad;
      }
      seen.push_back(in);
    }
    std::sort(seen.begin(), seen.end());
    if (std::adjacent_find(seen.begin(), seen.end()) != seen.end()) {
      ADD_FAILURE() << what << ": query " << i << " repeats an index";
      ++bad;
    }
  }
  EXPECT_EQ(bad, 0u) << what;
}

TEST_F(GpuWalk, KnnAndRadiusEqualBruteForceWithDuplicates) {
  auto xyz = dwgpu_test::randomCloud(2500, 55);
  for (int i = 0; i < 300; ++i)  // duplicates: one vertex, several inputs
    for (int a = 0; a < 3; ++a) xyz.push_back(xyz[3 * (i * 7) + a]);
  xyz.push_back(std::numeric_limits<double>::quiet_NaN());  // a skipped input
  xyz.push_back(0.0);
  xyz.push_back(0.0);
  const auto g = buildGraph(xyz);
  DelaunayWalk w(g);
  auto q = randomQueries(700, 56, -1.3f, 1.3f);
  q.push_back(float4{std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f, 0.f});
  DeviceBuffer<float4> dq;
  dq.upload(q);
  DeviceBuffer<std::uint32_t> di, dc;
  DeviceBuffer<float> dd;
  std::vector<std::uint32_t> idx, counts;
  std::vector<float> d2;
  for (unsigned k : {1u, 5u, 16u, 33u, 64u}) {
    w.knn(dq, k, nullptr, di, dd, dc);
    di.download(idx);
    dd.download(d2);
    dc.download(counts);
    checkExpansion(g, q, k, std::numeric_limits<double>::infinity(), idx, d2, counts, "knn");
    EXPECT_EQ(counts.back(), 0u);
  }
  for (float r : {0.0f, 0.05f, 0.15f, 0.3f}) {
    for (unsigned max_nn : {4u, 64u}) {
      w.radius(dq, r, max_nn, nullptr, di, dd, dc);
      di.download(idx);
      dd.download(d2);
      dc.download(counts);
      checkExpansion(g, q, max_nn, double(r) * double(r), idx, d2, counts, "radius");
    }
  }
}

TEST_F(GpuWalk, BadArgumentsThrow) {
  const auto g = buildGraph(dwgpu_test::randomCloud(100, 1));
  DelaunayWalk w(g);
  DeviceBuffer<float4> dq;
  dq.upload(randomQueries(10, 2, -1, 1));
  DeviceBuffer<std::uint32_t> di, dc, dh;
  DeviceBuffer<float> dd;
  EXPECT_THROW(w.knn(dq, 0, nullptr, di, dd, dc), dw::Error);
  EXPECT_THROW(w.knn(dq, DelaunayWalk::kMaxK + 1, nullptr, di, dd, dc), dw::Error);
  EXPECT_THROW(w.radius(dq, -1.f, 8, nullptr, di, dd, dc), dw::Error);
  EXPECT_THROW(w.radius(dq, std::numeric_limits<float>::infinity(), 8, nullptr, di, dd, dc), dw::Error);
  EXPECT_THROW(w.radius(dq, 0.1f, 0, nullptr, di, dd, dc), dw::Error);
  EXPECT_THROW(w.setGroupSize(3), dw::Error);
  dh.upload(std::vector<std::uint32_t>(5, 0));
  EXPECT_THROW(w.nearest(dq, &dh, di, dd), dw::Error);  // hint count differs from query count
  dw::DelaunayGraph broken = g;
  broken.edges[0].j = 1u << 30;
  EXPECT_THROW(DelaunayWalk{broken}, dw::Error);
}

}  // namespace
