/// \file dw_graph_load.cpp
/// \brief dw_graph_load: time and peak memory of loading a graph file (core only), side by side:
///   - read+parse: the whole file read into a buffer, then dw::deserializeGraph (two copies of the
///     payload: file -> buffer -> arrays);
///   - loadGraph: dw::loadGraph, which parses a read-only mapping of the file (one copy: -> arrays).
/// Both validate the same way (checksums, structure, safe radii). The file is a graph of -n uniform
/// random points built and saved first (or --graph FILE). Times are the best of --repeats.
///   dw_graph_load -n 1M [--repeats 5] [--threads T] | --graph FILE
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "app_args.h"
#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Run {
  double seconds = 1e300, peak_mb = 0;
  std::size_t edges = 0;
};

/// Best time and largest peak growth of `load` over `repeats` runs.
template <typename Load>
Run measure(unsigned repeats, Load&& load) {
  Run r;
  for (unsigned k = 0; k < repeats; ++k) {
    const long base = dw::processStatusKb("VmRSS:");
    dw::resetPeakResident();
    const auto t0 = Clock::now();
    const dw::DelaunayGraph g = load();
    r.seconds = std::min(r.seconds, std::chrono::duration<double>(Clock::now() - t0).count());
    r.peak_mb = std::max(r.peak_mb, double(dw::processStatusKb("VmHWM:") - base) / 1024.0);
    r.edges = g.numDirectedEdges();
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::uint64_t n = 0;
  unsigned repeats = 5, threads = 0;
  std::string file;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw dw::Error("missing value after " + a);
        return argv[++i];
      };
      if (a == "-n")
        n = dw_apps::parseCount(value(), "point count");
      else if (a == "--graph")
        file = value();
      else if (a == "--repeats")
        repeats = unsigned(dw_apps::parseCount(value(), "repeat count"));
      else if (a == "--threads")
        threads = unsigned(dw_apps::parseCount(value(), "thread count"));
      else
        throw dw::Error("unknown argument " + a + " (usage: dw_graph_load -n POINTS | --graph FILE)");
    }
    if ((n == 0) == file.empty()) throw dw::Error("give exactly one of -n POINTS and --graph FILE");
    const bool generated = file.empty();
    if (generated) {
      std::mt19937_64 rng(7);
      std::uniform_real_distribution<float> u(0.f, 1.f);
      std::vector<float> xyz(3 * n);
      for (float& v : xyz) v = u(rng);
      dw::BuildOptions o;
      o.num_threads = threads;
      const auto t0 = Clock::now();
      const dw::DelaunayGraph g = dw::buildDelaunayGraph(dw::PointView::fromFloat(xyz.data(), n), o);
      file = "/tmp/dw_graph_load_" + std::to_string(::getpid()) + ".graph";
      dw::saveGraph(g, file);
      std::printf("built %zu vertices, %zu directed edges in %.2f s; saved to %s\n", g.numVertices(),
                  g.numDirectedEdges(), std::chrono::duration<double>(Clock::now() - t0).count(),
                  file.c_str());
    }
    std::ifstream probe(file, std::ios::binary | std::ios::ate);
    const double file_mb = double(probe.tellg()) / 1048576.0;
    const Run copy = measure(repeats, [&] {
      std::ifstream f(file, std::ios::binary | std::ios::ate);
      std::vector<std::uint8_t> bytes(static_cast<std::size_t>(f.tellg()));
      f.seekg(0);
      f.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
      return dw::deserializeGraph(bytes.data(), bytes.size());
    });
    const Run mapped = measure(repeats, [&] { return dw::loadGraph(file); });
    std::printf("file %.1f MB, best of %u (page cache warm)\n", file_mb, repeats);
    std::printf("%-34s %9s %9s\n", "load", "seconds", "peak_MB");
    std::printf("%-34s %9.4f %9.1f\n", "read into a buffer + deserialize", copy.seconds, copy.peak_mb);
    std::printf("%-34s %9.4f %9.1f\n", "loadGraph (parses the mapping)", mapped.seconds, mapped.peak_mb);
    std::printf("ratio (buffer / mapping): time %.2fx, peak memory %.2fx\n", copy.seconds / mapped.seconds,
                copy.peak_mb / mapped.peak_mb);
    if (copy.edges != mapped.edges) throw dw::Error("the two loads disagree");
    if (generated) std::remove(file.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_graph_load: %s\n", e.what());
    return 1;
  }
}
