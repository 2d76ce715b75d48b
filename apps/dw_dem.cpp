/// \file dw_dem.cpp
/// \brief dw_dem: a raster DEM (DTM with --class 2, DSM with all returns) of a LAS/LAZ file, by TIN-linear
/// interpolation of the Delaunay TIN at the cell centres, written as a tiled, compressed GeoTIFF (or COG)
/// carrying the file's coordinate system (docs/dem.md).
///   dw_dem input.{las,laz} [more tiles ...] -o out.tif --resolution R [--class C]
///          [--bounds xmin ymin xmax ymax] [--max-edge L] [--value z|intensity] [--cog]
///          [--hillshade out.png] [--tin out.ply] [--threads N] [--stream [--memory-limit MB]] ...
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "app_args.h"
#include "core/util/process_memory.h"
#include "dem_stage.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/tin/ply_writer.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "stream_stage.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_dem input.{las,laz} [more.las ...] -o out.tif --resolution R [options]\n"
      "  TIN-linear DEM of the points: the Delaunay TIN interpolated at every cell centre.\n"
      "  Several inputs (tiles of one survey: same scale, offsets on one grid) are one cloud.\n"
      "  --class C            keep points of classification C (2 = ground: a DTM; default all: a DSM)\n"
      "  --bounds X0 Y0 X1 Y1 the raster's west, south, east, north edges (default: the points'\n"
      "                       bounding box, widened to multiples of R)\n"
      "  --max-edge L         leave nodata under triangles with an edge longer than L\n"
      "  --value z|intensity  what is interpolated (default z)\n"
      "  --nodata V           nodata value (default -9999)\n"
      "  --float64            Float64 cells (default Float32)\n"
      "  --compress C         DEFLATE (default), LZW, ZSTD or NONE\n"
      "  --cog                a Cloud-Optimized GeoTIFF\n"
      "  --hillshade OUT.png  also write a hillshade preview\n"
      "  --tin OUT.ply        also write the TIN as a binary PLY (as dw_tin; with --stream every kept\n"
      "                       point is a vertex, in input order)\n"
      "  --threads N          threads (default: all cores)\n"
      "  --certify            check the TIN with the exact Delaunay certificate first\n"
      "  --stream             read strip by strip from north to south, holding only the open band\n"
      "  --memory-limit MB    with --stream: the strips' memory (default 1024), sets their height\n"
      "  --quiet              no progress output\n");
}

double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

struct Arguments {
  std::vector<std::string> inputs;  ///< tiles of one survey, triangulated as one cloud
  std::string tin_ply;              ///< --tin: the TIN as a PLY too
  int cls = -1;
  bool certify = false, quiet = false, help = false, stream = false;
  std::size_t memory_limit_mb = 1024;
  unsigned threads = 0;
  dw_apps::DemOptions dem;
};

Arguments parseArguments(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) throw dw::Error("missing value after " + s);
      return argv[++i];
    };
    if (s == "-o" || s == "--output") {
      a.dem.out = value();
    } else if (dw_apps::parseDemOption(s, value, a.dem)) {
      // --resolution, --bounds, --max-edge, --value, --nodata, --float64, --compress, --cog, --hillshade
    } else if (s == "--class") {
      const auto v = dw_apps::parseList(value(), "class", 0, 255);
      if (v.size() != 1) throw dw::Error("--class takes one class code");
      a.cls = int(v[0]);
    } else if (s == "--threads") {
      const auto v = dw_apps::parseList(value(), "thread count", 1, 4096);
      if (v.size() != 1) throw dw::Error("--threads takes one count");
      a.threads = v[0];
    } else if (s == "--stream") {
      a.stream = true;
    } else if (s == "--memory-limit") {
      const auto v = dw_apps::parseList(value(), "memory limit in MB", 1, 1 << 24);
      if (v.size() != 1) throw dw::Error("--memory-limit takes one size in MB");
      a.memory_limit_mb = v[0];
    } else if (s == "--tin") {
      a.tin_ply = value();
    } else if (s == "--certify") {
      a.certify = true;
    } else if (s == "--quiet") {
      a.quiet = true;
    } else if (s == "-h" || s == "--help") {
      a.help = true;
      return a;
    } else if (!s.empty() && s[0] == '-') {
      throw dw::Error("unknown option " + s);
    } else {
      a.inputs.push_back(s);
    }
  }
  if (a.inputs.empty()) throw dw::Error("no input file");
  if (a.dem.out.empty()) throw dw::Error("no output file (-o out.tif)");
  if (!(a.dem.resolution > 0)) throw dw::Error("no --resolution given");
  a.threads = dw::resolveThreads(a.threads);
  if (a.stream && (!a.dem.hillshade.empty() || a.certify))
    throw dw::Error("--stream does not take --hillshade or --certify (they need the whole raster or TIN)");
  return a;
}

