// raster_from_tin(): the TIN-linear DEM of NumPy points (dw::dem::rasterizeTin over dw::tin's
// triangulation) as a 2D array and its GDAL geotransform; with the GDAL adapter, write_dem() writes a
// raster (or the DEM of points, as dw_dem does) as a GeoTIFF/COG through dw::gdal::GeoTiffWriter, and
// las_crs_wkt() reads a LAS file's CRS as dw_dem does. Long calls run with the GIL released.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "pcl_delaunay_walk/core/dem/raster_grid.h"
#include "pcl_delaunay_walk/core/dem/tin_raster.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

#ifdef DW_PY_WITH_GDAL
#include "pcl_delaunay_walk/core/las/las_crs.h"
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#include "pcl_delaunay_walk/gdal/hillshade.h"
#include "pcl_delaunay_walk/gdal/las_srs.h"
#endif

namespace dw_py {

namespace {

using py_tuple6 = std::tuple<double, double, double, double, double, double>;

py_tuple6 geotransformOf(const dw::dem::RasterGrid& g) {
  return {g.west, g.cell, 0.0, g.north, 0.0, -g.cell};
}

/// A DEM of points: the grid, its cells (row 0 north) and what the rasteriser counted.
struct Dem {
  dw::dem::RasterGrid grid;
  std::vector<double> cells;
  dw::dem::TinRasterStats stats;
};

/// The inputs of raster_from_tin, read and checked with the GIL held.
struct DemInput {
  std::vector<double> x, y, value;
  std::vector<dw::index_t> triangles;
  bool have_triangles = false;
  bool has_bounds = false;
  double bounds[4] = {0, 0, 0, 0};
  double resolution = 0;
  dw::dem::TinRasterOptions raster;
};

DemInput demInput(py::handle points, double resolution, py::handle bounds, double max_edge, double nodata,
                  py::handle values, py::handle triangles, unsigned threads) {
  const Points p = pointsArg(points, "points", 2, 3);
  DemInput in;
  if (!(resolution > 0) || std::isinf(resolution))
    throw py::value_error("resolution must be positive and finite");
  if (!(max_edge >= 0)) throw py::value_error("max_edge must be >= 0 (inf: no limit)");
  if (std::isnan(nodata))
    throw py::value_error("nodata must be a number (GeoTIFF readers compare cells to it)");
  in.resolution = resolution;
  in.raster.max_edge = std::isinf(max_edge) ? 0.0 : max_edge;  // the library's "no limit"
  in.raster.nodata = nodata;
  in.raster.num_threads = threads;
  const int cols = static_cast<int>(p.array.shape(1));
  in.x.resize(p.n), in.y.resize(p.n), in.value.resize(p.n);
  for (std::size_t i = 0; i < p.n; ++i) {
    in.x[i] = p.is_double ? p.at<double>(i, 0) : p.at<float>(i, 0);
    in.y[i] = p.is_double ? p.at<double>(i, 1) : p.at<float>(i, 1);
    if (cols == 3) in.value[i] = p.is_double ? p.at<double>(i, 2) : p.at<float>(i, 2);
  }
  if (!values.is_none()) {
    const auto v = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
    if (!v || v.ndim() != 1 || static_cast<std::size_t>(v.shape(0)) != p.n)
      throw py::value_error("values must have shape (" + std::to_string(p.n) + ",)");
    std::copy(v.data(), v.data() + p.n, in.value.begin());
  } else if (cols != 3) {
    throw py::value_error("(n, 2) points need values= (what is interpolated)");
  }
  if (!bounds.is_none()) {
    const std::vector<double> b = py::cast<std::vector<double>>(bounds);
    if (b.size() != 4) throw py::value_error("bounds must be (xmin, ymin, xmax, ymax)");
    std::copy(b.begin(), b.end(), in.bounds);
    in.has_bounds = true;
  }
  if (!triangles.is_none()) {
    const py::array a = py::array::ensure(triangles);
    if (!a || (a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
      throw py::type_error("triangles must be an integer array (what tin() returns)");
    if (a.ndim() != 2 || a.shape(1) != 3)
      throw py::value_error("triangles must have shape (t, 3), got " + shapeText(a));
    const auto t = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
    in.triangles.resize(static_cast<std::size_t>(t.size()));
    for (std::size_t i = 0; i < in.triangles.size(); ++i) {
      const std::int64_t v = t.data()[i];
      if (v < 0 || static_cast<std::size_t>(v) >= p.n)
        throw py::value_error("triangles: index " + std::to_string(v) +
                              " is not a point index (n = " + std::to_string(p.n) + ")");
      in.triangles[i] = static_cast<dw::index_t>(v);
    }
    in.have_triangles = true;
  }
  return in;
}

/// The grid of `in`: its bounds, or the resolution-aligned box of the finite points (dw_dem's default).
dw::dem::RasterGrid gridOf(const DemInput& in) {
  dw::dem::RasterGrid g;
  if (in.has_bounds) {
    g = dw::dem::gridFromBounds(in.bounds[0], in.bounds[1], in.bounds[2], in.bounds[3], in.resolution);
  } else {
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
    for (std::size_t i = 0; i < in.x.size(); ++i) {
      if (!std::isfinite(in.x[i]) || !std::isfinite(in.y[i])) continue;
      lo[0] = std::min(lo[0], in.x[i]), hi[0] = std::max(hi[0], in.x[i]);
      lo[1] = std::min(lo[1], in.y[i]), hi[1] = std::max(hi[1], in.y[i]);
    }
    if (!(lo[0] <= hi[0]))
      throw dw::Error("raster_from_tin: no finite points to take the bounds from (pass bounds=)");
    g = dw::dem::alignedGridCovering(lo[0], lo[1], hi[0], hi[1], in.resolution);
  }
  if (g.cols > 2147483647u || g.rows > 2147483647u || g.size() > (std::size_t(1) << 32))
    throw dw::Error("a raster of " + std::to_string(g.cols) + " x " + std::to_string(g.rows) +
                    " cells is too large to hold in memory (at most 2^32 cells); choose a coarser "
                    "resolution or smaller bounds");
  return g;
}

/// Triangulates (unless given triangles) and rasterises; runs without the GIL.
Dem rasterize(DemInput& in) {
  Dem d;
  d.grid = gridOf(in);
  if (!in.have_triangles) {
    dw::tin::TinOptions to;
    to.num_threads = in.raster.num_threads;
    in.triangles = dw::tin::triangulate(in.x.data(), in.y.data(), in.x.size(), to).triangles;
  }
  d.cells = dw::dem::rasterizeTin(in.x.data(), in.y.data(), in.value.data(), in.x.size(), in.triangles,
                                  d.grid, in.raster, &d.stats);
  return d;
}

py::tuple rasterFromTin(py::handle points, double resolution, py::handle bounds, double max_edge,
                        double nodata, py::handle values, py::handle triangles, unsigned threads) {
  DemInput in = demInput(points, resolution, bounds, max_edge, nodata, values, triangles, threads);
  Dem d;
  {
    py::gil_scoped_release release;
    d = rasterize(in);
  }
  const auto rows = static_cast<py::ssize_t>(d.grid.rows), cols = static_cast<py::ssize_t>(d.grid.cols);
  return py::make_tuple(adopt(std::move(d.cells), {rows, cols}), geotransformOf(d.grid));
}

#ifdef DW_PY_WITH_GDAL

/// The grid of a north-up, square-celled GDAL geotransform (what dw::dem::RasterGrid describes).
dw::dem::RasterGrid gridOfGeotransform(py::handle gt_obj, std::size_t rows, std::size_t cols) {
  const std::vector<double> gt = py::cast<std::vector<double>>(gt_obj);
  if (gt.size() != 6) throw py::value_error("geotransform must have 6 numbers (GDAL's order)");
  for (double v : gt)
    if (!std::isfinite(v)) throw py::value_error("geotransform must be finite");
  if (!(gt[1] > 0) || gt[2] != 0 || gt[4] != 0 || gt[5] != -gt[1])
    throw py::value_error(
        "write_dem writes north-up rasters of square cells: geotransform must be (west, s, 0, north, 0, -s) "
        "with s > 0");
  dw::dem::RasterGrid g;
  g.west = gt[0], g.cell = gt[1], g.north = gt[3];
  g.rows = rows, g.cols = cols;
  return g;
}

py::dict writeDem(const std::string& path, py::handle data, py::handle geotransform, py::handle resolution,
                  py::handle bounds, double max_edge, double nodata, py::handle values, py::handle triangles,
                  py::handle crs_wkt, bool cog, bool float64, const std::string& compress, unsigned block,
                  py::handle hillshade, unsigned threads) {
  if (geotransform.is_none() == resolution.is_none())
    throw py::value_error(
        "write_dem takes a raster with geotransform=, or points with resolution= (exactly one of them)");
  dw::gdal::GeoTiffOptions tiff;
  tiff.cog = cog;
  tiff.float64 = float64;
  tiff.compress = compress;
  tiff.block = block;
  tiff.nodata = nodata;
  tiff.num_threads = threads;
  if (!crs_wkt.is_none()) tiff.srs_wkt = py::cast<std::string>(crs_wkt);
  const std::string shade = hillshade.is_none() ? std::string() : py::cast<std::string>(py::str(hillshade));
  if (std::isnan(nodata)) throw py::value_error("nodata must be a number");

  Dem d;
  py::array_t<double> raster;  // the caller's raster (kept alive while the GIL is released)
  DemInput in;
  const bool from_points = geotransform.is_none();
  if (from_points) {
    in = demInput(data, py::cast<double>(resolution), bounds, max_edge, nodata, values, triangles, threads);
  } else {
    if (!bounds.is_none() || !values.is_none() || !triangles.is_none() || !std::isinf(max_edge))
      throw py::value_error("bounds, values, triangles and max_edge belong to the points form (resolution=)");
    raster = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(data);
    const py::array a = py::array::ensure(data);
    if (!raster || !a || (a.dtype().kind() != 'f' && a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
      throw py::type_error("the raster must be a 2D array of numbers");
    if (raster.ndim() != 2 || raster.shape(0) == 0 || raster.shape(1) == 0)
      throw py::value_error("the raster must be a non-empty 2D array (rows, cols), got " + shapeText(raster));
    d.grid = gridOfGeotransform(geotransform, static_cast<std::size_t>(raster.shape(0)),
                                static_cast<std::size_t>(raster.shape(1)));
  }
  {
    py::gil_scoped_release release;
    if (from_points) d = rasterize(in);
    const double* cells = from_points ? d.cells.data() : raster.data();
    if (!from_points)
      d.stats.cells_set = static_cast<std::size_t>(
          std::count_if(cells, cells + d.grid.size(), [&](double v) { return v != nodata; }));
    dw::gdal::GeoTiffWriter writer(path, d.grid, tiff);
    writer.writeRows(0, d.grid.rows, cells);
    // The preview first, so that a failing preview keeps an existing DEM (as dw_dem).
    if (!shade.empty()) dw::gdal::writeHillshadePng(shade, d.grid, cells, nodata);
    writer.commit();
  }
  py::dict r;
  r["geotransform"] = geotransformOf(d.grid);
  r["shape"] = py::make_tuple(d.grid.rows, d.grid.cols);
  r["cells_set"] = d.stats.cells_set;
  r["triangles_killed"] = d.stats.triangles_killed;
  return r;
}

std::string lasCrsWkt(const std::string& path) {
  py::gil_scoped_release release;
  return dw::gdal::srsWktFromLas(dw::las::readLasCrs(path));
}

#endif

}  // namespace

void bindDem(py::module_& m) {
  const double inf = std::numeric_limits<double>::infinity();
  m.def("raster_from_tin", &rasterFromTin, py::arg("points"), py::arg("resolution"), py::kw_only(),
        py::arg("bounds") = py::none(), py::arg("max_edge") = inf, py::arg("nodata") = -9999.0,
        py::arg("values") = py::none(), py::arg("triangles") = py::none(), py::arg("threads") = 0u, R"doc(
TIN-linear DEM of (n, 3) points (x, y, z; or (n, 2) with values=): the Delaunay TIN in (x, y) (tin(),
or the given triangles) interpolated linearly at every cell centre (dw::dem::rasterizeTin, what dw_dem
writes). Returns (raster, geotransform): raster (rows, cols) float64, row 0 the northern row;
geotransform GDAL's (west, resolution, 0, north, 0, -resolution). bounds (xmin, ymin, xmax, ymax):
the raster's edges (default: the points' box widened to multiples of resolution). Cells outside the
hull or under a triangle with an (x, y) edge longer than max_edge are nodata. A centre on a shared
edge is owned by exactly one triangle, so the raster does not depend on threads.)doc");
#ifdef DW_PY_WITH_GDAL
  m.def("write_dem", &writeDem, py::arg("path"), py::arg("data"), py::kw_only(),
        py::arg("geotransform") = py::none(), py::arg("resolution") = py::none(),
        py::arg("bounds") = py::none(), py::arg("max_edge") = inf, py::arg("nodata") = -9999.0,
        py::arg("values") = py::none(), py::arg("triangles") = py::none(), py::arg("crs_wkt") = py::none(),
        py::arg("cog") = false, py::arg("float64") = false, py::arg("compress") = "DEFLATE",
        py::arg("block") = 0u, py::arg("hillshade") = py::none(), py::arg("threads") = 0u, R"doc(
Write a DEM as a tiled, compressed GeoTIFF (cog=True: a Cloud-Optimized GeoTIFF) through GDAL, under a
temporary name renamed over path when complete (a failure leaves an existing file untouched).
data is either a raster (rows, cols) with geotransform= (north-up, square cells, as raster_from_tin
returns; nodata= the value of its empty cells), or points with resolution= (and bounds, max_edge,
values, triangles as raster_from_tin): what dw_dem does. crs_wkt: the spatial reference as WKT (e.g.
las_crs_wkt(path)); float64: Float64 cells (else Float32); compress DEFLATE, LZW, ZSTD or NONE;
block: tile size (0: 256, COG 512); hillshade: also write a hillshade PNG there. Returns
{'geotransform', 'shape', 'cells_set', 'triangles_killed'}. Raises RasterError with GDAL's reason.)doc");
  m.def("las_crs_wkt", &lasCrsWkt, py::arg("path"), R"doc(
The coordinate reference system of a LAS/LAZ file as WKT (its OGC WKT record, else its GeoTIFF keys),
as dw_dem reads it; '' when the file has none.)doc");
#endif
}

}  // namespace dw_py
