/// \file dw_delaunay3d_scaling.cpp
/// \brief dw_delaunay3d_scaling: thread-scaling measurement of the 3D Delaunay graph builder (core
/// only, so it also runs on the device machine). Builds the triangulation of uniform points in a
/// cube (or of a point file) with every requested thread count, exactly as dw::incrementalDelaunayEdges
/// does (BRIO rounds, partitioned parallel insertion, parallel edge extraction), and prints the stage
/// times, how much the threads inserted, peak memory growth per point, and whether every thread count
/// gave the same edge set (an order-free checksum). The last stage buildDelaunayGraph adds, the walk
/// graph's records (assembleEdges), is timed on its own (assemble_s), outside total_s and B/point.
/// setup_s sums each parallel pass's wall time before its threads insert (cuts, cells, to-do lists,
/// slots, start walks); rest_s the calling thread's insertion of what a batch's passes left; handed
/// the points per input point that a pass's slower threads left untried for the next pass.
///   dw_delaunay3d_scaling -n 1M [--threads 1,2,4,8,16] [--repeats R] [--validate] [--independent]
///   dw_delaunay3d_scaling --file cloud.{pcd,ply} [...]
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "app_args.h"
#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "core/util/process_memory.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_delaunay3d_scaling (-n POINTS | --file CLOUD) [--threads 1,2,...] [--repeats R]\n"
      "                             [--validate] [--independent] [--max-bytes-per-point B]\n"
      "  POINTS accepts suffixes k and M (uniform in a cube, seed 42). CLOUD: PCD or PLY.\n"
      "  Times are the minimum over the repeats; speed-ups are against the first thread count.\n"
      "  --validate: check the whole triangulation (slow) after each build.\n"
      "  --independent: also the ceiling of any partitioned scheme: T threads each triangulate their\n"
      "  own 1/T of the points (Morton ranges) in separate kernels, nothing shared (not a graph).\n"
      "  --max-bytes-per-point B: exit with status 3 when a build's peak (B/point) exceeds B (the first\n"
      "  build in the process is the one measured on a fresh heap).\n"
      "  --max-extraction-growth P: exit with status 3 when the edge extraction raises the peak of the\n"
      "  insertion before it by more than P percent (a check for CI: both peaks come from one build).\n");
}

double seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

struct Run {
  double order_s = 1e30, insert_s = 1e30, parallel_s = 0, busy_max = 0, busy_sum = 0, setup_s = 0, rest_s = 0,
         edges_s = 1e30, total_s = 1e30, assemble_s = 1e30;
  double shared = 0, deferred = 0, handed = 0, bytes_per_point = 0;
  double extraction_growth = 0;  // how far the edge extraction raised the insertion's peak (fraction)
  double walk = 0, tests = 0, created = 0;  // per point: walk steps, conflict tests, tetrahedra made
  std::uint64_t checksum = 0;
  std::size_t edges = 0;
};

