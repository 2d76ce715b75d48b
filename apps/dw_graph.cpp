// dw_graph: builds the Delaunay walk graph of a point cloud, saves it, and prints its statistics.
//
//   dw_graph input.{pcd,ply,bin,las,laz} -o out.graph [--builder auto|qhull|incremental] [--threads N]
//   [--quiet]
//
// The graph is built from the cloud's float coordinates exactly as pcl::search::DelaunayWalk reads
// them, so the file can be given to DelaunayWalk::loadGraph / dw_icp --graph for the same cloud.
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "core/util/file_header_check.h"
#include "las_cloud.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

bool endsWith(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

/// xyz as PCL would hold them (float). PCD through PCL, PLY and KITTI .bin through the core reader,
/// LAS and LAZ relative to the tile's origin (las_cloud.h; dw_icp loads them the same way).
pcl::PointCloud<pcl::PointXYZ> loadCloud(const std::string& path) {
  if (!std::ifstream(path).good()) throw dw::Error("cannot open '" + path + "'");
  if (endsWith(path, ".gz")) throw dw::Error("'" + path + "' is compressed: gunzip it first");
  if (dw_apps::isLasPath(path)) {
    Eigen::Vector3d origin;
    pcl::PointCloud<pcl::PointXYZ> las = dw_apps::loadLasCloud(path, origin);
    dw_apps::printLasOrigin(origin);
    return las;
  }
  pcl::PointCloud<pcl::PointXYZ> cloud;
  if (endsWith(path, ".pcd")) {
    dw::checkPointFileHeader(path);  // PCL 1.13 crashes on some malformed headers (robustness.md)
    if (pcl::io::loadPCDFile(path, cloud) < 0) throw dw::Error("'" + path + "' is not a readable PCD file");
    return cloud;
  }
  const std::vector<double> xyz = dw::readPointsXyz(path);
  cloud.resize(xyz.size() / 3);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    cloud[i] = pcl::PointXYZ(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2]));
  return cloud;
}

void usage() {
  std::fprintf(stderr,
               "usage: dw_graph input.{pcd,ply,bin,las,laz} -o out.graph [--builder auto|qhull|incremental]\n"
               "                [--threads N] [--quiet]\n");
}

struct Options {
  std::string input, output;
  dw::BuildOptions build;
  bool quiet = false;
};

/// The command line into `o`. Returns -1 to go on, else the exit code (0 after --help, 2 on a usage
/// error, reported here).
int parseOptions(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "dw_graph: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "-o" || a == "--output") {
      o.output = value();
    } else if (a == "--builder") {
      const std::string b = value();
      if (b == "auto")
        o.build.builder = dw::BuilderType::Auto;
      else if (b == "qhull")
        o.build.builder = dw::BuilderType::Qhull;
      else if (b == "incremental")
        o.build.builder = dw::BuilderType::Incremental;
      else {
        std::fprintf(stderr, "dw_graph: unknown builder '%s'\n", b.c_str());
        return 2;
      }
    } else if (a == "--threads") {
      o.build.num_threads = static_cast<unsigned>(std::strtoul(value().c_str(), nullptr, 10));
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "dw_graph: unknown option '%s'\n", a.c_str());
      usage();
      return 2;
    } else if (o.input.empty()) {
      o.input = a;
    } else {
      std::fprintf(stderr, "dw_graph: more than one input given\n");
      return 2;
    }
  }
  if (o.input.empty() || o.output.empty()) {
    usage();
    return 2;
  }
  return -1;
}

using Stages = std::vector<std::pair<std::string, Clock::time_point>>;

/// A built and saved graph with the times of its build stages.
struct BuildRun {
  dw::DelaunayGraph graph;
  Stages stages;
  Clock::time_point built;  ///< the end of the last stage, and where saving starts
  double build_s = 0, save_s = 0;
};

