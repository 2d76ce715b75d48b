/// \file dw_dem_bench.cpp
/// \brief Side by side in one process: our TIN-linear DEM (dw::tin::triangulate + dw::dem::rasterizeTin)
/// against GDAL's GDALGridCreate(GGA_Linear) -- what `gdal_grid -a linear` runs -- on the same points
/// and the same grid, with the same thread count; prints both times, their ratio, and the largest
/// difference at the cells both define (docs/dem.md, "Benchmark").
///   dw_dem_bench [--las FILE [--class C]] [-n POINTS] --resolution R [--threads N] [--repeats K]
#include <cpl_conv.h>
#include <gdal.h>
#include <gdal_alg.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <thread>
#include <vector>

#include "app_args.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// CPU seconds of the whole process (all threads): on a shared machine less noisy than wall time.
double cpuNow() {
  return double(std::clock()) / CLOCKS_PER_SEC;
}

struct Points {
  std::vector<double> fx, fy, wx, wy, z;  // LAS-integer frame, world coordinates, heights
  double k = 1, off_x = 0, off_y = 0;     // world = frame * k + offset
  std::string name;
};

Points load(const std::string& las_path, int cls, std::uint64_t n) {
  Points p;
  dw::las::LasCloud las;
  if (!las_path.empty()) {
    dw::las::LasReadOptions lo;
    lo.classification = cls;
    las = dw::las::readLasFile(las_path, lo);
    p.name = las_path + (cls >= 0 ? " class " + std::to_string(cls) : std::string());
  } else {
    dw::las::LidarGenOptions g;
    g.num_points = n;
    las.header = dw::las::syntheticHeader(g);
    dw::las::generateLidar(g, [&](const dw::las::LasRecord& r) {
      if (cls >= 0 && r.classification != cls) return;
      las.X.push_back(r.X), las.Y.push_back(r.Y), las.Z.push_back(r.Z);
    });
    p.name = "synthetic " + std::to_string(n) + (cls >= 0 ? " class " + std::to_string(cls) : std::string());
  }
  if (las.header.scale[0] != las.header.scale[1])
    throw dw::Error("unequal x and y scales are not benchmarked");
  p.k = las.header.scale[0], p.off_x = las.header.offset[0], p.off_y = las.header.offset[1];
  for (std::size_t i = 0; i < las.size(); ++i) {
    p.fx.push_back(las.X[i]), p.fy.push_back(las.Y[i]);
    p.wx.push_back(las.x(i)), p.wy.push_back(las.y(i)), p.z.push_back(las.z(i));
  }
  return p;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string las;
    int cls = -1;
    std::uint64_t n = 1000000;
    double res = 1;
    unsigned threads = std::max(1u, std::thread::hardware_concurrency()), repeats = 3;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw dw::Error("missing value after " + a);
        return argv[++i];
      };
      if (a == "--las")
        las = value();
      else if (a == "--class")
        cls = int(dw_apps::parseList(value(), "class", 0, 255)[0]);
      else if (a == "-n")
        n = dw_apps::parseCount(value(), "point count");
      else if (a == "--resolution")
        res = dw_apps::parseNonNegative(value(), "resolution");
      else if (a == "--threads")
        threads = dw_apps::parseList(value(), "thread count", 1, 1024)[0];
      else if (a == "--repeats")
        repeats = dw_apps::parseList(value(), "repeat count", 1, 100)[0];
      else
        throw dw::Error("unknown option " + a);
    }
    if (!(res > 0)) throw dw::Error("--resolution must be positive");
    const Points p = load(las, cls, n);
    const std::size_t m = p.z.size();
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL}, zlo = HUGE_VAL, zhi = -HUGE_VAL;
    for (std::size_t i = 0; i < m; ++i) {
      lo[0] = std::min(lo[0], p.wx[i]), hi[0] = std::max(hi[0], p.wx[i]);
      lo[1] = std::min(lo[1], p.wy[i]), hi[1] = std::max(hi[1], p.wy[i]);
      zlo = std::min(zlo, p.z[i]), zhi = std::max(zhi, p.z[i]);
    }
    const dw::dem::RasterGrid g = dw::dem::alignedGridCovering(lo[0], lo[1], hi[0], hi[1], res);
    dw::dem::RasterGrid fg = g;
    fg.west = (g.west - p.off_x) / p.k, fg.north = (g.north - p.off_y) / p.k, fg.cell = g.cell / p.k;
    std::printf("input: %s, %zu points; grid %zu x %zu = %zu cells of %g; %u threads, best of %u\n",
                p.name.c_str(), m, g.cols, g.rows, g.size(), res, threads, repeats);

    const double nodata = -9999;
    std::vector<double> ours, theirs(g.size());
    double t_ours = HUGE_VAL, t_tin = 0, t_raster = 0, c_ours = HUGE_VAL;
    for (unsigned r = 0; r < repeats; ++r) {
      const double t0 = now(), c0 = cpuNow();
      dw::tin::TinOptions to;
      to.num_threads = threads;
      const auto tin = dw::tin::triangulate(p.fx.data(), p.fy.data(), m, to);
      const double t1 = now();
      dw::dem::TinRasterOptions ro;
      ro.nodata = nodata;
      ro.num_threads = threads;
      ours = dw::dem::rasterizeTin(p.fx.data(), p.fy.data(), p.z.data(), m, tin.triangles, fg, ro);
      const double t2 = now();
      c_ours = std::min(c_ours, cpuNow() - c0);
      if (t2 - t0 < t_ours) t_ours = t2 - t0, t_tin = t1 - t0, t_raster = t2 - t1;
    }
    std::printf("dw (triangulate + rasterise): wall %.3f s (%.3f + %.3f), cpu %.3f s\n", t_ours, t_tin,
                t_raster, c_ours);

    // GDAL on coordinates centred on the grid: on raw projected coordinates its qhull triangulation
    // overlaps itself (docs/dem.md), and the centring is outside the timing, as for us the frame.
    GDALAllRegister();
    CPLSetConfigOption("GDAL_NUM_THREADS", std::to_string(threads).c_str());
    const double cx = 0.5 * (g.west + g.east()), cy = 0.5 * (g.north + g.south());
    std::vector<double> gx(m), gy(m);
    for (std::size_t i = 0; i < m; ++i) gx[i] = p.wx[i] - cx, gy[i] = p.wy[i] - cy;
    GDALGridLinearOptions go;
    go.nSizeOfStructure = sizeof go;
    go.dfRadius = 0;
    go.dfNoDataValue = nodata;
    double t_gdal = HUGE_VAL, c_gdal = HUGE_VAL;
    for (unsigned r = 0; r < repeats; ++r) {
      const double t0 = now(), c0 = cpuNow();
      if (GDALGridCreate(GGA_Linear, &go, GUInt32(m), gx.data(), gy.data(), p.z.data(), g.west - cx,
                         g.east() - cx, g.north - cy, g.south() - cy, GUInt32(g.cols), GUInt32(g.rows),
                         GDT_Float64, theirs.data(), nullptr, nullptr) != CE_None)
        throw dw::Error(std::string("GDALGridCreate failed: ") + CPLGetLastErrorMsg());
      t_gdal = std::min(t_gdal, now() - t0);
      c_gdal = std::min(c_gdal, cpuNow() - c0);
    }
    std::printf("gdal (GDALGridCreate linear): wall %.3f s, cpu %.3f s\n", t_gdal, c_gdal);

    std::size_t both = 0, off = 0;
    double max_diff = 0;
    for (std::size_t i = 0; i < g.size(); ++i)
      if (ours[i] != nodata && theirs[i] != nodata) {
        ++both;
        const double d = std::fabs(ours[i] - theirs[i]);
        max_diff = std::max(max_diff, d);
        off += d > 1e-6 * (zhi - zlo);
      }
    std::printf("cells both define %zu; differing by more than 1e-6 of the z range %zu (max |diff| %.3g)\n",
                both, off, max_diff);
    std::printf("ratio gdal / dw: wall %.1fx, cpu %.1fx\n", t_gdal / t_ours, c_gdal / c_ours);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_dem_bench: %s\n", e.what());
    return 1;
  }
}