Run buildOnce(const std::vector<dw::Vec3f>& pts, unsigned threads, bool validate) {
  Run r;
  dw::resetPeakResident();
  const long base_kb = dw::processStatusKb("VmHWM:");
  const auto t0 = std::chrono::steady_clock::now();
  // As dw::incrementalDelaunayEdges: one team of threads for every parallel loop of the build.
  dw::ThreadTeam team(threads);
  dw::ThreadTeam::Scope scope(team);
  std::vector<std::size_t> rounds;
  std::vector<dw::index_t> order = dw::builder3d::brioOrder(pts, rounds, 0, threads);
  const auto t1 = std::chrono::steady_clock::now();
  dw::builder3d::Triangulation3D kernel;
  kernel.setPoints(pts.data(), pts.size());
  kernel.build(std::move(order), {}, rounds, threads);
  const auto t2 = std::chrono::steady_clock::now();
  const long insertion_kb = dw::processStatusKb("VmHWM:") - base_kb;
  const auto stats = kernel.stats();
  if (validate) kernel.validate();
  const auto t3 = std::chrono::steady_clock::now();
  auto chunks = kernel.releaseIntoEdgeChunks(threads);
  const auto t4 = std::chrono::steady_clock::now();
  const long builder_kb = dw::processStatusKb("VmHWM:") - base_kb;
  r.bytes_per_point = 1024.0 * double(builder_kb) / pts.size();
  r.extraction_growth = insertion_kb > 0 ? double(builder_kb - insertion_kb) / double(insertion_kb) : 0.0;
  r.order_s = seconds(t0, t1);
  r.insert_s = seconds(t1, t2);
  r.parallel_s = stats.parallel_seconds;
  r.busy_max = stats.parallel_busy_max;
  r.busy_sum = stats.parallel_busy_sum;
  r.setup_s = stats.parallel_setup_seconds;
  r.rest_s = stats.rest_seconds;
  r.edges_s = seconds(t3, t4);
  r.total_s = r.order_s + r.insert_s + r.edges_s;
  r.shared = double(stats.parallel_inserted) / pts.size();
  r.deferred = double(stats.deferred) / pts.size();
  r.handed = double(stats.handed_on) / pts.size();
  r.walk = double(stats.walk_steps) / pts.size();
  r.tests = double(stats.conflict_tests) / pts.size();
  r.created = double(stats.created_tets) / pts.size();
  for (const auto& c : chunks)
    for (const auto& e : c) {
      ++r.edges;
      r.checksum += (std::uint64_t(e.first) * 0x9E3779B97F4A7C15ull) ^
                    (std::uint64_t(e.second) * 0xC2B2AE3D27D4EB4Full);
    }
  // What buildDelaunayGraph does next: the walk graph's records (not in the builder's peak above).
  const auto t5 = std::chrono::steady_clock::now();
  dw::DelaunayGraph graph;
  graph.points = pts;
  dw::assembleEdges(graph, dw::builder3d::Triangulation3D::joinChunks(std::move(chunks)), true, threads);
  r.assemble_s = seconds(t5, std::chrono::steady_clock::now());
  return r;
}