/// Builds the graph of `cloud` and saves it. Progress on large inputs only: a line per stage and per
/// 10%, on stderr so stdout stays parseable. Each stage's time runs from its first report to the next
/// stage's (the last: to the end).
BuildRun buildAndSave(const pcl::PointCloud<pcl::PointXYZ>& cloud, Options& o) {
  BuildRun run;
  const bool print_progress = !o.quiet && cloud.size() >= 200000;
  Stages& stages = run.stages;
  o.build.progress = [&, last = std::string(), tenth = -1](const std::string& stage, double f) mutable {
    if (stages.empty() || stages.back().first != stage) stages.emplace_back(stage, Clock::now());
    const int t = static_cast<int>(f * 10);
    if (print_progress && (stage != last || t != tenth)) {
      std::fprintf(stderr, "  [%s] %3d%%\n", stage.c_str(), t * 10);
      last = stage;
      tenth = t;
    }
  };
  const auto t_build = Clock::now();
  run.graph = cloud.empty()
                  ? dw::buildDelaunayGraph(dw::PointView::fromFloat(nullptr, 0), o.build)
                  : dw::buildDelaunayGraph(
                        dw::PointView::fromFloat(&cloud[0].x, cloud.size(), sizeof(pcl::PointXYZ)), o.build);
  o.build.progress = nullptr;  // it refers to this frame
  run.built = Clock::now();
  run.build_s = std::chrono::duration<double>(run.built - t_build).count();
  dw::saveGraph(run.graph, o.output);
  run.save_s = since(run.built);
  return run;
}

/// The graph's statistics: skipped and collapsed points, degrees, memory, build stages, save time.
void report(const pcl::PointCloud<pcl::PointXYZ>& cloud, const BuildRun& run, const Options& o) {
  const dw::DelaunayGraph& g = run.graph;
  std::size_t skipped = 0;
  for (dw::index_t v : g.input_to_vertex) skipped += v == dw::kInvalidIndex ? 1 : 0;
  std::vector<std::size_t> deg(g.numVertices());
  for (std::size_t v = 0; v < deg.size(); ++v) deg[v] = g.degree(static_cast<dw::index_t>(v));
  std::sort(deg.begin(), deg.end());
  auto pct = [&](double p) {
    return deg.empty() ? 0 : deg[std::min(deg.size() - 1, std::size_t(p * deg.size()))];
  };
  const double mean = deg.empty() ? 0.0 : double(g.numDirectedEdges()) / double(deg.size());
  std::printf("non-finite   %zu (skipped)\n", skipped);
  std::printf("vertices     %zu (%zu duplicate points collapsed)\n", g.numVertices(),
              cloud.size() - skipped - g.numVertices());
  std::printf("dimension    %d\n", g.dimension);
  std::printf("edges        %zu undirected (%zu directed records)\n", g.numDirectedEdges() / 2,
              g.numDirectedEdges());
  std::printf("degree       min %zu  median %zu  mean %.2f  p99 %zu  max %zu\n",
              deg.empty() ? 0 : deg.front(), pct(0.5), mean, pct(0.99), deg.empty() ? 0 : deg.back());
  std::printf("origin       %.6f %.6f %.6f\n", g.origin[0], g.origin[1], g.origin[2]);
  std::printf("memory       %.1f MiB (%.0f B/point)\n", g.memoryBytes() / 1048576.0,
              cloud.empty() ? 0.0 : double(g.memoryBytes()) / double(cloud.size()));
  std::printf("build time   %.3f s (%.0f points/s)\n", run.build_s,
              run.build_s > 0 ? cloud.size() / run.build_s : 0.0);
  std::printf("stages      ");
  for (std::size_t k = 0; k < run.stages.size(); ++k) {
    const auto end = k + 1 < run.stages.size() ? run.stages[k + 1].second : run.built;
    std::printf("%s %s %.3f s", k ? "," : "", run.stages[k].first.c_str(),
                std::chrono::duration<double>(end - run.stages[k].second).count());
  }
  std::printf("\n");
  std::printf("saved        %s in %.3f s\n", o.output.c_str(), run.save_s);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  const int parsed = parseOptions(argc, argv, o);
  if (parsed >= 0) return parsed;
  try {
    const auto t_load = Clock::now();
    const auto cloud = loadCloud(o.input);
    const double load_s = since(t_load);
    std::printf("input        %s\npoints       %zu (loaded in %.3f s)\n", o.input.c_str(), cloud.size(),
                load_s);
    const BuildRun run = buildAndSave(cloud, o);
    report(cloud, run, o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_graph: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
