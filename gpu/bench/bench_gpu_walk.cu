// GPU Delaunay-walk benchmark: batch NN (PNN hints, grid start, perfect start) for every tile width,
// the GPU brute force, kNN / radius, the CPU walk and nanoflann on 1 and all cores, and the whole GPU
// ICP (single and batched), on the dragon clouds. A plain executable (the device machine has no
// Google Benchmark); prints one table and checks every walk answer against the brute force.
//
// usage: bench_gpu_walk [data_dir] [reps]     (data_dir holds dragon_vrip_res2.ply / dragon_vrip.ply)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numeric>
#include <string>
#include <thread>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/walk.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/gpu/delaunay_walk.h"
#include "pcl_delaunay_walk/gpu/iterative_closest_point.h"

#ifdef DW_HAVE_NANOFLANN
#include <nanoflann.hpp>
#endif

using dw::gpu::checkCuda;
using dw::gpu::DelaunayWalk;
using dw::gpu::DeviceBuffer;
using Clock = std::chrono::steady_clock;

namespace {

int g_reps = 50;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

/// Median kernel time in microseconds of fn() on the default stream, by CUDA events.
template <typename F>
double timeGpu(F&& fn, int reps = g_reps) {
  cudaEvent_t a, b;
  checkCuda(cudaEventCreate(&a), "event");
  checkCuda(cudaEventCreate(&b), "event");
  for (int i = 0; i < 3; ++i) fn();  // warm-up: module load, caches
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    checkCuda(cudaEventRecord(a), "record");
    fn();
    checkCuda(cudaEventRecord(b), "record");
    checkCuda(cudaEventSynchronize(b), "sync");
    float ms = 0.f;
    checkCuda(cudaEventElapsedTime(&ms, a, b), "elapsed");
    t.push_back(ms * 1e3);
  }
  checkCuda(cudaGetLastError(), "benchmark kernel");
  cudaEventDestroy(a);
  cudaEventDestroy(b);
  return median(t);
}

template <typename F>
double timeHost(F&& fn, int reps) {
  fn();
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    const auto t0 = Clock::now();
    fn();
    t.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return median(t);
}

template <typename F>
void parallelFor(std::size_t n, unsigned threads, F&& f) {
  if (threads <= 1) {
    f(std::size_t(0), n);
    return;
  }
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t)
    pool.emplace_back([&, t] { f(n * t / threads, n * (t + 1) / threads); });
  for (auto& th : pool) th.join();
}

void row(const std::string& name, double us, const std::string& note = "") {
  std::printf("| %-58s | %12.1f | %s\n", name.c_str(), us, note.c_str());
  std::fflush(stdout);
}

/// Rigid motion (rotation about a fixed skew axis by `angle`, then a shift) applied in float.
float4 moved(const dw::Vec3f& p, float angle, float shift) {
  const float ax = 0.267f, ay = 0.802f, az = 0.535f;  // unit axis
  const float c = std::cos(angle), s = std::sin(angle), k = 1.f - c;
  const float x = (c + ax * ax * k) * p.x + (ax * ay * k - az * s) * p.y + (ax * az * k + ay * s) * p.z;
  const float y = (ay * ax * k + az * s) * p.x + (c + ay * ay * k) * p.y + (ay * az * k - ax * s) * p.z;
  const float z = (az * ax * k - ay * s) * p.x + (az * ay * k + ax * s) * p.y + (c + az * az * k) * p.z;
  return float4{x + shift, y - 0.5f * shift, z + 0.25f * shift, 0.f};
}

#ifdef DW_HAVE_NANOFLANN
struct CloudAdaptor {
  const std::vector<dw::Vec3f>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const {
    const auto& p = (*pts)[i];
    return d == 0 ? p.x : (d == 1 ? p.y : p.z);
  }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, CloudAdaptor>,
                                                   CloudAdaptor, 3, std::uint32_t>;
#endif

/// One cloud's graph on the device with the ICP-like queries, their PNN hints and the brute-force
/// truth every timed walk is checked against.
struct WalkBench {
  const dw::DelaunayGraph& graph;
  DelaunayWalk& walk;
  std::size_t n;
  std::vector<float4> q;  ///< this iteration's queries (host copy)
  DeviceBuffer<float4> dq;
  DeviceBuffer<std::uint32_t> hints, verts, steps, truth_v;
  DeviceBuffer<float> d2, truth_d2;
  std::vector<float> truth;
  double brute_force_us = 0;
  int best_lanes = 8, best_layout = 0;

