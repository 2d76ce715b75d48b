/// \file dw_dem.cpp
/// \brief dw_dem: a raster DEM (DTM with --class 2, DSM with all returns) of a LAS/LAZ file, by TIN-linear
/// interpolation of the Delaunay TIN at the cell centres, written as a tiled, compressed GeoTIFF (or COG)
/// carrying the file's coordinate system (docs/dem.md).
///   dw_dem input.{las,laz} -o out.tif --resolution R [--class C] [--bounds xmin ymin xmax ymax]
///          [--max-edge L] [--value z|intensity] [--cog] [--hillshade out.png] [--threads N] ...
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "app_args.h"
#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/las/las_crs.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#include "pcl_delaunay_walk/gdal/hillshade.h"
#include "pcl_delaunay_walk/gdal/las_srs.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_dem input.{las,laz} -o out.tif --resolution R [options]\n"
      "  TIN-linear DEM of the points: the Delaunay TIN interpolated at every cell centre.\n"
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
      "  --threads N          threads (default: all cores)\n"
      "  --certify            check the TIN with the exact Delaunay certificate first\n"
      "  --quiet              no progress output\n");
}

double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

double parseNumber(const std::string& opt, const char* v) {
  char* end = nullptr;
  const double x = std::strtod(v, &end);
  if (!end || end == v || *end || !std::isfinite(x))
    throw dw::Error("bad value '" + std::string(v) + "' for " + opt);
  return x;
}

struct Arguments {
  std::string in, out, hillshade, value = "z";
  int cls = -1;
  double resolution = 0, max_edge = 0;
  bool has_bounds = false, certify = false, quiet = false, help = false;
  double bounds[4] = {0, 0, 0, 0};
  unsigned threads = 0;
  dw::gdal::GeoTiffOptions tiff;
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
      a.out = value();
    } else if (s == "--resolution") {
      a.resolution = parseNumber(s, value());
      if (!(a.resolution > 0)) throw dw::Error("--resolution must be positive");
    } else if (s == "--class") {
      const auto v = dw_apps::parseList(value(), "class", 0, 255);
      if (v.size() != 1) throw dw::Error("--class takes one class code");
      a.cls = int(v[0]);
    } else if (s == "--bounds") {
      for (double& b : a.bounds) b = parseNumber(s, value());
      a.has_bounds = true;
    } else if (s == "--max-edge") {
      a.max_edge = dw_apps::parseNonNegative(value(), "--max-edge");
    } else if (s == "--value") {
      a.value = value();
      if (a.value != "z" && a.value != "intensity") throw dw::Error("--value must be z or intensity");
    } else if (s == "--nodata") {
      a.tiff.nodata = parseNumber(s, value());
    } else if (s == "--float64") {
      a.tiff.float64 = true;
    } else if (s == "--compress") {
      a.tiff.compress = value();
    } else if (s == "--cog") {
      a.tiff.cog = true;
    } else if (s == "--hillshade") {
      a.hillshade = value();
    } else if (s == "--threads") {
      const auto v = dw_apps::parseList(value(), "thread count", 1, 4096);
      if (v.size() != 1) throw dw::Error("--threads takes one count");
      a.threads = v[0];
    } else if (s == "--certify") {
      a.certify = true;
    } else if (s == "--quiet") {
      a.quiet = true;
    } else if (s == "-h" || s == "--help") {
      a.help = true;
      return a;
    } else if (!s.empty() && s[0] == '-') {
      throw dw::Error("unknown option " + s);
    } else if (a.in.empty()) {
      a.in = s;
    } else {
      throw dw::Error("more than one input file given");
    }
  }
  if (a.in.empty()) throw dw::Error("no input file");
  if (a.out.empty()) throw dw::Error("no output file (-o out.tif)");
  if (!(a.resolution > 0)) throw dw::Error("no --resolution given");
  a.threads = dw::resolveThreads(a.threads);
  a.tiff.num_threads = a.threads;
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

/// The points in the triangulation frame: LAS integers when the x and y scales agree (an exact
/// similarity of the plane, see docs/tin.md "Frames"), else scaled units. world = frame * k + offset.
struct Frame {
  double k = 1, off_x = 0, off_y = 0;
  double toFrameX(double wx) const { return (wx - off_x) / k; }
  double toFrameY(double wy) const { return (wy - off_y) / k; }
};

Frame frameOf(const dw::las::LasHeader& h, std::vector<double>& x, std::vector<double>& y,
              const dw::las::LasCloud& las) {
  Frame f;
  const bool same = h.scale[0] == h.scale[1];
  f.k = same ? h.scale[0] : 1.0;
  f.off_x = h.offset[0];
  f.off_y = h.offset[1];
  x.resize(las.size());
  y.resize(las.size());
  for (std::size_t i = 0; i < las.size(); ++i) {
    x[i] = same ? double(las.X[i]) : las.X[i] * h.scale[0];
    y[i] = same ? double(las.Y[i]) : las.Y[i] * h.scale[1];
  }
  return f;
}

