/// \file dw_graph_load.cpp
/// \brief dw_graph_load: time and memory of loading a graph file (core only), side by side, in one
/// process:
///   - read+parse: the whole file read into a buffer, then dw::deserializeGraph (two copies of the
///     payload: file -> buffer -> arrays);
///   - copy-load: dw::loadGraph(GraphStorage::Copied), which parses a mapping and copies every array;
///   - mmap-load: dw::loadGraph (GraphStorage::Mapped): the edge records stay a view of the mapping.
/// All validate the same way (checksums, structure, safe radii); the parts of that validation are
/// timed alone on the mapped graph. anon_MB is the anonymous resident memory the loaded graph holds
/// (RssAnon growth): a mapped file's pages are page cache, not the process's own. The file is a graph
/// of -n uniform random points built and saved first (or --graph FILE). Times are the best of --repeats.
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
  double seconds = 1e300, anon_mb = 0;
  std::size_t edges = 0;
};

/// Best time and largest peak growth of `load` over `repeats` runs.
template <typename Load>
Run measure(unsigned repeats, Load&& load) {
  Run r;
  for (unsigned k = 0; k < repeats; ++k) {
    dw::releaseFreeHeap();  // else a load reusing freed resident blocks adds no pages
    const long base = dw::processStatusKb("RssAnon:");
    const auto t0 = Clock::now();
    const dw::DelaunayGraph g = load();
    r.seconds = std::min(r.seconds, std::chrono::duration<double>(Clock::now() - t0).count());
    r.anon_mb = std::max(r.anon_mb, double(dw::processStatusKb("RssAnon:") - base) / 1024.0);
    r.edges = g.numDirectedEdges();
  }
  return r;
}

/// The parts of a load's checks, each alone and best of `repeats`, on a mapped graph of `file`.
void timeChecks(const std::string& file, unsigned repeats) {
  dw::DelaunayGraph g = dw::loadGraph(file);
  std::ifstream f(file, std::ios::binary | std::ios::ate);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(f.tellg()));
  f.seekg(0);
  f.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  auto best = [&](auto&& fn) {
    double s = 1e300;
    for (unsigned k = 0; k < repeats; ++k) {
      const auto t0 = Clock::now();
      fn();
      s = std::min(s, std::chrono::duration<double>(Clock::now() - t0).count());
    }
    return 1e3 * s;
  };
  volatile std::uint64_t sink = 0;
  const double checksum_ms = best([&] { sink = sink + dw::graphFileChecksum(bytes.data(), bytes.size()); });
  const double order_ms = best([&] { dw::sortNeighbourhoods(g); });  // sorted: a read-only scan
  const double validate_ms = best([&] { g.validate(); });
  const double radii_ms = best([&] { dw::computeSafeRadii(g); });
  std::printf("checks alone (ms): payload checksum %.1f, neighbourhood order %.1f, validate() %.1f "
              "(offsets monotone, neighbours < n, order, originals), safe radii %.1f\n",
              checksum_ms, order_ms, validate_ms, radii_ms);
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
    const double file_mb = double(probe.tellg()) / 1e6;
    const Run buffered = measure(repeats, [&] {
      std::ifstream f(file, std::ios::binary | std::ios::ate);
      std::vector<std::uint8_t> bytes(static_cast<std::size_t>(f.tellg()));
      f.seekg(0);
      f.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
      return dw::deserializeGraph(bytes.data(), bytes.size());
    });
    const Run copied = measure(repeats, [&] { return dw::loadGraph(file, dw::GraphStorage::Copied); });
    const Run mapped = measure(repeats, [&] { return dw::loadGraph(file); });
    std::printf("file %.1f MB, best of %u (page cache warm)\n", file_mb, repeats);
    std::printf("%-38s %9s %9s %9s\n", "load", "ms", "MB/s", "anon_MB");
    auto row = [&](const char* name, const Run& r) {
      std::printf("%-38s %9.1f %9.0f %9.1f\n", name, 1e3 * r.seconds, file_mb / r.seconds, r.anon_mb);
    };
    row("read into a buffer + deserializeGraph", buffered);
    row("copy-load  loadGraph(Copied)", copied);
    row("mmap-load  loadGraph(Mapped)", mapped);
    std::printf("ratio copy-load / mmap-load: time %.2fx, anonymous memory %.2fx\n",
                copied.seconds / mapped.seconds, copied.anon_mb / std::max(mapped.anon_mb, 1e-3));
    timeChecks(file, repeats);
    if (buffered.edges != mapped.edges || copied.edges != mapped.edges) throw dw::Error("the loads disagree");
    if (generated) std::remove(file.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_graph_load: %s\n", e.what());
    return 1;
  }
}
