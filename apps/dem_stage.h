/// \file dem_stage.h
/// \brief The DEM stage shared by dw_dem and `dw_tin --dem`: its command-line options, the grid in the
/// points' triangulation frame, TIN-linear rasterisation and the GeoTIFF (+ hillshade) output, written
/// safely (docs/dem.md). Needs the GDAL adapter.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "app_args.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/las/las_crs.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#include "pcl_delaunay_walk/gdal/hillshade.h"
#include "pcl_delaunay_walk/gdal/las_srs.h"

namespace dw_apps {

/// The DEM's options (docs/dem.md, "Using it").
struct DemOptions {
  std::string out, hillshade, value = "z";
  double resolution = 0, max_edge = 0;
  bool has_bounds = false;
  double bounds[4] = {0, 0, 0, 0};
  dw::gdal::GeoTiffOptions tiff;
};

inline double parseFinite(const std::string& opt, const char* v) {
  char* end = nullptr;
  const double x = std::strtod(v, &end);
  if (!end || end == v || *end || !std::isfinite(x))
    throw dw::Error("bad value '" + std::string(v) + "' for " + opt);
  return x;
}

/// If `a` is a DEM option, reads its values through `value()` into `d` and returns true.
inline bool parseDemOption(const std::string& a, const std::function<const char*()>& value, DemOptions& d) {
  if (a == "--resolution") {
    d.resolution = parseFinite(a, value());
    if (!(d.resolution > 0)) throw dw::Error("--resolution must be positive");
  } else if (a == "--bounds") {
    for (double& b : d.bounds) b = parseFinite(a, value());
    d.has_bounds = true;
  } else if (a == "--max-edge") {
    d.max_edge = parseNonNegative(value(), "--max-edge");
  } else if (a == "--value") {
    d.value = value();
    if (d.value != "z" && d.value != "intensity") throw dw::Error("--value must be z or intensity");
  } else if (a == "--nodata") {
    d.tiff.nodata = parseFinite(a, value());
  } else if (a == "--float64") {
    d.tiff.float64 = true;
  } else if (a == "--compress") {
    d.tiff.compress = value();
  } else if (a == "--cog") {
    d.tiff.cog = true;
  } else if (a == "--hillshade") {
    d.hillshade = value();
  } else {
    return false;
  }
  return true;
}

/// The triangulation frame of the points: world = frame * k + offset (LAS integers when the x and y
/// scales agree, docs/tin.md "Frames").
struct Frame {
  double k = 1, off_x = 0, off_y = 0;
};

/// What the DEM is interpolated from: the points in the triangulation frame (what the TIN was built
/// of), the value of each, and the world box of the points (the default grid covers it).
struct DemPoints {
  Frame frame;
  std::vector<double> x, y, value;
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  void extend(double wx, double wy) {
    lo[0] = std::min(lo[0], wx), hi[0] = std::max(hi[0], wx);
    lo[1] = std::min(lo[1], wy), hi[1] = std::max(hi[1], wy);
  }
};

/// A LAS cloud's DEM points; `value` is "z" or "intensity" (then `las` must keep its attributes).
inline DemPoints demPointsOfLas(const dw::las::LasCloud& las, const std::string& value) {
  const dw::las::LasHeader& h = las.header;
  DemPoints p;
  const bool same = h.scale[0] == h.scale[1];
  p.frame.k = same ? h.scale[0] : 1.0;
  p.frame.off_x = h.offset[0];
  p.frame.off_y = h.offset[1];
  const std::size_t n = las.size();
  p.x.resize(n), p.y.resize(n), p.value.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.x[i] = same ? double(las.X[i]) : las.X[i] * h.scale[0];
    p.y[i] = same ? double(las.Y[i]) : las.Y[i] * h.scale[1];
    p.value[i] = value == "z" ? las.z(i) : double(las.intensity[i]);
    p.extend(las.x(i), las.y(i));
  }
  return p;
}

/// The CRS of the first input as WKT (empty: none); a warning when another input's records differ
/// or when GDAL cannot read the records (then the raster gets no CRS).
inline std::string lasCrsWkt(const std::vector<std::string>& inputs, bool quiet) {
  std::string source, wkt;
  try {
    wkt = dw::gdal::srsWktFromLas(dw::las::readLasCrs(inputs[0]), &source);
    if (!quiet)
      std::fprintf(stderr, "coordinate system: %s\n", wkt.empty() ? "none in the file" : source.c_str());
    for (std::size_t i = 1; i < inputs.size(); ++i)
      if (dw::gdal::srsWktFromLas(dw::las::readLasCrs(inputs[i])) != wkt)
        std::fprintf(stderr, "warning: %s: another coordinate system than %s's; the raster takes %s's\n",
                     inputs[i].c_str(), inputs[0].c_str(), inputs[0].c_str());
  } catch (const dw::gdal::RasterError& e) {
    std::fprintf(stderr, "warning: %s; the raster gets no coordinate system\n", e.what());
    return std::string();
  }
  return wkt;
}