  WalkBench(const dw::DelaunayGraph& g, DelaunayWalk& w)
      : graph(g), walk(w), n(g.numVertices()), hints(n), verts(n), steps(n), truth_v(n), d2(n), truth_d2(n) {}

  /// How many of d2's answers differ from the brute force (printed when any do).
  std::size_t check(const char* what) {
    std::vector<float> got;
    d2.download(got);
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i) bad += got[i] != truth[i];
    if (bad) std::printf("!! %s: %zu of %zu answers differ from brute force\n", what, bad, n);
    return bad;
  }
  double meanSteps() {
    std::vector<std::uint32_t> s;
    steps.download(s);
    return std::accumulate(s.begin(), s.end(), 0.0) / double(n);
  }
};

/// Reads the cloud, builds its graph on the host and prints its size and degrees.
dw::DelaunayGraph buildGraph(const std::vector<double>& xyz) {
  const auto t0 = Clock::now();
  auto graph = dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3));
  const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::size_t max_deg = 0;
  for (std::size_t v = 0; v < graph.numVertices(); ++v)
    max_deg = std::max(max_deg, graph.degree(dw::index_t(v)));
  std::printf(
      "points %zu, vertices %zu, directed edges %zu (mean degree %.1f, max %zu), graph build %.2f s (host)\n",
      xyz.size() / 3, graph.numVertices(), graph.numDirectedEdges(),
      double(graph.numDirectedEdges()) / double(graph.numVertices()), max_deg, build_s);
  return graph;
}

/// ICP-like queries in the graph's (Morton) order: the cloud moved a little (previous iteration),
/// then moved a little less (this iteration); PNN hints are the previous iteration's answers. Times
/// the brute force that gives the truth.
void prepareQueries(WalkBench& b) {
  const std::size_t n = b.n;
  std::vector<float4> q_prev(n);
  b.q.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    q_prev[i] = moved(b.graph.points[i], 0.010f, 0.0010f);
    b.q[i] = moved(b.graph.points[i], 0.008f, 0.0008f);
  }
  DeviceBuffer<float4> dq_prev;
  dq_prev.upload(q_prev);
  b.dq.upload(b.q);
  b.walk.nearest(dq_prev.ptr(), n, nullptr, b.hints.ptr(), b.d2.ptr());
  const int bf_reps = n > 200000 ? 3 : 10;
  b.brute_force_us =
      timeGpu([&] { b.walk.bruteForceNearest(b.dq.ptr(), n, b.truth_v.ptr(), b.truth_d2.ptr()); }, bf_reps);
  b.truth_d2.download(b.truth);
}

// Layouts: 0 = neighbour indices (gather positions), 1 = inline neighbour positions.
const char* const kLayoutName[2] = {"index", "inline positions"};

/// The PNN walk for every tile width and layout; leaves the walk at the fastest.
void benchTileWidths(WalkBench& b) {
  DelaunayWalk& walk = b.walk;
  const std::size_t n = b.n;
  double best = 1e30;
  for (int layout : {0, 1}) {
    walk.setInlineNeighbourPositions(layout == 1);
    for (int lanes : {1, 2, 4, 8, 16, 32}) {
      if (layout == 1 && (lanes == 1 || lanes == 32)) continue;
      walk.setGroupSize(lanes);
      const double t =
          timeGpu([&] { walk.nearest(b.dq.ptr(), n, b.hints.ptr(), b.verts.ptr(), b.d2.ptr()); });
      walk.nearest(b.dq.ptr(), n, b.hints.ptr(), b.verts.ptr(), b.d2.ptr(), b.steps.ptr());
      const std::size_t bad = b.check("PNN walk");
      char note[128];
      std::snprintf(note, sizeof note, "mean steps %.2f, %s", b.meanSteps(),
                    bad ? "MISMATCH" : "== brute force");
      row(std::string("GPU walk, PNN hints, ") + std::to_string(lanes) + " lane(s)/query, " +
              kLayoutName[layout],
          t, note);
      if (t < best) {
        best = t;
        b.best_lanes = lanes;
        b.best_layout = layout;
      }
    }
  }
  walk.setInlineNeighbourPositions(b.best_layout == 1);
  std::printf("best: %d lanes, %s layout\n", b.best_lanes, kLayoutName[b.best_layout]);
  walk.setGroupSize(b.best_lanes);
}