/// Prints "stage pct%" on one terminal line, at most every 5 %.
struct Progress {
  bool on = true;
  int last = -1;
  std::string stage;
  void operator()(const std::string& s, double f) {
    if (!on) return;
    const int pct = int(100.0 * f);
    if (s == stage && pct / 5 == last / 5 && f < 1.0) return;
    stage = s;
    last = pct;
    std::fprintf(stderr, "\r  %-10s %5d%%%s", s.c_str(), pct, f >= 1.0 ? "\n" : "");
  }
};
Progress progress;

/// Appends `more` to `all`, re-expressing its integers in `all`'s scale and offset: exact when the
/// scales are equal and the offsets differ by whole units (tiles of one survey), else refused.
void appendCloud(dw::las::LasCloud& all, const dw::las::LasCloud& more, const std::string& name) {
  std::int64_t shift[3];
  for (int k = 0; k < 3; ++k) {
    const double d = (more.header.offset[k] - all.header.offset[k]) / all.header.scale[k];
    if (more.header.scale[k] != all.header.scale[k] || d != std::round(d) || std::fabs(d) > 4e9)
      throw dw::Error(name +
                      ": its LAS scale and offset do not share the first input's integer grid (scales " +
                      std::to_string(more.header.scale[k]) + " and " + std::to_string(all.header.scale[k]) +
                      "); tiles of one survey can be combined, others not yet");
    shift[k] = std::int64_t(d);
  }
  auto add = [&](std::vector<std::int32_t>& to, const std::vector<std::int32_t>& from, std::int64_t s) {
    for (std::int32_t v : from) {
      const std::int64_t w = std::int64_t(v) + s;
      if (w < INT32_MIN || w > INT32_MAX)
        throw dw::Error(name + ": a coordinate leaves the first input's frame");
      to.push_back(std::int32_t(w));
    }
  };
  add(all.X, more.X, shift[0]);
  add(all.Y, more.Y, shift[1]);
  add(all.Z, more.Z, shift[2]);
  all.intensity.insert(all.intensity.end(), more.intensity.begin(), more.intensity.end());
  all.classification.insert(all.classification.end(), more.classification.begin(), more.classification.end());
  all.return_number.insert(all.return_number.end(), more.return_number.begin(), more.return_number.end());
}