struct DemResult {
  dw::dem::RasterGrid grid;
  dw::dem::TinRasterStats stats;
  double raster_s = 0, write_s = 0;
};

/// The raster's grid: `--bounds`, or the aligned grid covering the world box [lo, hi] of the points.
/// Refuses a grid that cannot be held in memory as doubles (GDAL also takes int sizes).
inline dw::dem::RasterGrid demGrid(const DemOptions& d, const double lo[2], const double hi[2]) {
  const dw::dem::RasterGrid grid =
      d.has_bounds ? dw::dem::gridFromBounds(d.bounds[0], d.bounds[1], d.bounds[2], d.bounds[3], d.resolution)
                   : dw::dem::alignedGridCovering(lo[0], lo[1], hi[0], hi[1], d.resolution);
  if (grid.cols > 2147483647u || grid.rows > 2147483647u || grid.size() > (std::size_t(1) << 32))
    throw dw::Error(
        "a raster of " + std::to_string(grid.cols) + " x " + std::to_string(grid.rows) +
        " cells is too large to hold in memory (at most 2^32 cells); choose a coarser --resolution "
        "or smaller --bounds");
  return grid;
}

/// The same cells in the triangulation frame, computed in one place so that every tool samples a
/// cell at bit for bit the same point.
inline dw::dem::RasterGrid frameGrid(const dw::dem::RasterGrid& grid, const Frame& frame) {
  dw::dem::RasterGrid f = grid;
  f.west = (grid.west - frame.off_x) / frame.k;
  f.north = (grid.north - frame.off_y) / frame.k;
  f.cell = grid.cell / frame.k;
  return f;
}

/// The rasteriser's options in the frame's units.
inline dw::dem::TinRasterOptions rasterOptions(const DemOptions& d, const Frame& frame, unsigned threads) {
  dw::dem::TinRasterOptions ro;
  ro.max_edge = d.max_edge / frame.k;
  ro.nodata = d.tiff.nodata;
  ro.num_threads = threads;
  return ro;
}

/// Rasterises `tin` of the frame points (fx, fy) with per-point `value`s on the grid of `d` (or the
/// aligned grid covering the world box [lo, hi]), then writes the GeoTIFF (and the hillshade first, so
/// that a failing preview keeps an existing DEM), with the CRS `srs_wkt`.
inline DemResult writeDem(const DemOptions& d, const Frame& frame, const std::vector<double>& fx,
                          const std::vector<double>& fy, const std::vector<double>& value,
                          const dw::tin::TinResult& tin, const double lo[2], const double hi[2],
                          const std::string& srs_wkt, unsigned threads,
                          const std::function<void(const std::string&, double)>& progress) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  DemResult res;
  res.grid = demGrid(d, lo, hi);
  const dw::dem::RasterGrid& grid = res.grid;
  const dw::dem::RasterGrid fgrid = frameGrid(grid, frame);
  dw::dem::TinRasterOptions ro = rasterOptions(d, frame, threads);
  if (progress) ro.progress = [&](double f) { progress("raster", f); };
  const std::vector<double> raster = dw::dem::rasterizeTin(fx.data(), fy.data(), value.data(), fx.size(),
                                                           tin.triangles, fgrid, ro, &res.stats);
  const auto t1 = clock::now();
  res.raster_s = std::chrono::duration<double>(t1 - t0).count();

  dw::gdal::GeoTiffOptions tiff = d.tiff;
  tiff.srs_wkt = srs_wkt;
  tiff.num_threads = threads;
  dw::gdal::GeoTiffWriter writer(d.out, grid, tiff);
  const std::size_t band = 256;
  for (std::size_t r = 0; r < grid.rows; r += band) {
    writer.writeRows(r, std::min(band, grid.rows - r), raster.data() + r * grid.cols);
    if (progress) progress("write", double(std::min(grid.rows, r + band)) / double(grid.rows));
  }
  if (!d.hillshade.empty()) dw::gdal::writeHillshadePng(d.hillshade, grid, raster.data(), d.tiff.nodata);
  writer.commit();
  res.write_s = std::chrono::duration<double>(clock::now() - t1).count();
  return res;
}

/// The DEM stage of dw_dem and `dw_tin --dem` (in memory): `tin` was built of `p.x`, `p.y`.
inline DemResult writeDem(const DemOptions& d, const DemPoints& p, const dw::tin::TinResult& tin,
                          const std::string& srs_wkt, unsigned threads,
                          const std::function<void(const std::string&, double)>& progress) {
  return writeDem(d, p.frame, p.x, p.y, p.value, tin, p.lo, p.hi, srs_wkt, threads, progress);
}

}  // namespace dw_apps
