/// \file dw_dem_scale.cpp
/// \brief dw_dem_scale: the DEM at scale without GDAL (core only, so it also runs on the device
/// machine): LAS/LAZ tiles of one survey to a TIN-linear DEM written as a raw band + ENVI header
/// (core/dem/envi_writer.h), either streamed (dw::dem::StreamDem, what `dw_dem --stream` runs) or in
/// memory (read everything, dw::tin::triangulate, dw::dem::rasterizeTin: what `dw_dem` runs). Prints
/// the stages, the wall time including all reading and writing, points per second, the process's peak
/// resident memory (getrusage) and bytes per point, and one `result` line for scripts
/// (tools/device/dem_scale.sh, docs/dem.md "Scale").
///   dw_dem_scale tiles.las... -o dem.raw --resolution R [--class C] [--max-edge L] [--threads N]
///                [--stream [--memory-limit MB]] [--float64] [--quiet]
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "app_args.h"
#include "pcl_delaunay_walk/core/dem/envi_writer.h"
#include "pcl_delaunay_walk/core/dem/stream_dem.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_dem_scale tiles.{las,laz}... -o dem.raw --resolution R [--class C] [--max-edge L]\n"
      "                    [--threads N] [--stream [--memory-limit MB]] [--float64] [--quiet]\n"
      "  Writes dem.raw (one band, little-endian Float32, row 0 north) and dem.hdr (ENVI header).\n");
}

struct Arguments {
  std::vector<std::string> inputs;
  std::string out;
  double resolution = 0, max_edge = 0;
  int cls = -1;
  unsigned threads = 0;
  bool stream = false, float64 = false, quiet = false;
  std::size_t memory_limit_mb = 1024;
};

Arguments parse(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw dw::Error("missing value after " + s);
      return argv[++i];
    };
    if (s == "-o")
      a.out = value();
    else if (s == "--resolution")
      a.resolution = dw_apps::parseNonNegative(value(), "--resolution");
    else if (s == "--max-edge")
      a.max_edge = dw_apps::parseNonNegative(value(), "--max-edge");
    else if (s == "--class")
      a.cls = int(dw_apps::parseList(value(), "class", 0, 255).at(0));
    else if (s == "--threads")
      a.threads = dw_apps::parseList(value(), "thread count", 1, 4096).at(0);
    else if (s == "--memory-limit")
      a.memory_limit_mb = dw_apps::parseList(value(), "memory limit in MB", 1, 1 << 24).at(0);
    else if (s == "--stream")
      a.stream = true;
    else if (s == "--float64")
      a.float64 = true;
    else if (s == "--quiet")
      a.quiet = true;
    else if (s == "-h" || s == "--help") {
      usage();
      std::exit(0);
    } else if (!s.empty() && s[0] == '-')
      throw dw::Error("unknown option " + s);
    else
      a.inputs.push_back(s);
  }
  if (a.inputs.empty()) throw dw::Error("no input file");
  if (a.out.empty()) throw dw::Error("no output file (-o dem.raw)");
  if (!(a.resolution > 0)) throw dw::Error("no --resolution given");
  a.threads = dw::resolveThreads(a.threads);
  return a;
}

double peakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // Linux: kB
}

struct Result {
  std::uint64_t points = 0;
  dw::dem::RasterGrid grid;
  std::size_t cells_set = 0;
};

Result runStream(const Arguments& a) {
  dw::dem::StreamDemOptions o;
  o.inputs = a.inputs;
  o.classification = a.cls;
  o.resolution = a.resolution;
  o.max_edge = a.max_edge;
  o.memory_limit_mb = a.memory_limit_mb;
  o.threads = a.threads;
  double last = -1;
  std::function<void(const dw::dem::StreamDemProgress&)> show;
  if (!a.quiet)
    show = [&](const dw::dem::StreamDemProgress& p) {
      const bool end = p.points_read >= p.points_total;
      if (p.elapsed_s - last < 5.0 && !end) return;
      last = p.elapsed_s;
      std::fprintf(stderr,
                   "  [%7.1f s] %-6s %llu of %llu points  strips %zu of %zu  %.2f M points/s  left %.0f s\n",
                   p.elapsed_s, p.stage, (unsigned long long)p.points_read,
                   (unsigned long long)p.points_total, p.strips_done, p.strips, p.rate / 1e6, p.left_s);
    };
  dw::dem::StreamDem dem(o, show);
  dw::dem::EnviOptions eo;
  eo.float64 = a.float64;
  dw::dem::EnviWriter writer(a.out, dem.grid(), eo);
  const dw::dem::StreamDemStats st =
      dem.run([&](std::size_t r, std::size_t k, const double* v) { writer.writeRows(r, k, v); });
  writer.commit();
  std::printf("strips %zu (largest %zu points)  resident at most %zu points  rows held at most %zu\n",
              st.strips, st.max_strip_points, st.max_resident, st.max_rows_held);
  std::printf("scan %.3f s  spill %.3f s  strips %.3f s\n", st.scan_s, st.spill_s, st.strips_s);
  std::printf(
      "strips: read %.3f  merge %.3f  tin %.3f  classify %.3f  raster %.3f  frontier %.3f  flush %.3f s\n",
      st.read_s, st.merge_s, st.tin_s, st.classify_s, st.emit_s, st.frontier_s, st.flush_s);
  return {st.points, dem.grid(), st.raster.cells_set};
}

