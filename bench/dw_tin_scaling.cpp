/// \file dw_tin_scaling.cpp
/// \brief dw_tin_scaling: thread-scaling measurement of the parallel TIN (core only: no PCL, no Google
/// Benchmark, so it also runs on the device machine). Generates a synthetic airborne tile in memory (or
/// reads a LAS file), triangulates it with every requested thread count, and prints wall and process
/// CPU time, speed-up over one thread, peak memory growth per point, the stage times, and whether the
/// triangles are the same set for every thread count (an order-free checksum).
///   dw_tin_scaling -n 21M [--threads 1,2,4,8,16] [--strips 0,16,...] [--repeats R] [--certify]
///   dw_tin_scaling --las tile.las [...]
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "app_args.h"
#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_tin_scaling (-n POINTS | --las FILE) [--threads 1,2,...] [--strips 0,K,...] [--repeats R]\n"
      "                      [--certify]\n"
      "  POINTS accepts suffixes k and M. Every thread count runs with every strip count (0, the default:\n"
      "  automatic). Speed-ups are against the first run.\n"
      "  Times are the minimum over the repeats; CPU is process CPU time (all threads).\n");
}

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// Sum over triangles of a hash of the triangle rotated to start at its smallest index: independent of
/// the order of the triangles and of where each one starts, so equal sets give equal checksums.
std::uint64_t triangleChecksum(const std::vector<dw::index_t>& t) {
  std::uint64_t sum = 0;
  for (std::size_t k = 0; k + 2 < t.size(); k += 3) {
    std::uint32_t a = t[k], b = t[k + 1], c = t[k + 2];
    while (a > b || a > c) {
      const std::uint32_t s = a;
      a = b;
      b = c;
      c = s;
    }
    std::uint64_t z = (std::uint64_t(a) * 0x9E3779B97F4A7C15ull) ^ (std::uint64_t(b) << 21) ^
                      (std::uint64_t(c) * 0xC2B2AE3D27D4EB4Full);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    sum += z ^ (z >> 31);
  }
  return sum;
}

struct Run {
  double wall = 1e300, cpu = 1e300, bytes_per_point = 0;
  dw::tin::TinStats stats;
  std::size_t triangles = 0;
  std::uint64_t checksum = 0;
};

}  // namespace

int main(int argc, char** argv) {
  std::uint64_t n_gen = 0;
  std::string las_path;
  std::vector<unsigned> threads = {1, 2}, strips = {0};
  unsigned repeats = 1;
  bool certify = false;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw dw::Error("missing value after " + a);
        return argv[++i];
      };
      if (a == "-n")
        n_gen = dw_apps::parseCount(value(), "point count");
      else if (a == "--las")
        las_path = value();
      else if (a == "--threads")
        threads = dw_apps::parseList(value(), "thread count", 0, 4096);
      else if (a == "--strips")
        strips = dw_apps::parseList(value(), "strip count", 0, 1u << 20);
      else if (a == "--repeats")
        repeats = unsigned(dw_apps::parseCount(value(), "repeat count"));
      else if (a == "--certify")
        certify = true;
      else if (a == "-h" || a == "--help") {
        usage();
        return 0;
      } else {
        throw dw::Error("unknown argument " + a);
      }
    }
    if ((n_gen == 0) == las_path.empty()) throw dw::Error("give exactly one of -n POINTS and --las FILE");

    // Input in LAS integer units, the exact frame dw_tin uses.
    std::vector<double> x, y;
    const auto t_in = std::chrono::steady_clock::now();
    if (n_gen) {
      x.reserve(n_gen);
      y.reserve(n_gen);
      dw::las::LidarGenOptions o;
      o.num_points = n_gen;
      dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) {
        x.push_back(r.X);
        y.push_back(r.Y);
      });
    } else {
      const dw::las::LasCloud c = dw::las::readLasFile(las_path);
      x.assign(c.X.begin(), c.X.end());
      y.assign(c.Y.begin(), c.Y.end());
    }
    const std::size_t n = x.size();
    if (n == 0) throw dw::Error("no points");
    std::printf("input %zu points (%s) in %.1f s; hardware threads %u\n", n,
                n_gen ? "synthetic" : las_path.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t_in).count(),
                std::thread::hardware_concurrency());
    // merge: merging left after the last strip; mwork: all merges' times added up (mostly overlapped
    // with the strips).
    std::printf("%7s %6s %8s %8s %7s %7s %6s %7s %7s %7s %6s %6s %6s %8s %s\n", "threads", "strips", "wall_s",
                "cpu_s", "speedup", "B/point", "prep_s", "strip_s", "maxstr", "wait_s", "merge", "mwork",
                "out_s", "band_pts", "checksum");

    std::vector<Run> runs;
    for (const unsigned t : threads)
      for (const unsigned k : strips) {
        Run best;
        for (unsigned r = 0; r < repeats; ++r) {
          std::vector<double> cx = x, cy = y;  // the run owns (and frees) its copy, as dw_tin does
          const long base = dw::processStatusKb("VmRSS:");
          dw::resetPeakResident();
          dw::tin::TinOptions o;
          o.num_threads = t;
          o.num_strips = k;
          const double c0 = processCpuSeconds();
          const auto w0 = std::chrono::steady_clock::now();
          dw::tin::TinResult res = dw::tin::triangulate(std::move(cx), std::move(cy), o);
          const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
          const double cpu = processCpuSeconds() - c0;
          // Growth of the peak over what was resident before; the moved-in copy counts (it is the input).
          const double bpp =
              (double(dw::processStatusKb("VmHWM:") - base) * 1024.0 + 16.0 * double(n)) / double(n);
          if (wall < best.wall) {
            best.wall = wall;
            best.stats = res.stats;
          }
          best.cpu = std::min(best.cpu, cpu);
          best.bytes_per_point = std::max(best.bytes_per_point, bpp);
          if (r == 0) {
            best.triangles = res.numTriangles();
            best.checksum = triangleChecksum(res.triangles);
            if (certify && runs.empty()) {
              const auto c = dw::tin::certifyDelaunay(x.data(), y.data(), n, res.triangles, res.num_vertices);
              std::printf("certificate (%u threads): %s\n", t, c.message.c_str());
              if (!c.ok) return 2;
            }
          }
        }
        runs.push_back(best);
        const Run& b = runs.back();
        std::printf(
            "%7u %6zu %8.3f %8.3f %7.2f %7.1f %6.3f %7.3f %7.3f %7.3f %6.3f %6.3f %6.3f %8zu %016llx%s\n", t,
            b.stats.strips, b.wall, b.cpu, runs.front().wall / b.wall, b.bytes_per_point, b.stats.prepare_s,
            b.stats.strips_s, b.stats.strip_max_s, b.stats.fill_wait_s, b.stats.merge_s, b.stats.merge_work_s,
            b.stats.output_s, b.stats.merge_points, static_cast<unsigned long long>(b.checksum),
            b.checksum == runs.front().checksum && b.triangles == runs.front().triangles ? ""
                                                                                         : "  DIFFERENT");
        std::fflush(stdout);
      }
    for (const Run& r : runs)
      if (r.checksum != runs.front().checksum || r.triangles != runs.front().triangles) {
        std::printf("triangles differ between thread counts\n");
        return 3;
      }
    std::printf("same %zu triangles for every thread count\n", runs.front().triangles);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_tin_scaling: %s\n", e.what());
    return 1;
  }
}
