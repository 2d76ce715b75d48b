/// \file dw_tin.cpp
/// \brief dw_tin: parallel Delaunay TIN of a LiDAR cloud (LAS, PCD or PLY) written as a binary PLY mesh
/// and/or, with GDAL, as a raster DEM (the DEM stage of dw_dem, apps/dem_stage.h; docs/dem.md).
///   dw_tin input.{las,pcd,ply} [-o out.ply] [--dem out.tif --resolution R ...] [--threads N] [--strips K]
///          [--class C] [--certify] [--stream [--memory-limit MB]] [--quiet]
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

#include "core/util/file_header_check.h"
#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/tin/ply_writer.h"
#include "stream_stage.h"
#ifdef DW_HAVE_GDAL
#include "dem_stage.h"
#endif

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_tin input.{las,pcd,ply} -o out.ply [--threads N] [--strips K] [--class C] [--certify] "
      "[--quiet]\n"
      "  Delaunay triangulation of the points' (x, y), z kept; writes a binary PLY mesh.\n"
      "  --class C   LAS only: keep points of classification C (2 = ground)\n"
      "  --certify   check every edge with exact predicates afterwards (slower, more memory)\n"
      "  --dem OUT.tif --resolution R [--bounds ..] [--max-edge L] [--value z|intensity] [--cog] "
      "[--hillshade P]\n"
      "              also (or only, without -o) a TIN-linear GeoTIFF DEM, as dw_dem writes it (needs "
      "GDAL)\n"
      "  --stream    LAS/LAZ: read strip by strip from north to south, writing the PLY's triangles (all\n"
      "              kept points as vertices, input order) and the DEM's rows as they become final\n"
      "  --memory-limit MB  with --stream: the strips' memory (default 1024), sets their height\n"
      "  --quiet     no progress output\n");
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

bool endsWith(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

unsigned parseUnsigned(const std::string& opt, const char* v) {
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  if (!end || *end || x < 0 || x > 1 << 20) throw dw::Error("bad value '" + std::string(v) + "' for " + opt);
  return unsigned(x);
}

double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// The command line.
struct Arguments {
  std::string in, out, dem_out;
#ifdef DW_HAVE_GDAL
  dw_apps::DemOptions dem;
#endif
  dw::tin::TinOptions opt;
  int cls = -1;
  bool certify = false, quiet = false, help = false, stream = false, strips_given = false;
  std::size_t memory_limit_mb = 1024;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) throw dw::Error("missing value after " + a);
      return argv[++i];
    };
    if (a == "-o" || a == "--output")
      args.out = value();
    else if (a == "--dem")
      args.dem_out = value();
#ifdef DW_HAVE_GDAL
    else if (dw_apps::parseDemOption(a, value, args.dem))
      continue;
#endif
    else if (a == "--threads")
      args.opt.num_threads = parseUnsigned(a, value());
    else if (a == "--strips")
      args.opt.num_strips = parseUnsigned(a, value()), args.strips_given = true;
    else if (a == "--stream")
      args.stream = true;
    else if (a == "--memory-limit") {
      args.memory_limit_mb = parseUnsigned(a, value());
      if (args.memory_limit_mb == 0) throw dw::Error("--memory-limit must be at least 1 MB");
    } else if (a == "--class")
      args.cls = int(parseUnsigned(a, value()));
    else if (a == "--certify")
      args.certify = true;
    else if (a == "--quiet")
      args.quiet = true;
    else if (a == "-h" || a == "--help") {
      args.help = true;
      return args;
    } else if (!a.empty() && a[0] == '-') {
      throw dw::Error("unknown option " + a);
    } else if (args.in.empty()) {
      args.in = a;
    } else {
      throw dw::Error("more than one input file given");
    }
  }
  if (args.in.empty()) throw dw::Error("no input file");
  if (args.out.empty() && args.dem_out.empty())
    throw dw::Error("no output file (-o out.ply or --dem out.tif)");
#ifdef DW_HAVE_GDAL
  args.dem.out = args.dem_out;
  if (!args.dem_out.empty() && !(args.dem.resolution > 0)) throw dw::Error("--dem needs --resolution");
#else
  if (!args.dem_out.empty()) throw dw::Error("--dem: this dw_tin was built without GDAL (see docs/dem.md)");
#endif
  if (!std::ifstream(args.in).good()) throw dw::Error(args.in + ": cannot open for reading");
  if (args.stream) {
    const std::string ext = lower(args.in);
    if (!endsWith(ext, ".las") && !endsWith(ext, ".laz"))
      throw dw::Error("--stream reads LAS or LAZ input (" + args.in + " is neither)");
    if (args.certify || args.strips_given)
      throw dw::Error("--stream does not take --certify or --strips (the strips follow --memory-limit)");
#ifdef DW_HAVE_GDAL
    if (!args.dem.hillshade.empty())
      throw dw::Error("--stream does not take --hillshade (it needs the whole raster)");
#endif
  }
  if (args.opt.num_threads == 0) args.opt.num_threads = std::max(1u, std::thread::hardware_concurrency());
  if (!args.quiet)
    args.opt.progress = [](const std::string& stage, double f) {
      std::fprintf(stderr, "\r  %-8s %5.1f%%", stage.c_str(), 100.0 * f);
      if (f >= 1.0) std::fprintf(stderr, "\n");
    };
  return args;
}