dw::dem::RasterGrid worldGrid(const Arguments& a, const dw::las::LasCloud& las) {
  if (a.has_bounds)
    return dw::dem::gridFromBounds(a.bounds[0], a.bounds[1], a.bounds[2], a.bounds[3], a.resolution);
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  for (std::size_t i = 0; i < las.size(); ++i) {
    const double p[2] = {las.x(i), las.y(i)};
    for (int k = 0; k < 2; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
  }
  return dw::dem::alignedGridCovering(lo[0], lo[1], hi[0], hi[1], a.resolution);
}

std::string crsOf(const Arguments& a) {
  std::string source;
  try {
    const std::string wkt = dw::gdal::srsWktFromLas(dw::las::readLasCrs(a.in), &source);
    if (!a.quiet)
      std::fprintf(stderr, "coordinate system: %s\n", wkt.empty() ? "none in the file" : source.c_str());
    return wkt;
  } catch (const dw::gdal::RasterError& e) {
    std::fprintf(stderr, "warning: %s: %s; the raster gets no coordinate system\n", a.in.c_str(), e.what());
    return std::string();
  }
}

int run(const Arguments& a) {
  const auto t0 = std::chrono::steady_clock::now();
  dw::las::LasReadOptions lo;
  lo.classification = a.cls;
  lo.threads = a.threads;
  lo.keep_attributes = a.value == "intensity";
  if (!a.quiet) lo.progress = [](double f, void*) { progress("read", f); };
  const dw::las::LasCloud las = dw::las::readLasFile(a.in, lo);
  const std::size_t n = las.size();
  if (n == 0)
    throw dw::Error(a.in + ": no points" +
                    (a.cls >= 0 ? " of class " + std::to_string(a.cls) : std::string()));
  const std::string wkt = crsOf(a);
  const double t_read = since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  std::vector<double> x, y;
  const Frame frame = frameOf(las.header, x, y, las);
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

  const auto t2 = std::chrono::steady_clock::now();
  const dw::dem::RasterGrid grid = worldGrid(a, las);
  // The raster is held in memory as doubles (and GDAL takes int sizes): refuse what cannot fit.
  if (grid.cols > 2147483647u || grid.rows > 2147483647u || grid.size() > (std::size_t(1) << 32))
    throw dw::Error(
        "a raster of " + std::to_string(grid.cols) + " x " + std::to_string(grid.rows) +
        " cells is too large to hold in memory (at most 2^32 cells); choose a coarser --resolution "
        "or smaller --bounds");
  dw::dem::RasterGrid fgrid = grid;  // the same cells in the frame
  fgrid.west = frame.toFrameX(grid.west);
  fgrid.north = frame.toFrameY(grid.north);
  fgrid.cell = grid.cell / frame.k;
  std::vector<double> value(n);
  for (std::size_t i = 0; i < n; ++i) value[i] = a.value == "z" ? las.z(i) : double(las.intensity[i]);
  dw::dem::TinRasterOptions ro;
  ro.max_edge = a.max_edge / frame.k;
  ro.nodata = a.tiff.nodata;
  ro.num_threads = a.threads;
  if (!a.quiet) ro.progress = [](double f) { progress("raster", f); };
  dw::dem::TinRasterStats rs;
  const std::vector<double> raster =
      dw::dem::rasterizeTin(x.data(), y.data(), value.data(), n, tin.triangles, fgrid, ro, &rs);
  const double t_raster = since(t2);

  const auto t3 = std::chrono::steady_clock::now();
  dw::gdal::GeoTiffOptions tiff = a.tiff;
  tiff.srs_wkt = wkt;
  dw::gdal::GeoTiffWriter writer(a.out, grid, tiff);
  const std::size_t band = 256;
  for (std::size_t r = 0; r < grid.rows; r += band) {
    writer.writeRows(r, std::min(band, grid.rows - r), raster.data() + r * grid.cols);
    if (!a.quiet) progress("write", double(std::min(grid.rows, r + band)) / double(grid.rows));
  }
  // The preview first: if it fails, the DEM is not committed and an existing one stays as it was.
  if (!a.hillshade.empty()) dw::gdal::writeHillshadePng(a.hillshade, grid, raster.data(), a.tiff.nodata);
  writer.commit();
  const double t_write = since(t3), total = since(t0);

  const long peak = dw::processStatusKb("VmHWM:");
  std::printf(
      "points %zu (distinct %zu)  triangles %zu  killed %zu  raster %zu x %zu (%.6g units)  cells set %zu of "
      "%zu\n",
      n, tin.num_vertices, tin.numTriangles(), rs.triangles_killed, grid.cols, grid.rows, grid.cell,
      rs.cells_set, grid.size());
  std::printf("threads %u  read %.3f s  triangulate %.3f s  raster %.3f s  write %.3f s  total %.3f s\n",
              a.threads, t_read, t_tin, t_raster, t_write, total);
  std::printf("peak memory %.1f MB  wrote %s%s%s\n", peak / 1024.0, a.out.c_str(),
              a.hillshade.empty() ? "" : " and ", a.hillshade.c_str());
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
    return run(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\ndw_dem: %s\n", e.what());
    return 1;
  }
}
