/// \file dw_laz_bench.cpp
/// \brief dw_laz_bench: LAZ decoding speed (core only: no PCL, no Google Benchmark, so it also runs on
/// the device machine). For every requested thread count it measures
///   - decode: every chunk decoded to raw LAS records by `threads` threads, each taking the next chunk
///     when it finishes one and holding one chunk at a time (the streaming form: memory does not grow
///     with the file);
///   - readLasFile: the whole file into arrays (X, Y, Z), as dw_tin and the loaders read it;
/// and prints points/s, the speed-up over the first thread count, the peak memory growth and an
/// order-free checksum of the points (equal for every thread count). With --lazperf DIR it also runs
/// npm's laz-perf (LASzip compiled to WASM, bench/laz_perf_decode.js) on the same file in node, and
/// prints the single-thread ratio. The input is a LAZ file, or a synthetic one written first by our
/// encoder (-n).
///   dw_laz_bench FILE.laz [--threads 1,2,...] [--repeats R] [--lazperf DIR]
///   dw_laz_bench -n 20M [--format F] [--chunk N] [--variable-chunks] [--keep PATH] [...]
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <thread>
#include <vector>

#include "app_args.h"
#include "core/las/laz_codec.h"
#include "core/las/laz_reader.h"
#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

#ifndef DW_BENCH_DIR
#define DW_BENCH_DIR "bench"
#endif

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void usage() {
  std::fprintf(stderr,
               "usage: dw_laz_bench (FILE.laz | -n POINTS [--format F] [--chunk N] [--variable-chunks]\n"
               "                    [--keep PATH]) [--threads 1,2,...] [--repeats R] [--lazperf DIR]\n"
               "  -n: writes a synthetic LAZ tile first (our encoder; format 1 unless --format; removed at\n"
               "  the end unless --keep). Times are the best of R runs (default 3). --lazperf DIR: the\n"
               "  folder holding node_modules/laz-perf (scripts/setup.sh installs it in .deps/lazperf).\n");
}

/// Order-free checksum of a point's integer coordinates.
inline std::uint64_t pointHash(std::int32_t x, std::int32_t y, std::int32_t z) {
  std::uint64_t h = (std::uint64_t(std::uint32_t(x)) * 0x9E3779B97F4A7C15ull) ^
                    (std::uint64_t(std::uint32_t(y)) << 17) ^
                    (std::uint64_t(std::uint32_t(z)) * 0xC2B2AE3D27D4EB4Full);
  h = (h ^ (h >> 31)) * 0xBF58476D1CE4E5B9ull;
  return h ^ (h >> 29);
}

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Result {
  double seconds = 1e300;
  double cpu_seconds = 1e300;  ///< process CPU time: on a shared machine steadier than wall time
  double peak_mb = 0;
  std::uint64_t checksum = 0;
};

/// Streaming decode on `threads` threads, one chunk in flight per thread.
Result decodeChunks(const std::string& path, unsigned threads) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw dw::las::LasError(path + ": cannot open for reading");
  std::fseek(f, 0, SEEK_END);
  const std::uint64_t size = std::uint64_t(std::ftell(f));
  const dw::las::LasReader reader(path);
  const dw::las::LasHeader& h = reader.header();
  Result r;
  const long base = dw::processStatusKb("VmRSS:");
  dw::resetPeakResident();
  const double c0 = processCpuSeconds();
  const auto t0 = Clock::now();
  const dw::las::LazChunks chunks(fileno(f), path, h, size);
  std::atomic<std::size_t> next{0};
  std::vector<std::uint64_t> sums(threads, 0);
  std::vector<std::string> errors(threads);
  auto work = [&](unsigned w) {
    try {
      auto decoder = chunks.makeDecoder();
      std::vector<std::uint8_t> compressed, records;
      std::uint64_t sum = 0;
      for (std::size_t c = next++; c < chunks.size(); c = next++) {
        chunks.decode(c, *decoder, compressed, records);
        for (std::uint64_t i = 0; i < chunks.points(c); ++i) {
          std::int32_t v[3];
          std::memcpy(v, records.data() + i * h.record_length, 12);
          sum += pointHash(v[0], v[1], v[2]);
        }
      }
      sums[w] = sum;
    } catch (const std::exception& e) {
      errors[w] = e.what();
    }
  };
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < threads; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  r.seconds = since(t0);
  r.cpu_seconds = processCpuSeconds() - c0;
  for (const std::string& e : errors)
    if (!e.empty()) throw dw::las::LasError(e);
  for (std::uint64_t s : sums) r.checksum += s;
  r.peak_mb = double(dw::processStatusKb("VmHWM:") - base) / 1024.0;
  std::fclose(f);
  return r;
}

