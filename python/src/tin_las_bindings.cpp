// tin(): the parallel 2D Delaunay TIN of NumPy points; read_las(): a LAS file as NumPy arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <utility>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace dw_py {

namespace {

/// The triangulation reads x and y as two contiguous double arrays; an (n, 2|3) array never has that
/// layout, so the columns are copied (16 bytes a point) and handed over to the library.
py::array_t<dw::index_t> tin(py::handle points, unsigned threads, unsigned strips) {
  const Points p = pointsArg(points, "points", 2, 3);
  std::vector<double> x(p.n), y(p.n);
  for (std::size_t i = 0; i < p.n; ++i) {
    x[i] = p.is_double ? p.at<double>(i, 0) : p.at<float>(i, 0);
    y[i] = p.is_double ? p.at<double>(i, 1) : p.at<float>(i, 1);
  }
  dw::tin::TinOptions options;
  options.num_threads = threads;
  options.num_strips = strips;
  dw::tin::TinResult r;
  {
    py::gil_scoped_release release;
    r = dw::tin::triangulate(std::move(x), std::move(y), options);
  }
  const auto t = static_cast<py::ssize_t>(r.numTriangles());
  return adopt(std::move(r.triangles), {t, 3});
}

py::dict readLas(const std::string& path, int classification, bool attributes) {
  dw::las::LasReadOptions options;
  options.classification = classification;
  options.keep_attributes = attributes;
  dw::las::LasCloud c;
  {
    py::gil_scoped_release release;
    c = dw::las::readLasFile(path, options);
  }
  const auto n = static_cast<py::ssize_t>(c.size());
  py::array_t<double> xyz({n, py::ssize_t(3)});
  double* out = xyz.mutable_data();
  for (std::size_t i = 0; i < c.size(); ++i)
    out[3 * i] = c.x(i), out[3 * i + 1] = c.y(i), out[3 * i + 2] = c.z(i);
  py::dict d;
  d["xyz"] = xyz;
  const dw::las::LasHeader& h = c.header;
  d["scale"] = py::make_tuple(h.scale[0], h.scale[1], h.scale[2]);
  d["offset"] = py::make_tuple(h.offset[0], h.offset[1], h.offset[2]);
  d["version"] = py::make_tuple(int(h.version_major), int(h.version_minor));
  d["point_format"] = int(h.point_format);
  d["point_count"] = h.point_count;
  if (attributes) {
    d["classification"] = adopt(std::move(c.classification), {n});
    d["intensity"] = adopt(std::move(c.intensity), {n});
    d["return_number"] = adopt(std::move(c.return_number), {n});
  }
  return d;
}

}  // namespace

void bindTinLas(py::module_& m) {
  m.def("tin", &tin, py::arg("points"), py::arg("threads") = 0u, py::arg("strips") = 0u, R"doc(
Delaunay triangulation in (x, y) of an (n, 2) or (n, 3) float array (z is ignored): triangles as input
index triples, (t, 3) uint32, counter-clockwise. Duplicates appear as their smallest input index, NaN/Inf
points are skipped; the triangles do not depend on threads or strips. Pass georeferenced data in a
centred frame (subtract the tile's offset) so the exact predicates stay rare.)doc");
  m.def("read_las", &readLas, py::arg("path"), py::arg("classification") = -1, py::arg("attributes") = true,
        R"doc(
Read an uncompressed LAS 1.0-1.4 file: {'xyz': (n, 3) float64 world coordinates, 'classification',
'intensity', 'return_number' (when attributes), 'scale', 'offset', 'version', 'point_format',
'point_count'}. classification >= 0 keeps only that class (2: ground). Raises LasError on a corrupt,
truncated or compressed (LAZ) file.)doc");
}

}  // namespace dw_py
