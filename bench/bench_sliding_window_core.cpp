// Sliding-window maps: keeping the walk graph of a window up to date by vertex removal and
// insertion (dw::DynamicDelaunayGraph) against rebuilding it (buildDelaunayGraph, incremental builder).
// One thread throughout; times are thread CPU time. Each "slide" drops the oldest 10 % (or 1 %) of the window
// and adds as many new points.
//
// Counters: us_per_removed / us_per_inserted (kernel updates), update_ms (both), graph_ms (walk graph
// from the kept triangulation), slide_ms (all). The rebuild benchmarks give the alternative:
// graph_ms (buildDelaunayGraph, which is the reported time) and kernel_ms (its triangulation alone).
//
//   bench_sliding_window_core                      # window 200k: uniform, quantised, synthetic LiDAR
//   DW_BENCH_WINDOW=50000 bench_sliding_window_core
#include <benchmark/benchmark.h>
#include <time.h>

#include <cmath>
#include <cstdlib>
#include <deque>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "pcl_delaunay_walk/core/graph/dynamic_delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

#ifdef DW_HAVE_CGAL
#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/property_map.h>
#include <CGAL/spatial_sort.h>
#endif

namespace {

constexpr int kSlides = 5;

std::size_t windowSize() {
  const char* e = std::getenv("DW_BENCH_WINDOW");
  return e ? std::strtoull(e, nullptr, 10) : 200000;
}

// A stream of distinct points: uniform in a slab that moves along x (a vehicle driving through a map),
// optionally quantised to 1 cm like LAS coordinates (many cospherical ties).
enum class Kind { Uniform, Quantised, Lidar };

std::vector<dw::Vec3f> lidarStream(std::size_t n);

std::vector<dw::Vec3f> stream(std::size_t n, Kind kind) {
  if (kind == Kind::Lidar) return lidarStream(n);
  const bool quantised = kind == Kind::Quantised;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<dw::Vec3f> p;
  p.reserve(n);
  std::set<std::tuple<float, float, float>> seen;
  const float length = 100.f * float(n) / 200000.f;  // ~20 points per m^3 over a 100 x 40 x 25 m slab
  for (std::size_t i = 0; p.size() < n; ++i) {
    const float t = float(p.size()) / float(n);
    dw::Vec3f q{length * (t + 0.1f * u(rng)), 40.f * u(rng), 25.f * u(rng)};
    if (quantised)
      q = {std::round(q.x * 100.f) / 100.f, std::round(q.y * 100.f) / 100.f, std::round(q.z * 100.f) / 100.f};
    if (seen.insert({q.x, q.y, q.z}).second) p.push_back(q);
  }
  return p;
}

// Thread CPU time: the machine these numbers come from is shared, and every step here is one thread.
double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Synthetic airborne LiDAR (core/las/synthetic_lidar.h) in acquisition order, repeats dropped, relative
// to the generator's offset: flat roofs and terrain, multi-return trees, 1 cm quantisation.
std::vector<dw::Vec3f> lidarStream(std::size_t n) {
  dw::las::LidarGenOptions opt;
  opt.num_points = n + n / 5 + 1000;
  std::vector<dw::Vec3f> p;
  p.reserve(n);
  std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> seen;
  dw::las::generateLidar(opt, [&](const dw::las::LasRecord& r) {
    if (p.size() < n && seen.insert({r.X, r.Y, r.Z}).second)
      p.push_back({float(r.X * opt.scale), float(r.Y * opt.scale), float(r.Z * opt.scale)});
  });
  return p;
}

dw::PointView view(const dw::Vec3f* p, std::size_t n) {
  return dw::PointView::fromFloat(&p->x, n, sizeof(dw::Vec3f));
}

void slide(benchmark::State& state, Kind kind) {
  const std::size_t window = windowSize(), step = window * std::size_t(state.range(0)) / 100;
  const auto pts = stream(window + kSlides * step, kind);
  dw::DynamicDelaunayGraph dyn(std::array<double, 3>{0.0, 0.0, 0.0});
  std::deque<dw::DynamicDelaunayGraph::PointId> fifo;
  for (auto id : dyn.insert(view(pts.data(), window))) fifo.push_back(id);
  std::size_t next = window;
  double remove_s = 0, insert_s = 0, graph_s = 0;
  for (auto _ : state) {
    const auto t0 = cpuSeconds();
    std::vector<dw::DynamicDelaunayGraph::PointId> oldest(fifo.begin(), fifo.begin() + step);
    dyn.remove(oldest);
    fifo.erase(fifo.begin(), fifo.begin() + step);
    const auto t1 = cpuSeconds();
    for (auto id : dyn.insert(view(pts.data() + next, step))) fifo.push_back(id);
    next += step;
    const auto t2 = cpuSeconds();
    const dw::DelaunayGraph g = dyn.graph(nullptr, 1);
    benchmark::DoNotOptimize(g.edges.data());
    const auto t3 = cpuSeconds();
    remove_s += t1 - t0;
    insert_s += t2 - t1;
    graph_s += t3 - t2;
    state.SetIterationTime(t3 - t0);
  }
  const double slides = double(state.iterations());
  state.counters["us_per_removed"] = 1e6 * remove_s / (slides * step);
  state.counters["us_per_inserted"] = 1e6 * insert_s / (slides * step);
  state.counters["graph_ms"] = 1e3 * graph_s / slides;
  state.counters["slide_ms"] = 1e3 * (remove_s + insert_s + graph_s) / slides;
  state.counters["update_ms"] = 1e3 * (remove_s + insert_s) / slides;
  state.counters["removed_per_slide"] = double(step);
}

// What a sliding-window user does without removal: rebuild the window's graph from scratch.
void rebuild(benchmark::State& state, Kind kind) {
  const std::size_t window = windowSize();
  const auto pts = stream(window, kind);
  dw::BuildOptions opt;
  opt.builder = dw::BuilderType::Incremental;
  opt.num_threads = 1;
  double seconds = 0, kernel_seconds = 0;
  for (auto _ : state) {
    const auto t0 = cpuSeconds();
    const dw::DelaunayGraph g = dw::buildDelaunayGraph(view(pts.data(), pts.size()), opt);
    benchmark::DoNotOptimize(g.edges.data());
    const auto t1 = cpuSeconds();
    {
      // The triangulation alone (BRIO + Bowyer-Watson), the part that removal and insertion replace.
      dw::builder3d::Triangulation3D k;
      k.setPoints(pts.data(), pts.size());
      const auto order = dw::builder3d::brioOrder(pts);
      k.build(order.data(), order.size());
      benchmark::DoNotOptimize(k.numLiveTetrahedra());
    }
    kernel_seconds += cpuSeconds() - t1;
    seconds += t1 - t0;
    state.SetIterationTime(t1 - t0);
  }
  state.counters["graph_ms"] = 1e3 * seconds / double(state.iterations());
  state.counters["kernel_ms"] = 1e3 * kernel_seconds / double(state.iterations());
  state.counters["us_per_point"] = 1e6 * seconds / (double(state.iterations()) * window);
}

#ifdef DW_HAVE_CGAL
// The peer: CGAL's Delaunay_triangulation_3 (exact predicates, symbolic perturbation) doing the same
// slides on its own structure, by vertex handle. Its removal also re-triangulates the hole from a
// small triangulation of the link. Each batch (the first window too) is spatially sorted before it is
// inserted, each point with the previous one as the location hint, and the oldest points are removed
// in spatial order: our side BRIO-sorts both its batches, and CGAL's own range insertion sorts too.
// (In stream order consecutive points lie ~20 m apart, which makes CGAL's insertions ~2.6x dearer.)
void cgalSlide(benchmark::State& state, Kind kind) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using DT = CGAL::Delaunay_triangulation_3<K>;
  using SortByIndex = CGAL::Spatial_sort_traits_adapter_3<K, CGAL::Pointer_property_map<K::Point_3>::type>;
  const std::size_t window = windowSize(), step = window * std::size_t(state.range(0)) / 100;
  const auto pts = stream(window + kSlides * step, kind);
  DT dt;
  std::deque<DT::Vertex_handle> fifo;
  std::vector<K::Point_3> batch;
  std::vector<std::size_t> order;
  std::vector<DT::Vertex_handle> handles;
  auto spatialOrder = [&] {
    order.resize(batch.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    CGAL::spatial_sort(order.begin(), order.end(), SortByIndex(CGAL::make_property_map(batch)));
  };
  auto insertBatch = [&](std::size_t first, std::size_t count) {  // handles join the FIFO in stream order
    batch.resize(count);
    for (std::size_t k = 0; k < count; ++k)
      batch[k] = K::Point_3(pts[first + k].x, pts[first + k].y, pts[first + k].z);
    spatialOrder();
    handles.resize(count);
    DT::Vertex_handle hint = fifo.empty() ? DT::Vertex_handle() : fifo.back();
    for (std::size_t k : order) handles[k] = hint = dt.insert(batch[k], hint);
    fifo.insert(fifo.end(), handles.begin(), handles.end());
  };
  auto removeOldest = [&](std::size_t count) {
    handles.assign(fifo.begin(), fifo.begin() + std::ptrdiff_t(count));
    fifo.erase(fifo.begin(), fifo.begin() + std::ptrdiff_t(count));
    batch.resize(count);
    for (std::size_t k = 0; k < count; ++k) batch[k] = handles[k]->point();
    spatialOrder();
    for (std::size_t k : order) dt.remove(handles[k]);
  };
  insertBatch(0, window);
  std::size_t next = window;
  double remove_s = 0, insert_s = 0;
  for (auto _ : state) {
    const double t0 = cpuSeconds();
    removeOldest(step);
    const double t1 = cpuSeconds();
    insertBatch(next, step);
    next += step;
    const double t2 = cpuSeconds();
    remove_s += t1 - t0;
    insert_s += t2 - t1;
    state.SetIterationTime(t2 - t0);
  }
  const double slides = double(state.iterations());
  state.counters["us_per_removed"] = 1e6 * remove_s / (slides * step);
  state.counters["us_per_inserted"] = 1e6 * insert_s / (slides * step);
  state.counters["update_ms"] = 1e3 * (remove_s + insert_s) / slides;
}
void BM_cgal_slide_uniform(benchmark::State& s) {
  cgalSlide(s, Kind::Uniform);
}
BENCHMARK(BM_cgal_slide_uniform)
    ->Arg(10)
    ->Iterations(kSlides)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
#endif

void BM_slide_uniform(benchmark::State& s) {
  slide(s, Kind::Uniform);
}
void BM_slide_quantised(benchmark::State& s) {
  slide(s, Kind::Quantised);
}
void BM_rebuild_uniform(benchmark::State& s) {
  rebuild(s, Kind::Uniform);
}
void BM_rebuild_quantised(benchmark::State& s) {
  rebuild(s, Kind::Quantised);
}

// Argument: the slide in percent of the window.
BENCHMARK(BM_slide_uniform)
    ->Arg(10)
    ->Arg(1)
    ->Iterations(kSlides)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_rebuild_uniform)->Iterations(2)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_slide_quantised)
    ->Arg(10)
    ->Arg(1)
    ->Iterations(kSlides)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_rebuild_quantised)->Iterations(2)->UseManualTime()->Unit(benchmark::kMillisecond);
void BM_slide_lidar(benchmark::State& s) {
  slide(s, Kind::Lidar);
}
void BM_rebuild_lidar(benchmark::State& s) {
  rebuild(s, Kind::Lidar);
}
BENCHMARK(BM_slide_lidar)
    ->Arg(10)
    ->Arg(1)
    ->Iterations(kSlides)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_rebuild_lidar)->Iterations(2)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