/// readLasFile into arrays; the peak is reported beyond the cloud's own 12 bytes per point.
Result readArrays(const std::string& path, unsigned threads) {
  Result r;
  const long base = dw::processStatusKb("VmRSS:");
  dw::resetPeakResident();
  const double c0 = processCpuSeconds();
  const auto t0 = Clock::now();
  dw::las::LasReadOptions o;
  o.threads = threads;
  const dw::las::LasCloud c = dw::las::readLasFile(path, o);
  r.seconds = since(t0);
  r.cpu_seconds = processCpuSeconds() - c0;
  r.peak_mb = (double(dw::processStatusKb("VmHWM:") - base) * 1024.0 - 12.0 * double(c.size())) / 1048576.0;
  for (std::size_t i = 0; i < c.size(); ++i) r.checksum += pointHash(c.X[i], c.Y[i], c.Z[i]);
  return r;
}

struct GenOptions {
  std::uint64_t points = 0;
  int format = 1;
  std::uint32_t chunk = 50000;
  bool variable = false;
};

/// Writes the synthetic tile with our encoder; variable chunks are 1/4 to 1 chunk long.
void writeTile(const std::string& path, const GenOptions& g) {
  dw::las::LidarGenOptions o;
  o.num_points = g.points;
  dw::las::LasHeader h = dw::las::syntheticHeader(o);
  h.point_format = std::uint8_t(g.format);
  h.version_minor = g.format >= 6 ? 4 : 2;
  dw::las::LazWriter w(path, h, 0, g.chunk,
                       g.variable ? dw::las::LazChunking::kVariable : dw::las::LazChunking::kFixed);
  std::uint64_t n = 0, state = 12345, end = g.chunk;
  const std::uint64_t step = std::max<std::uint64_t>(1, g.points / 10);
  const auto t0 = Clock::now();
  dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) {
    w.write(r);
    if (g.variable && ++n == end) {
      w.endChunk();
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      end = n + std::max<std::uint64_t>(1, g.chunk / 4 + (state >> 33) % (g.chunk - g.chunk / 4 + 1));
    } else if (!g.variable) {
      ++n;
    }
    if (n % step == 0) std::fprintf(stderr, "\rwriting %s: %3d%%", path.c_str(), int(100 * n / g.points));
  });
  w.close();
  std::fprintf(stderr, "\rwrote %llu points to %s in %.1f s\n", static_cast<unsigned long long>(n),
               path.c_str(), since(t0));
}