/// The kept source coordinates (12 bytes/point) give the output vertices and, converted exactly, the
/// triangulation frame: LAS integers when the x and y scales agree (an exact similarity of the world
/// plane), else scaled units; PCD/PLY floats as they are.
struct InputCloud {
  dw::las::LasCloud las;
  pcl::PointCloud<pcl::PointXYZ> cloud;
  bool is_las = false, same_scale = true;

  std::size_t size() const { return is_las ? las.size() : cloud.size(); }
  /// The triangulation frame's (x, y) of every point.
  void frame(std::vector<double>& x, std::vector<double>& y) const {
    const std::size_t n = size();
    x.resize(n);
    y.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (is_las) {
        x[i] = same_scale ? double(las.X[i]) : las.X[i] * las.header.scale[0];
        y[i] = same_scale ? double(las.Y[i]) : las.Y[i] * las.header.scale[1];
      } else {
        x[i] = cloud[i].x;
        y[i] = cloud[i].y;
      }
    }
  }
  /// Point i's source coordinates, as written to the mesh.
  void point(std::size_t i, double* p) const {
    if (is_las) {
      p[0] = las.x(i);
      p[1] = las.y(i);
      p[2] = las.z(i);
    } else {
      p[0] = cloud[i].x;
      p[1] = cloud[i].y;
      p[2] = cloud[i].z;
    }
  }
};

InputCloud readInput(const Arguments& args) {
  InputCloud input;
  const std::string& in = args.in;
  const std::string ext = lower(in);
  if (endsWith(ext, ".las") || endsWith(ext, ".laz")) {
    input.is_las = true;
    dw::las::LasReadOptions lo;
    lo.classification = args.cls;
#ifdef DW_HAVE_GDAL
    lo.keep_attributes = !args.dem_out.empty() && args.dem.value == "intensity";
#endif
    static int last_pct = -1;  // print every 5 %: a terminal line, not a log flood
    if (!args.quiet)
      lo.progress = [](double f, void*) {
        const int pct = int(100.0 * f);
        if (pct / 5 == last_pct / 5) return;
        last_pct = pct;
        std::fprintf(stderr, "\r  %-8s %5d%%", "read", pct);
      };
    input.las = dw::las::readLasFile(in, lo);
    if (!args.quiet) std::fprintf(stderr, "\n");
    input.same_scale = input.las.header.scale[0] == input.las.header.scale[1];
  } else if (endsWith(ext, ".pcd") || endsWith(ext, ".ply")) {
    if (args.cls >= 0) throw dw::Error("--class needs a LAS input");
    dw::checkPointFileHeader(in);  // PCL 1.13 crashes on some malformed headers (robustness.md)
    const int rc =
        endsWith(ext, ".pcd") ? pcl::io::loadPCDFile(in, input.cloud) : pcl::io::loadPLYFile(in, input.cloud);
    if (rc < 0) throw dw::Error(in + ": PCL could not read the file (corrupt or unsupported)");
  } else {
    throw dw::Error(in + ": unknown input type (expected .las, .pcd or .ply)");
  }
  return input;
}

/// The exact local-Delaunay check of every edge, on a second copy of the frame; false if it fails.
bool certify(const InputCloud& input, const dw::tin::TinResult& tin) {
  std::vector<double> x, y;
  input.frame(x, y);
  const auto c = dw::tin::certifyDelaunay(x.data(), y.data(), input.size(), tin.triangles, tin.num_vertices);
  std::fprintf(stderr, "certificate: %s (%zu interior edges locally Delaunay, %zu hull edges)\n",
               c.message.c_str(), c.interior_edges, c.hull_edges);
  return c.ok;
}

/// Seconds spent in each step of the run, for the report.
struct Timings {
  double read = 0, tin = 0, write = 0, total = 0;
};

void printReport(const Arguments& args, std::size_t n, const dw::tin::TinResult& tin, std::uint64_t written,
                 const Timings& t) {
  const long peak = dw::processStatusKb("VmHWM:");
  std::printf(
      "points %zu (distinct %zu, duplicates %zu, skipped %zu)  triangles %zu  vertices written %llu\n", n,
      tin.num_vertices, tin.duplicates.size(), tin.skipped.size(), tin.numTriangles(),
      static_cast<unsigned long long>(written));
  std::printf(
      "strips %zu  threads %u  read %.2f s  triangulate %.2f s (%.2f M points/s; strips %.2f s, merge %.2f "
      "s)"
      "  write %.2f s  total %.2f s\n",
      tin.stats.strips, args.opt.num_threads ? args.opt.num_threads : std::thread::hardware_concurrency(),
      t.read, t.tin, n / t.tin / 1e6, tin.stats.strips_s, tin.stats.merge_s, t.write, t.total);
  std::printf("peak memory %.1f MB (%.1f bytes/point)\n", peak / 1024.0, peak * 1024.0 / double(n));
}

