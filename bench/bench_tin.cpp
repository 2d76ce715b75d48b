/// \file bench_tin.cpp
/// \brief Parallel TIN benchmark at the seed's sizes (Song, Li, Liu: 2.1M, 4.4M, 6.0M, 10M, 21M points)
/// on synthetic airborne LiDAR, with CGAL's 2D Delaunay (Delaunay_triangulation_2, exact predicates,
/// spatially sorted range insertion, one thread) side by side in the same run.
///
///   bench_tin [--benchmark_filter=...]          sizes from DW_TIN_BENCH_SIZES (millions, default "2.1,4.4")
///   DW_TIN_BENCH_SIZES=2.1,4.4,6,10,21 bench_tin
/// Counters: Mpts_per_s, bytes_per_point (peak resident growth during the run), triangles.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

#ifdef DW_HAVE_CGAL
#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#endif

namespace {

struct Input {
  std::vector<double> x, y;  // LAS integer units (an exact frame)
};

/// Synthetic tiles are generated once per size and reused by every benchmark of that size.
const Input& input(std::size_t n) {
  static std::map<std::size_t, Input> cache;
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  Input in;
  in.x.reserve(n);
  in.y.reserve(n);
  dw::las::LidarGenOptions o;
  o.num_points = n;
  dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) {
    in.x.push_back(r.X);
    in.y.push_back(r.Y);
  });
  return cache.emplace(n, std::move(in)).first->second;
}

void BM_DwTin(benchmark::State& state, std::size_t n, unsigned threads) {
  const Input& in = input(n);
  std::size_t tris = 0;
  double peak_bytes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<double> x = in.x, y = in.y;  // the run owns (and frees) its copy, as dw_tin does
    const long base = dw::processStatusKb("VmRSS:");
    dw::resetPeakResident();
    dw::pred::resetPredicateStats();
    state.ResumeTiming();
    dw::tin::TinOptions o;
    o.num_threads = threads;
    const auto r = dw::tin::triangulate(std::move(x), std::move(y), o);
    state.PauseTiming();
    tris = r.numTriangles();
    // Growth of the peak over what was resident before (the moved-in copy counts: it is the input).
    peak_bytes = double(dw::processStatusKb("VmHWM:") - base) * 1024.0 + 16.0 * double(n);
    state.ResumeTiming();
  }
  state.counters["Mpts_per_s"] =
      benchmark::Counter(double(n) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["bytes_per_point"] = peak_bytes / double(n);
  state.counters["triangles"] = double(tris);
  state.counters["threads"] = threads;
  // How often the floating-point filter could not decide (per input point) and how many exact ties
  // the perturbation broke: LAS quantisation makes both non-zero.
  const dw::pred::PredicateStats ps = dw::pred::predicateStats();
  state.counters["exact_per_pt"] = double(ps.orient_exact + ps.incircle_exact) / double(n);
  state.counters["ties_per_pt"] = double(ps.perturbed_ties) / double(n);
}

#ifdef DW_HAVE_CGAL
void BM_CgalDelaunay2(benchmark::State& state, std::size_t n) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  using DT = CGAL::Delaunay_triangulation_2<K>;
  const Input& in = input(n);
  std::size_t tris = 0;
  double peak_bytes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<K::Point_2> pts;
    pts.reserve(n);
    for (std::size_t i = 0; i < n; ++i) pts.emplace_back(in.x[i], in.y[i]);
    const long base = dw::processStatusKb("VmRSS:");
    dw::resetPeakResident();
    state.ResumeTiming();
    DT dt;
    dt.insert(pts.begin(), pts.end());  // CGAL spatially sorts the range (Hilbert/BRIO) first
    state.PauseTiming();
    tris = dt.number_of_faces();
    peak_bytes = double(dw::processStatusKb("VmHWM:") - base) * 1024.0 + double(n * sizeof(K::Point_2));
    state.ResumeTiming();
  }
  state.counters["Mpts_per_s"] =
      benchmark::Counter(double(n) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["bytes_per_point"] = peak_bytes / double(n);
  state.counters["triangles"] = double(tris);
  state.counters["threads"] = 1;
}
#endif

std::vector<double> sizesInMillions() {
  const char* env = std::getenv("DW_TIN_BENCH_SIZES");
  std::string s = env ? env : "2.1,4.4";
  std::vector<double> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(std::atof(item.c_str()));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  for (const double m : sizesInMillions()) {
    const std::size_t n = std::size_t(m * 1e6);
    const std::string tag = std::to_string(m).substr(0, std::to_string(m).find('.') + 2) + "M";
    std::vector<unsigned> threads = {1, 2};
    if (hw > 2) threads.push_back(hw);
    for (unsigned t : threads)
      benchmark::RegisterBenchmark(("DwTin/" + tag + "/threads:" + std::to_string(t)).c_str(),
                                   [n, t](benchmark::State& s) { BM_DwTin(s, n, t); })
          ->Unit(benchmark::kSecond)
          ->Iterations(1)
          ->UseRealTime();
#ifdef DW_HAVE_CGAL
    benchmark::RegisterBenchmark(("CgalDelaunay2/" + tag).c_str(),
                                 [n](benchmark::State& s) { BM_CgalDelaunay2(s, n); })
        ->Unit(benchmark::kSecond)
        ->Iterations(1)
        ->UseRealTime();
#endif
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