/// The in-memory DEM as dw_dem computes it: the tiles re-expressed in the first one's integers, the
/// TIN on the LAS integers, the raster on the grid mapped into that frame.
Result runInMemory(const Arguments& a) {
  const auto t0 = Clock::now();
  dw::las::LasReadOptions lo;
  lo.classification = a.cls;
  lo.threads = a.threads;
  dw::las::LasCloud las = dw::las::readLasFile(a.inputs[0], lo);
  const dw::las::LasHeader h = las.header;  // a copy: the cloud is released before the raster
  for (std::size_t i = 1; i < a.inputs.size(); ++i) {
    const dw::las::LasCloud more = dw::las::readLasFile(a.inputs[i], lo);
    std::int64_t shift[3];
    for (int k = 0; k < 3; ++k) {
      const double d = (more.header.offset[k] - h.offset[k]) / h.scale[k];
      if (more.header.scale[k] != h.scale[k] || d != std::round(d) || std::fabs(d) > 4e9)
        throw dw::Error(a.inputs[i] +
                        ": its LAS scale and offset do not share the first input's integer grid");
      shift[k] = std::int64_t(d);
    }
    auto add = [&](std::vector<std::int32_t>& to, const std::vector<std::int32_t>& from, std::int64_t s) {
      for (std::int32_t v : from) {
        const std::int64_t w = std::int64_t(v) + s;
        if (w < INT32_MIN || w > INT32_MAX)
          throw dw::Error(a.inputs[i] + ": a coordinate leaves the first input's frame");
        to.push_back(std::int32_t(w));
      }
    };
    add(las.X, more.X, shift[0]), add(las.Y, more.Y, shift[1]), add(las.Z, more.Z, shift[2]);
  }
  const std::size_t n = las.size();
  if (n == 0) throw dw::Error("no points");
  const double t_read = since(t0);
  const auto t1 = Clock::now();
  const bool same = h.scale[0] == h.scale[1];
  const double k = same ? h.scale[0] : 1.0;
  std::vector<double> x(n), y(n), value(n);
  double lo_w[2] = {HUGE_VAL, HUGE_VAL}, hi_w[2] = {-HUGE_VAL, -HUGE_VAL};
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = same ? double(las.X[i]) : las.X[i] * h.scale[0];
    y[i] = same ? double(las.Y[i]) : las.Y[i] * h.scale[1];
    value[i] = las.z(i);
    lo_w[0] = std::min(lo_w[0], las.x(i)), hi_w[0] = std::max(hi_w[0], las.x(i));
    lo_w[1] = std::min(lo_w[1], las.y(i)), hi_w[1] = std::max(hi_w[1], las.y(i));
  }
  las = dw::las::LasCloud();
  dw::tin::TinOptions to;
  to.num_threads = a.threads;
  const dw::tin::TinResult tin = dw::tin::triangulate(x.data(), y.data(), n, to);
  const double t_tin = since(t1);
  const auto t2 = Clock::now();
  Result res;
  res.points = n;
  res.grid = dw::dem::alignedGridCovering(lo_w[0], lo_w[1], hi_w[0], hi_w[1], a.resolution);
  dw::dem::RasterGrid f = res.grid;
  f.west = (res.grid.west - (same ? h.offset[0] : 0.0)) / k;
  f.north = (res.grid.north - (same ? h.offset[1] : 0.0)) / k;
  f.cell = res.grid.cell / k;
  dw::dem::TinRasterOptions ro;
  ro.max_edge = a.max_edge / k;
  ro.num_threads = a.threads;
  dw::dem::TinRasterStats rs;
  const std::vector<double> raster =
      dw::dem::rasterizeTin(x.data(), y.data(), value.data(), n, tin.triangles, f, ro, &rs);
  const double t_raster = since(t2);
  const auto t3 = Clock::now();
  dw::dem::EnviOptions eo;
  eo.float64 = a.float64;
  dw::dem::EnviWriter writer(a.out, res.grid, eo);
  writer.writeRows(0, res.grid.rows, raster.data());
  writer.commit();
  std::printf("read %.3f s  triangulate %.3f s  raster %.3f s  write %.3f s\n", t_read, t_tin, t_raster,
              since(t3));
  res.cells_set = rs.cells_set;
  return res;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Arguments a = parse(argc, argv);
    const auto t0 = Clock::now();
    const Result r = a.stream ? runStream(a) : runInMemory(a);
    const double wall = since(t0), peak = peakRssMb();
    std::printf("raster %zu x %zu  cells set %zu of %zu\n", r.grid.cols, r.grid.rows, r.cells_set,
                r.grid.size());
    std::printf(
        "result mode %s threads %u memory_limit_mb %zu points %llu wall_s %.3f points_per_s %.0f peak_rss_mb "
        "%.1f "
        "bytes_per_point %.1f\n",
        a.stream ? "stream" : "in-memory", a.threads, a.stream ? a.memory_limit_mb : std::size_t(0),
        (unsigned long long)r.points, wall, double(r.points) / wall, peak,
        peak * 1048576.0 / double(r.points));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_dem_scale: %s\n", e.what());
    return 1;
  }
}