#ifdef DW_HAVE_GDAL
/// The DEM of the TIN (apps/dem_stage.h, the stage dw_dem runs), with the LAS file's CRS; prints its
/// line of the report.
void writeDemOf(const Arguments& args, const InputCloud& input, const dw::tin::TinResult& tin) {
  if (args.dem.value == "intensity" && !input.is_las) throw dw::Error("--value intensity needs a LAS input");
  dw_apps::DemPoints points;
  std::string wkt;
  if (input.is_las) {
    points = dw_apps::demPointsOfLas(input.las, args.dem.value);
    wkt = dw_apps::lasCrsWkt({args.in}, args.quiet);
  } else {
    input.frame(points.x, points.y);  // PCD/PLY floats: the frame is the world
    points.value.resize(input.size());
    double p[3];
    for (std::size_t i = 0; i < input.size(); ++i) {
      input.point(i, p);
      points.value[i] = p[2];
      points.extend(p[0], p[1]);
    }
  }
  std::function<void(const std::string&, double)> show;
  if (!args.quiet)
    show = [](const std::string& stage, double f) {
      std::fprintf(stderr, "\r  %-8s %5.1f%%", stage.c_str(), 100.0 * f);
      if (f >= 1.0) std::fprintf(stderr, "\n");
    };
  const unsigned threads = args.opt.num_threads;  // set by parseArguments
  const auto dem = dw_apps::writeDem(args.dem, points, tin, wkt, threads, show);
  std::printf("dem %s: %zu x %zu cells of %.6g, set %zu, killed triangles %zu, raster %.2f s, write %.2f s\n",
              args.dem.out.c_str(), dem.grid.cols, dem.grid.rows, dem.grid.cell, dem.stats.cells_set,
              dem.stats.triangles_killed, dem.raster_s, dem.write_s);
}
#endif

/// --stream: strip by strip, the PLY's triangles and the DEM's rows written as they become final
/// (apps/stream_stage.h, the run `dw_dem --stream` makes).
int runStream(const Arguments& args) {
  dw_apps::StreamRequest r;
  r.inputs = {args.in};
  r.classification = args.cls;
  r.memory_limit_mb = args.memory_limit_mb;
  r.threads = args.opt.num_threads;
  r.quiet = args.quiet;
#ifdef DW_HAVE_GDAL
  if (!args.dem_out.empty()) r.dem = &args.dem;
#endif
  r.ply = args.out;
  r.ply_comments = {
      "dw_tin streamed Delaunay TIN of " + args.in,
      "triangles are Delaunay in (x, y); z is carried; vertices: every kept point in input order"};
  dw_apps::runStreamed(r);
  return 0;
}

/// Read, triangulate, certify if asked, write, report; the process's exit status.
int run(const Arguments& args) {
  Timings t;
  const auto t0 = std::chrono::steady_clock::now();
  const InputCloud input = readInput(args);
  const std::size_t n = input.size();
  t.read = since(t0);
  if (!args.quiet) std::fprintf(stderr, "read %zu points in %.2f s\n", n, t.read);
  if (n == 0)
    throw dw::Error(args.in + ": no points" +
                    (args.cls >= 0 ? " of class " + std::to_string(args.cls) : std::string()));

  const auto t1 = std::chrono::steady_clock::now();
  dw::tin::TinResult tin;
  {
    std::vector<double> x, y;
    input.frame(x, y);
    tin = dw::tin::triangulate(std::move(x), std::move(y), args.opt);
  }
  t.tin = since(t1);
  if (tin.degenerate)
    std::fprintf(stderr, "warning: the %zu distinct points are collinear (or fewer than 3): no triangle\n",
                 tin.num_vertices);
  if (args.certify && !certify(input, tin)) return 2;

#ifdef DW_HAVE_GDAL
  if (!args.dem_out.empty()) writeDemOf(args, input, tin);
#endif
  if (args.out.empty()) return 0;
  const auto t2 = std::chrono::steady_clock::now();
  const std::vector<std::string> comments = {"dw_tin Delaunay TIN of " + args.in,
                                             "triangles are Delaunay in (x, y); z is carried"};
  const std::uint64_t written = dw::tin::writeTinPly(
      args.out, n, [&](std::size_t i, double* p) { input.point(i, p); }, tin.triangles.data(),
      tin.triangles.size(), comments);
  t.write = since(t2);
  t.total = since(t0);
  printReport(args, n, tin, written, t);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Arguments args = parseArguments(argc, argv);
    if (args.help) {
      usage();
      return 0;
    }
    return args.stream ? runStream(args) : run(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_tin: %s\n", e.what());
    return 1;
  }
}