/// At the best tile width: the safe-ball test off, a user's defaults, the grid start, the perfect
/// start, and the brute force beside them.
void benchWalkVariants(WalkBench& b) {
  DelaunayWalk& walk = b.walk;
  const std::size_t n = b.n;
  {  // what the safe-ball test saves (same configuration, test off)
    walk.setSafeBallTest(false);
    const double t = timeGpu([&] { walk.nearest(b.dq.ptr(), n, b.hints.ptr(), b.verts.ptr(), b.d2.ptr()); });
    walk.nearest(b.dq.ptr(), n, b.hints.ptr(), b.verts.ptr(), b.d2.ptr(), b.steps.ptr());
    char note[128];
    std::snprintf(note, sizeof note, "mean steps %.2f, %s", b.meanSteps(),
                  b.check("PNN walk, no safe ball") ? "MISMATCH" : "== brute force");
    row("GPU walk, PNN hints, best, safe-ball test off", t, note);
    walk.setSafeBallTest(true);
  }
  {
    DelaunayWalk fresh(b.graph);  // the defaults a user gets
    const double t = timeGpu([&] { fresh.nearest(b.dq.ptr(), n, b.hints.ptr(), b.verts.ptr(), b.d2.ptr()); });
    fresh.nearest(b.dq.ptr(), n, b.hints.ptr(), b.verts.ptr(), b.d2.ptr());
    char note[128];
    std::snprintf(note, sizeof note, "%s", b.check("default walk") ? "MISMATCH" : "== brute force");
    row("GPU walk, PNN hints, DEFAULT settings (" + std::to_string(fresh.groupSize()) + " lanes, " +
            (fresh.inlineNeighbourPositions() ? "inline positions" : "index") + ")",
        t, note);
  }
  {
    const double t = timeGpu([&] { walk.nearest(b.dq.ptr(), n, nullptr, b.verts.ptr(), b.d2.ptr()); });
    walk.nearest(b.dq.ptr(), n, nullptr, b.verts.ptr(), b.d2.ptr(), b.steps.ptr());
    char note[128];
    std::snprintf(note, sizeof note, "mean steps %.2f, %s", b.meanSteps(),
                  b.check("grid walk") ? "MISMATCH" : "== brute force");
    row("GPU walk, grid start (first ICP round), " + std::to_string(b.best_lanes) + " lanes", t, note);
  }
  for (int lanes : {1, b.best_lanes}) {
    walk.setGroupSize(lanes);
    const double t =
        timeGpu([&] { walk.nearest(b.dq.ptr(), n, b.truth_v.ptr(), b.verts.ptr(), b.d2.ptr()); });
    row("GPU walk, perfect start, " + std::to_string(lanes) + " lane(s)", t, "scan of one neighbourhood");
  }
  walk.setGroupSize(b.best_lanes);
  row("GPU brute force (own kernel)", b.brute_force_us, "reference");
}

/// kNN for two k and a bounded radius search at twice the mean NN spacing, from the PNN hints.
void benchKnnAndRadius(WalkBench& b) {
  DeviceBuffer<std::uint32_t> idx, cnt;
  DeviceBuffer<float> dd;
  for (unsigned k : {8u, 16u}) {
    const double t = timeGpu([&] { b.walk.knn(b.dq, k, &b.hints, idx, dd, cnt); }, 10);
    row("GPU kNN k=" + std::to_string(k) + ", PNN hints", t, "");
  }
  const dw::DelaunayGraph& graph = b.graph;
  double spacing = 0.0;  // mean NN spacing estimate from the graph's edges
  for (std::size_t v = 0; v < std::min<std::size_t>(b.n, 2000); ++v) {
    float m = 1e30f;
    for (auto e = graph.offsets[v]; e < graph.offsets[v + 1]; ++e) m = std::min(m, 2.f * graph.edges[e].m);
    spacing += m;
  }
  spacing /= double(std::min<std::size_t>(b.n, 2000));
  const float r = float(2.0 * spacing);
  const double t = timeGpu([&] { b.walk.radius(b.dq, r, 32, &b.hints, idx, dd, cnt); }, 10);
  std::vector<std::uint32_t> c;
  cnt.download(c);
  char note[96];
  std::snprintf(note, sizeof note, "r = %.2g, mean found %.1f", r,
                std::accumulate(c.begin(), c.end(), 0.0) / double(b.n));
  row("GPU radius, max_nn 32, PNN hints", t, note);
}