// T kernels on T threads, each over its own Morton range of the points: no shared structure at all.
double independentBuilds(const std::vector<dw::Vec3f>& pts, unsigned threads) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> pool;
  for (unsigned i = 0; i < threads; ++i)
    pool.emplace_back([&, i] {
      const std::size_t b = pts.size() * i / threads, e = pts.size() * (i + 1) / threads;
      std::vector<dw::index_t> ids(e - b);
      for (std::size_t k = b; k < e; ++k) ids[k - b] = static_cast<dw::index_t>(k);
      // Each is a whole build, ordered as the shared one is (fourfold rounds).
      const std::vector<dw::index_t> order =
          dw::builder3d::brioOrder(pts, ids, 0, dw::builder3d::BrioGrowth::kFourfold);
      dw::builder3d::Triangulation3D kernel;
      kernel.setPoints(pts.data(), pts.size());
      kernel.build(order.data(), order.size());
    });
  for (auto& t : pool) t.join();
  return seconds(t0, std::chrono::steady_clock::now());
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::size_t n = 0;
    std::string file;
    std::vector<unsigned> threads{1, 2};
    int repeats = 1;
    bool validate = false, independent = false;
    double max_bytes_per_point = 0;     // 0: no check
    double max_extraction_growth = -1;  // percent; negative: no check
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw dw::Error("dw_delaunay3d_scaling: " + a + " needs a value");
        return argv[++i];
      };
      if (a == "-n") {
        n = static_cast<std::size_t>(dw_apps::parseCount(next(), "point count"));
        if (n < 5) throw dw::Error("dw_delaunay3d_scaling: at least 5 points");
      } else if (a == "--file") {
        file = next();
      } else if (a == "--threads") {
        threads = dw_apps::parseList(next(), "thread count", 1, 4096);
      } else if (a == "--repeats") {
        repeats = static_cast<int>(dw_apps::parseCount(next(), "repeat count"));
      } else if (a == "--validate") {
        validate = true;
      } else if (a == "--independent") {
        independent = true;
      } else if (a == "--max-bytes-per-point") {
        max_bytes_per_point = static_cast<double>(dw_apps::parseCount(next(), "bytes per point"));
      } else if (a == "--max-extraction-growth") {
        max_extraction_growth = dw_apps::parseNonNegative(next(), "percent");
      } else {
        usage();
        return a == "-h" || a == "--help" ? 0 : 2;
      }
    }
    if ((n == 0) == file.empty() || threads.empty()) {
      usage();
      return 2;
    }
    std::vector<dw::Vec3f> raw;
    if (!file.empty()) {
      const std::vector<double> xyz = dw::readPointsXyz(file);
      raw.resize(xyz.size() / 3);
      double c[3] = {0, 0, 0};
      for (std::size_t i = 0; i < raw.size(); ++i)
        for (int k = 0; k < 3; ++k) c[k] += xyz[3 * i + k] / double(raw.size());
      for (std::size_t i = 0; i < raw.size(); ++i)
        raw[i] = {float(xyz[3 * i] - c[0]), float(xyz[3 * i + 1] - c[1]), float(xyz[3 * i + 2] - c[2])};
    } else {
      std::mt19937 rng(42);
      std::uniform_real_distribution<float> u(-1.0f, 1.0f);
      raw.resize(n);
      for (auto& q : raw) q = {u(rng), u(rng), u(rng)};
    }
    const std::vector<dw::Vec3f> pts = dw::mortonSortedDistinct(raw);
    std::printf("%zu distinct points (%s)\n", pts.size(), file.empty() ? "uniform cube" : file.c_str());
    std::printf(
        "threads  total_s  speedup  order_s  insert_s  parallel_s  busy_max  busy_sum  setup_s  rest_s  "
        "shared  deferred  handed  edges_s  B/point  M pt/s  assemble_s  walk/pt  tests/pt  made/pt  "
        "checksum\n");
    double first = 0;
    std::uint64_t checksum = 0;
    bool same = true;
    double worst_bytes_per_point = 0, worst_extraction_growth = 0;
    for (unsigned t : threads) {
      Run best;
      for (int k = 0; k < repeats; ++k) {
        const Run r = buildOnce(pts, t, validate);
        worst_bytes_per_point = std::max(worst_bytes_per_point, r.bytes_per_point);
        worst_extraction_growth = std::max(worst_extraction_growth, r.extraction_growth);
        if (r.total_s < best.total_s) best = r;
      }
      if (first == 0) {
        first = best.total_s;
        checksum = best.checksum;
      }
      same = same && best.checksum == checksum;
      std::printf(
          "%7u  %7.3f  %6.2fx  %7.3f  %8.3f  %10.3f  %8.3f  %8.3f  %7.3f  %6.3f  %6.3f  %8.3f  %6.3f  "
          "%7.3f  %7.0f  %6.3f  %10.3f  %7.2f  %8.2f  %7.2f  %016llx\n",
          t, best.total_s, first / best.total_s, best.order_s, best.insert_s, best.parallel_s, best.busy_max,
          best.busy_sum, best.setup_s, best.rest_s, best.shared, best.deferred, best.handed, best.edges_s,
          best.bytes_per_point, pts.size() / best.total_s / 1e6, best.assemble_s, best.walk, best.tests,
          best.created, static_cast<unsigned long long>(best.checksum));
      std::fflush(stdout);
    }
    if (independent) {
      std::printf("independent kernels (no sharing): threads  wall_s  speedup\n");
      double one = 0;
      for (unsigned t : threads) {
        const double w = independentBuilds(pts, t);
        if (one == 0) one = w;
        std::printf("%7u  %7.3f  %6.2fx\n", t, w, one / w);
        std::fflush(stdout);
      }
    }
    std::printf("%s edge set (%s) for every thread count\n", same ? "same" : "DIFFERENT",
                same ? "checksums equal" : "checksums differ");
    if (!same) return 1;
    if (max_bytes_per_point > 0 && worst_bytes_per_point > max_bytes_per_point) {
      std::printf("peak memory %.1f bytes per point exceeds the limit of %.0f\n", worst_bytes_per_point,
                  max_bytes_per_point);
      return 3;
    }
    if (max_extraction_growth >= 0 && 100.0 * worst_extraction_growth > max_extraction_growth) {
      std::printf("the edge extraction raised the insertion's peak by %.1f %% (limit %.0f %%)\n",
                  100.0 * worst_extraction_growth, max_extraction_growth);
      return 3;
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_delaunay3d_scaling: %s\n", e.what());
    return 1;
  }
}