int run(const Arguments& a) {
  const auto t0 = std::chrono::steady_clock::now();
  dw::las::LasReadOptions lo;
  lo.classification = a.cls;
  lo.threads = a.threads;
  lo.keep_attributes = a.dem.value == "intensity";
  if (!a.quiet) lo.progress = [](double f, void*) { progress("read", f); };
  dw::las::LasCloud las = dw::las::readLasFile(a.inputs[0], lo);
  for (std::size_t i = 1; i < a.inputs.size(); ++i)
    appendCloud(las, dw::las::readLasFile(a.inputs[i], lo), a.inputs[i]);
  const std::size_t n = las.size();
  if (n == 0)
    throw dw::Error((a.inputs.size() == 1 ? a.inputs[0] : "the inputs") + ": no points" +
                    (a.cls >= 0 ? " of class " + std::to_string(a.cls) : std::string()));
  const std::string wkt = dw_apps::lasCrsWkt(a.inputs, a.quiet);
  const double t_read = since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  const dw_apps::DemPoints points = dw_apps::demPointsOfLas(las, a.dem.value);
  const std::vector<double>&x = points.x, &y = points.y;
  dw::tin::TinOptions to;
  to.num_threads = a.threads;
  if (!a.quiet) to.progress = [](const std::string& stage, double f) { progress(stage, f); };
  const dw::tin::TinResult tin = dw::tin::triangulate(x.data(), y.data(), n, to);
  const double t_tin = since(t1);
  if (tin.degenerate)
    std::fprintf(stderr, "warning: the points are collinear: no triangle, the raster is all nodata\n");
  if (a.certify) {
    const auto c = dw::tin::certifyDelaunay(x.data(), y.data(), n, tin.triangles, tin.num_vertices);
    std::fprintf(stderr, "certificate: %s (%zu interior edges locally Delaunay)\n", c.message.c_str(),
                 c.interior_edges);
    if (!c.ok) return 2;
  }

  std::function<void(const std::string&, double)> show;
  if (!a.quiet) show = [](const std::string& stage, double f) { progress(stage, f); };
  const dw_apps::DemResult dem = dw_apps::writeDem(a.dem, points, tin, wkt, a.threads, show);
  const dw::dem::RasterGrid& grid = dem.grid;
  const dw::dem::TinRasterStats& rs = dem.stats;
  const double t_raster = dem.raster_s, t_write = dem.write_s;
  if (!a.tin_ply.empty())
    dw::tin::writeTinPly(
        a.tin_ply, n, [&](std::size_t i, double* p) { p[0] = las.x(i), p[1] = las.y(i), p[2] = las.z(i); },
        tin.triangles.data(), tin.triangles.size(), {"dw_dem Delaunay TIN of " + a.inputs[0]});
  const double total = since(t0);

  const long peak = dw::processStatusKb("VmHWM:");
  std::printf(
      "points %zu (distinct %zu)  triangles %zu  killed %zu  raster %zu x %zu (%.6g units)  cells set %zu of "
      "%zu\n",
      n, tin.num_vertices, tin.numTriangles(), rs.triangles_killed, grid.cols, grid.rows, grid.cell,
      rs.cells_set, grid.size());
  std::printf("threads %u  read %.3f s  triangulate %.3f s  raster %.3f s  write %.3f s  total %.3f s\n",
              a.threads, t_read, t_tin, t_raster, t_write, total);
  std::printf("peak memory %.1f MB  wrote %s%s%s%s%s\n", peak / 1024.0, a.dem.out.c_str(),
              a.dem.hillshade.empty() ? "" : " and ", a.dem.hillshade.c_str(),
              a.tin_ply.empty() ? "" : " and ", a.tin_ply.c_str());
  return 0;
}

/// --stream: the strips, their final rows written as they come (docs/dem.md "Beyond memory").
int runStream(const Arguments& a) {
  dw_apps::StreamRequest r;
  r.inputs = a.inputs;
  r.classification = a.cls;
  r.memory_limit_mb = a.memory_limit_mb;
  r.threads = a.threads;
  r.quiet = a.quiet;
  r.dem = &a.dem;
  r.ply = a.tin_ply;
  r.ply_comments = {"dw_dem streamed Delaunay TIN of " + a.inputs[0],
                    "vertices: every kept point in input order"};
  dw_apps::runStreamed(r);
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
    progress.on = !args.quiet;
    return args.stream ? runStream(args) : run(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\ndw_dem: %s\n", e.what());
    return 1;
  }
}