/// The CPU peers: the core's walk from the same hints, and nanoflann, on 1 and all threads.
void benchCpuPeers(WalkBench& b, unsigned hw_threads) {
  const std::size_t n = b.n;
  std::vector<std::uint32_t> h;
  b.hints.download(h);
  std::vector<dw::Vec3f> qc(n);
  for (std::size_t i = 0; i < n; ++i) qc[i] = {b.q[i].x, b.q[i].y, b.q[i].z};
  std::vector<dw::index_t> out(n);
  for (unsigned th : {1u, hw_threads}) {
    const double t = timeHost(
        [&] {
          parallelFor(n, th, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t i = lo; i < hi; ++i) out[i] = dw::walk(b.graph, qc[i], h[i]).vertex;
          });
        },
        th == 1 ? 3 : 10);
    row("CPU walk (core), PNN hints, " + std::to_string(th) + " thread(s)", t, "");
  }
#ifdef DW_HAVE_NANOFLANN
  CloudAdaptor ad{&b.graph.points};
  const auto t0 = Clock::now();
  KdTree tree(3, ad, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  std::printf("nanoflann build: %.1f ms\n",
              std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  for (unsigned th : {1u, hw_threads}) {
    const double t = timeHost(
        [&] {
          parallelFor(n, th, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t i = lo; i < hi; ++i) {
              std::uint32_t idx;
              float dd;
              tree.knnSearch(&qc[i].x, 1, &idx, &dd);
              out[i] = idx;
            }
          });
        },
        th == 1 ? 3 : 10);
    row("CPU nanoflann k-d tree, " + std::to_string(th) + " thread(s)", t, "");
  }
#else
  std::printf("(nanoflann not found: its rows are missing)\n");
#endif
}

/// GPU ICP align() to convergence, then with no criterion able to fire before max_iterations (the
/// per-iteration cost).
void benchIcpSingle(dw::gpu::IterativeClosestPoint& icp, const dw::gpu::IcpParameters& p) {
  dw::gpu::IcpResult res;
  const double t = timeHost([&] { res = icp.align(); }, 20);
  char note[160];
  std::snprintf(note, sizeof note, "%d iterations (%s), %u correspondences, MSE %.2e, R00 %.6f",
                res.iterations, dw::gpu::toString(res.state), res.correspondences, res.mse,
                res.transformation[0]);
  row("GPU ICP align(), end to end (graph on device)", t, note);
  dw::gpu::IcpParameters fixed = p;
  fixed.transformation_epsilon = -1.0;
  fixed.euclidean_fitness_epsilon = -1.0;
  fixed.mse_threshold_absolute = -1.0;
  icp.setParameters(fixed);
  dw::gpu::IcpResult r30;
  const double t30 = timeHost([&] { r30 = icp.align(); }, 10);
  char n30[96];
  std::snprintf(n30, sizeof n30, "%d iterations: %.1f us per iteration", r30.iterations,
                t30 / r30.iterations);
  row("GPU ICP align(), exactly 30 iterations", t30, n30);
  icp.setParameters(p);
}

