// 3D Delaunay graph builders side by side: the incremental kernel (1..N threads), Qhull
// (dw::qhullDelaunayEdges) and CGAL's Delaunay_triangulation_3 (benchmark-only peer) on the same
// Morton-ordered distinct float points the graph builder hands over. Counters: points per second,
// peak bytes per point the build adds (measured in a forked child), distinct edges per point, and for
// CGAL triangulation_s, its triangulation alone (without the edge listing).
//
//   bench_builder3d_core --benchmark_filter=uniform_1M
//   DW_BENCH_BIG=1 bench_builder3d_core        # also uniform 4M (incremental, CGAL)
//   DW_BENCH_QHULL_1M=1 bench_builder3d_core   # also Qhull at 1M (tens of seconds per run)
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/builder3d/block_parallel_builder.h"
#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "core/util/process_memory.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"

#ifdef DW_HAVE_CGAL
#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>
#endif

namespace {

using Points = std::vector<dw::Vec3f>;

// Distinct points in Morton order: what buildDelaunayGraph gives the builder.
Points prepare(const std::vector<dw::Vec3f>& p) {
  return dw::mortonSortedDistinct(p);
}

Points uniform(std::size_t n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Points p(n);
  for (auto& q : p) q = {u(rng), u(rng), u(rng)};
  return prepare(p);
}

// ASCII PLY vertices (x y z first), read through `gzip -dc` for .gz files so that no zlib is needed.
Points loadPly(const std::string& path) {
  const bool gz = path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0;
  FILE* f = gz ? popen(("gzip -dc '" + path + "'").c_str(), "r") : std::fopen(path.c_str(), "r");
  Points p;
  if (!f) return p;
  char line[4096];
  long vertices = -1;
  while (std::fgets(line, sizeof line, f)) {
    if (std::strncmp(line, "element vertex", 14) == 0) vertices = std::atol(line + 14);
    if (std::strncmp(line, "end_header", 10) == 0) break;
  }
  double c[3] = {0, 0, 0};
  std::vector<double> xyz;
  for (long i = 0; i < vertices && std::fgets(line, sizeof line, f); ++i) {
    double x, y, z;
    if (std::sscanf(line, "%lf %lf %lf", &x, &y, &z) != 3) break;
    xyz.insert(xyz.end(), {x, y, z});
    c[0] += x, c[1] += y, c[2] += z;
  }
  gz ? pclose(f) : std::fclose(f);
  const std::size_t n = xyz.size() / 3;
  for (std::size_t i = 0; i < n; ++i)
    p.push_back(
        {float(xyz[3 * i] - c[0] / n), float(xyz[3 * i + 1] - c[1] / n), float(xyz[3 * i + 2] - c[2] / n)});
  return prepare(p);
}

const Points& dataset(const std::string& name) {
  static std::vector<std::pair<std::string, Points>> cache;
  for (const auto& e : cache)
    if (e.first == name) return e.second;
  Points p;
  if (name == "uniform_100k") p = uniform(100000);
  if (name == "uniform_1M") p = uniform(1000000);
  if (name == "uniform_4M") p = uniform(4000000);
  if (name == "dragon_437k") {
    const char* dir = std::getenv("DW_SHARED_DATA_DIR");  // run-time override (e.g. on another machine)
    p = loadPly(std::string(dir ? dir : DW_SHARED_DATA_DIR) + "/models/dragon_vrip.ply.gz");
  }
  cache.emplace_back(name, std::move(p));
  return cache.back().second;
}

// Peak memory a build adds: run it in a forked child and compare the child's peak resident set with
// that of a child that does nothing (both start with the parent's pages, data sets included). The
// parent's free heap goes back to the system first (dw::releaseFreeHeap): a child reusing blocks that
// earlier timed runs freed adds no pages and under-reports (100k points read 64 B/pt on 2 threads).
template <class Fn>
double peakBytesOf(Fn&& fn) {
  dw::releaseFreeHeap();
  auto childPeak = [](auto&& body) -> double {
    const pid_t pid = fork();
    if (pid == 0) {
      body();
      _exit(0);
    }
    int status = 0;
    rusage ru{};
    if (pid < 0 || wait4(pid, &status, 0, &ru) != pid) return -1.0;
    return double(ru.ru_maxrss) * 1024.0;
  };
  const double base = childPeak([] {});
  const double used = childPeak(fn);
  return base < 0 || used < 0 ? 0.0 : std::max(0.0, used - base);
}

void setCounters(benchmark::State& state, std::size_t n, std::size_t edges, double bytes) {
  state.counters["points/s"] = benchmark::Counter(double(n), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["edges/pt"] = double(edges) / double(n);
  if (bytes > 0) state.counters["B/pt"] = bytes / double(n);
}

void benchIncremental(benchmark::State& state, std::string name, unsigned threads) {
  const Points& p = dataset(name);
  if (p.size() < 5) return state.SkipWithError(("data set not available: " + name).c_str());
  dw::BuildOptions opt;
  opt.num_threads = threads;
  std::size_t edges = 0;
  for (auto _ : state) {
    dw::EdgeList e = dw::incrementalDelaunayEdges(p, opt);
    edges = e.size();
    benchmark::DoNotOptimize(e.data());
  }
  const double bytes = peakBytesOf([&] {
    dw::EdgeList e = dw::incrementalDelaunayEdges(p, opt);
    benchmark::DoNotOptimize(e.data());
  });
  setCounters(state, p.size(), edges, bytes);
}

// The experimental block-parallel builder (not the default path; see docs/builder3d.md).
void benchBlocks(benchmark::State& state, std::string name, unsigned blocks) {
  const Points& p = dataset(name);
  if (p.size() < 5) return state.SkipWithError(("data set not available: " + name).c_str());
  std::size_t edges = 0;
  dw::builder3d::BlockBuildStats stats;
  for (auto _ : state) {
    dw::EdgeList e = dw::builder3d::blockParallelDelaunayEdges(p, blocks, &stats);
    edges = e.size();
    benchmark::DoNotOptimize(e.data());
  }
  state.counters["halo/pt"] = double(stats.halo_points) / double(p.size());
  setCounters(state, p.size(), edges, 0);
}

void benchQhull(benchmark::State& state, std::string name) {
  const Points& p = dataset(name);
  if (p.size() < 5) return state.SkipWithError(("data set not available: " + name).c_str());
  if (!dw::haveQhullBuilder()) return state.SkipWithError("Qhull builder not compiled in");
  std::size_t edges = 0;
  for (auto _ : state) {
    dw::EdgeList e = dw::qhullDelaunayEdges(p, 3, nullptr);
    benchmark::DoNotOptimize(e.data());
    state.PauseTiming();
    for (auto& pr : e)
      if (pr.first > pr.second) std::swap(pr.first, pr.second);
    std::sort(e.begin(), e.end());
    edges = std::size_t(std::unique(e.begin(), e.end()) - e.begin());  // Qhull lists each edge per facet
    state.ResumeTiming();
  }
  const double bytes = peakBytesOf([&] {
    dw::EdgeList e = dw::qhullDelaunayEdges(p, 3, nullptr);
    benchmark::DoNotOptimize(e.data());
  });
  setCounters(state, p.size(), edges, bytes);
}

#ifdef DW_HAVE_CGAL
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<dw::index_t, K>;
using Tds = CGAL::Triangulation_data_structure_3<Vb>;
using CgalDelaunay = CGAL::Delaunay_triangulation_3<K, Tds>;

// CGAL's whole job as ours: triangulate (range insertion spatially sorts, Hilbert and BRIO, itself),
// then list each finite edge once. The edges are listed per vertex through finite_adjacent_vertices:
// on 1M uniform points (this box) that took 1.3 s, against 2.2 s through finite_edges_iterator and
// another 2.2 s for number_of_finite_edges(), which counts by walking all edges (calling both would
// charge CGAL 8.6 s for its 5.5 s job). *triangulation_s gets the triangulation's own time.
dw::EdgeList cgalEdges(const Points& p, std::size_t* cells, double* triangulation_s) {
  std::vector<std::pair<K::Point_3, dw::index_t>> in(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) in[i] = {K::Point_3(p[i].x, p[i].y, p[i].z), dw::index_t(i)};
  const auto start = std::chrono::steady_clock::now();
  CgalDelaunay dt(in.begin(), in.end());
  *triangulation_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  dw::EdgeList e;
  e.reserve(8 * p.size());  // ~7.7 edges per point in uniform 3D triangulations
  std::vector<CgalDelaunay::Vertex_handle> around;
  for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v) {
    around.clear();
    dt.finite_adjacent_vertices(v, std::back_inserter(around));
    for (const auto& u : around)
      if (u->info() > v->info()) e.emplace_back(v->info(), u->info());
  }
  *cells = dt.number_of_cells();
  return e;
}

void benchCgal(benchmark::State& state, std::string name) {
  const Points& p = dataset(name);
  if (p.size() < 5) return state.SkipWithError(("data set not available: " + name).c_str());
  std::size_t edges = 0, cells = 0;
  double triangulation_s = 0, triangulation_sum = 0;
  for (auto _ : state) {
    const dw::EdgeList e = cgalEdges(p, &cells, &triangulation_s);
    edges = e.size();
    triangulation_sum += triangulation_s;
    benchmark::DoNotOptimize(e.data());
  }
  benchmark::DoNotOptimize(cells);
  const double bytes = peakBytesOf([&] {
    const dw::EdgeList e = cgalEdges(p, &cells, &triangulation_s);
    benchmark::DoNotOptimize(e.data());
  });
  setCounters(state, p.size(), edges, bytes);
  state.counters["triangulation_s"] =
      benchmark::Counter(triangulation_sum, benchmark::Counter::kAvgIterations);
}
#endif

void registerAll() {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const bool big = std::getenv("DW_BENCH_BIG") != nullptr;
  const bool qhull_1m = std::getenv("DW_BENCH_QHULL_1M") != nullptr;
  std::vector<std::string> names{"uniform_100k", "uniform_1M", "dragon_437k"};
  if (big) names.push_back("uniform_4M");
  for (const std::string& name : names) {
    // 1 and 2 threads (the 1 -> 2 ratio, measurable on a 2-core machine too), then doubling up to all.
    std::vector<unsigned> threads{1, 2};
    for (unsigned t = 4; t < hw; t *= 2) threads.push_back(t);
    if (hw > 2) threads.push_back(hw);
    for (unsigned t : threads)
      benchmark::RegisterBenchmark(("incremental/" + name + "/threads:" + std::to_string(t)).c_str(),
                                   benchIncremental, name, t)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->Iterations(name == "uniform_100k" ? 5 : 1);
    std::vector<unsigned> block_counts{2};
    if (hw > 2) block_counts.push_back(hw);
    if (name != "uniform_4M")
      for (unsigned b : block_counts)
        benchmark::RegisterBenchmark(("blocks/" + name + "/blocks:" + std::to_string(b)).c_str(), benchBlocks,
                                     name, b)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->Iterations(1);
    if ((name != "uniform_1M" || qhull_1m) && name != "uniform_4M")
      benchmark::RegisterBenchmark(("qhull/" + name).c_str(), benchQhull, name)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->Iterations(1);
#ifdef DW_HAVE_CGAL
    benchmark::RegisterBenchmark(("cgal/" + name).c_str(), benchCgal, name)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(name == "uniform_100k" ? 5 : 1);
#endif
  }
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