/// laz-perf's best single-thread rate in points/s (0 when it did not run) and, in `cpu`, its best
/// pass's CPU seconds; its output echoed.
double runLazPerf(const std::string& dir, const std::string& file, unsigned repeats, double& cpu) {
  const std::string cmd = "node '" + std::string(DW_BENCH_DIR) + "/laz_perf_decode.js' '" + dir + "' '" +
                          file + "' " + std::to_string(repeats) + " 2>&1";
  std::FILE* p = popen(cmd.c_str(), "r");
  if (!p) return 0;
  char line[512];
  double rate = 0;
  while (std::fgets(line, sizeof line, p)) {
    std::printf("  %s", line);
    const char* at = std::strstr(line, "laz-perf best:");
    const char* eq = at ? std::strstr(at, "= ") : nullptr;
    if (eq) rate = std::atof(eq + 2) * 1e6;
    const char* c = at ? std::strstr(at, "cpu ") : nullptr;
    if (c) cpu = std::atof(c + 4);
  }
  const int rc = pclose(p);
  return rc == 0 ? rate : 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string file, keep, lazperf;
  GenOptions gen;
  std::vector<unsigned> threads = {1, 2};
  unsigned repeats = 3;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw dw::Error("missing value after " + a);
        return argv[++i];
      };
      if (a == "-n")
        gen.points = dw_apps::parseCount(value(), "point count");
      else if (a == "--format") {
        gen.format = std::atoi(value().c_str());
        if (!((gen.format >= 0 && gen.format <= 3) || (gen.format >= 6 && gen.format <= 8)))
          throw dw::Error("--format must be 0-3 or 6-8");
      } else if (a == "--chunk")
        gen.chunk =
            std::uint32_t(std::min<std::uint64_t>(dw_apps::parseCount(value(), "chunk size"), 1u << 24));
      else if (a == "--variable-chunks")
        gen.variable = true;
      else if (a == "--keep")
        keep = value();
      else if (a == "--threads")
        threads = dw_apps::parseList(value(), "thread count", 1, 4096);
      else if (a == "--repeats")
        repeats = unsigned(dw_apps::parseCount(value(), "repeat count"));
      else if (a == "--lazperf")
        lazperf = value();
      else if (a == "-h" || a == "--help") {
        usage();
        return 0;
      } else if (!a.empty() && a[0] != '-' && file.empty())
        file = a;
      else
        throw dw::Error("unknown argument " + a);
    }
    if ((gen.points == 0) == file.empty()) throw dw::Error("give exactly one of FILE.laz and -n POINTS");
    const bool generated = gen.points != 0;
    if (generated) {
      file = keep.empty() ? "/tmp/dw_laz_bench_" + std::to_string(::getpid()) + ".laz" : keep;
      writeTile(file, gen);
    }
    const dw::las::LasReader probe(file);
    const std::uint64_t n = probe.header().point_count;
    std::printf("input %s: %llu points, format %u, %u-byte records; hardware threads %u\n", file.c_str(),
                static_cast<unsigned long long>(n), unsigned(probe.header().point_format),
                unsigned(probe.header().record_length), std::thread::hardware_concurrency());
    std::printf("%-12s %7s %9s %9s %9s %8s %8s %s\n", "what", "threads", "seconds", "cpu_s", "Mpts/s",
                "speedup", "peak_MB", "checksum");
    int rc = 0;
    double decode1 = 0, decode1_cpu = 0;
    for (int kind = 0; kind < 2; ++kind) {
      std::vector<Result> results;
      for (unsigned t : threads) {
        Result best;
        for (unsigned r = 0; r < repeats; ++r) {
          const Result x = kind == 0 ? decodeChunks(file, t) : readArrays(file, t);
          if (r > 0 && x.checksum != best.checksum) throw dw::Error("checksum changed between repeats");
          best.checksum = x.checksum;
          best.seconds = std::min(best.seconds, x.seconds);
          best.cpu_seconds = std::min(best.cpu_seconds, x.cpu_seconds);
          best.peak_mb = std::max(best.peak_mb, x.peak_mb);
        }
        results.push_back(best);
        const bool same = best.checksum == results.front().checksum;
        if (!same) rc = 3;
        std::printf("%-12s %7u %9.4f %9.4f %9.3f %8.2f %8.1f %016llx%s\n",
                    kind == 0 ? "decode" : "readLasFile", t, best.seconds, best.cpu_seconds,
                    double(n) / best.seconds / 1e6, results.front().seconds / best.seconds, best.peak_mb,
                    static_cast<unsigned long long>(best.checksum), same ? "" : "  DIFFERENT");
        std::fflush(stdout);
      }
      if (kind == 0 && threads.front() == 1) {
        decode1 = double(n) / results.front().seconds;
        decode1_cpu = results.front().cpu_seconds;
      }
    }
    if (!lazperf.empty()) {
      std::printf("laz-perf (node, WASM) on the same file:\n");
      double lp_cpu = 0;
      const double rate = runLazPerf(lazperf, file, repeats, lp_cpu);
      if (rate > 0 && decode1 > 0) {
        std::printf("single-thread decode: ours %.3f Mpts/s, laz-perf %.3f Mpts/s, ratio %.2fx (wall)\n",
                    decode1 / 1e6, rate / 1e6, decode1 / rate);
        if (lp_cpu > 0)
          std::printf("single-thread decode CPU time: ours %.4f s, laz-perf %.4f s, ratio %.2fx\n",
                      decode1_cpu, lp_cpu, lp_cpu / decode1_cpu);
      } else
        std::printf("laz-perf did not run (node or %s/node_modules/laz-perf missing?)\n", lazperf.c_str());
    }
    if (generated && keep.empty()) std::remove(file.c_str());
    if (rc) std::printf("points differ between thread counts\n");
    return rc;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_laz_bench: %s\n", e.what());
    return 1;
  }
}