/// Batched: 8 sources (the same cloud under 8 shifts) in one alignAll(), against 8 single calls.
void benchIcpBatch(const DelaunayWalk::ConstPtr& target, const std::vector<double>& src,
                   const dw::gpu::IcpParameters& p) {
  const int kBatch = 8;
  std::vector<std::vector<double>> srcs(kBatch, src);
  for (int b = 0; b < kBatch; ++b)
    for (std::size_t i = 0; i + 2 < src.size(); i += 3) srcs[b][i] += 0.0005 * b;
  dw::gpu::IterativeClosestPoint batch(target);
  batch.setParameters(p);
  std::vector<std::unique_ptr<dw::gpu::IterativeClosestPoint>> singles;
  for (auto& sb : srcs) {
    batch.addSource(dw::PointView::fromDouble(sb.data(), sb.size() / 3));
    singles.push_back(std::make_unique<dw::gpu::IterativeClosestPoint>(target));
    singles.back()->setParameters(p);
    singles.back()->setInputSource(dw::PointView::fromDouble(sb.data(), sb.size() / 3));
  }
  const double tb = timeHost([&] { batch.alignAll(); }, 10);
  const double ts = timeHost(
      [&] {
        for (auto& one : singles) one->align();
      },
      10);
  row("GPU ICP alignAll(), 8 sources in one call", tb, "");
  row("GPU ICP align() x 8, one after another", ts, "sources already on the device");
}

/// Whole GPU ICP: the cloud (input order, world frame) moved by a known motion, registered back,
/// with the walk at the best tile width and layout.
void benchIcp(const WalkBench& b, const std::vector<double>& xyz) {
  dw::gpu::IcpParameters p;
  p.max_iterations = 30;
  p.max_correspondence_distance = 0.01;
  p.transformation_epsilon = 1e-10;
  p.euclidean_fitness_epsilon = 1e-6;
  auto target = std::make_shared<DelaunayWalk>(b.graph);
  target->setGroupSize(b.best_lanes);  // the ICP walk uses the target's tile width and layout
  target->setInlineNeighbourPositions(b.best_layout == 1);
  dw::gpu::IterativeClosestPoint icp(target);
  icp.setParameters(p);
  std::vector<double> src(xyz.size());
  const double ang = 0.05, c = std::cos(ang), s = std::sin(ang);
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    src[i] = c * xyz[i] - s * xyz[i + 1] + 0.003;
    src[i + 1] = s * xyz[i] + c * xyz[i + 1] - 0.002;
    src[i + 2] = xyz[i + 2] + 0.001;
  }
  icp.setInputSource(dw::PointView::fromDouble(src.data(), src.size() / 3));
  benchIcpSingle(icp, p);
  benchIcpBatch(target, src, p);
}

void benchCloud(const std::string& name, const std::string& path, unsigned hw_threads) {
  std::printf("\n## %s (%s)\n", name.c_str(), path.c_str());
  const auto xyz = dw::readPointsXyz(path);
  const dw::DelaunayGraph graph = buildGraph(xyz);
  const auto t0 = Clock::now();
  DelaunayWalk walk(graph);
  std::printf("upload + start grid: %.1f ms\n",
              std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  WalkBench b(graph, walk);
  prepareQueries(b);
  std::printf("| %-58s | %12s | note\n", "what (exact 1-NN unless said)", "median us");
  std::printf("|%s|%s|-----\n", std::string(60, '-').c_str(), std::string(14, '-').c_str());
  benchTileWidths(b);
  benchWalkVariants(b);
  benchKnnAndRadius(b);
  benchCpuPeers(b, hw_threads);
  benchIcp(b, xyz);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : "../shared/data/models";
  if (argc > 2) g_reps = std::max(3, std::atoi(argv[2]));
  if (dw::gpu::cudaDeviceCount() == 0) {
    std::printf("no CUDA device: nothing to measure\n");
    return 0;
  }
  cudaDeviceProp prop{};
  checkCuda(cudaGetDeviceProperties(&prop, 0), "properties");
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  std::printf("device: %s, %d SMs, L2 %d MB; host threads: %u\n", prop.name, prop.multiProcessorCount,
              prop.l2CacheSize >> 20, hw);
  try {
    for (const char* f : {"dragon_vrip_res2.ply", "dragon_vrip.ply"}) {
      const std::string path = dir + "/" + f;
      if (FILE* fp = std::fopen(path.c_str(), "rb")) {
        std::fclose(fp);
        benchCloud(f, path, hw);
      } else {
        std::printf("missing %s: skipped\n", path.c_str());
      }
    }
  } catch (const std::exception& e) {
    std::printf("error: %s\n", e.what());
    return 1;
  }
  return 0;
}
