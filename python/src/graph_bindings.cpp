// DelaunayGraph: build from NumPy points (GIL released, builder threads), save/load, statistics, and
// read-only views of the arrays that keep the graph alive.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <memory>
#include <string>

#include "arrays.h"
#include "bindings.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"

namespace dw_py {

namespace {

dw::BuilderType parseBuilder(const std::string& name) {
  if (name == "auto") return dw::BuilderType::Auto;
  if (name == "qhull") return dw::BuilderType::Qhull;
  if (name == "incremental") return dw::BuilderType::Incremental;
  throw py::value_error("builder must be 'auto', 'qhull' or 'incremental', got '" + name + "'");
}

std::shared_ptr<dw::DelaunayGraph> build(py::handle points, unsigned threads, const std::string& builder) {
  Points p = pointsArg(points, "points");
  const dw::PointView view = pointView(p);
  dw::BuildOptions options;
  options.builder = parseBuilder(builder);
  options.num_threads = threads;
  py::gil_scoped_release release;
  return std::make_shared<dw::DelaunayGraph>(dw::buildDelaunayGraph(view, options));
}

/// A read-only view of one of the graph's arrays; `owner` (the Python graph) stays alive while it does.
template <typename T>
py::array view(const T* data, std::vector<py::ssize_t> shape, py::handle owner) {
  py::array a(py::dtype::of<typename std::remove_const<T>::type>(), shape, {}, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::dict degreeStatistics(const dw::DelaunayGraph& g) {
  std::size_t lo = 0, hi = 0;
  if (g.numVertices() > 0) {
    lo = g.degree(0);
    for (dw::index_t v = 0; v < g.numVertices(); ++v) {
      lo = std::min(lo, g.degree(v));
      hi = std::max(hi, g.degree(v));
    }
  }
  py::dict d;
  d["min"] = lo;
  d["max"] = hi;
  d["mean"] = g.numVertices() ? double(g.numDirectedEdges()) / double(g.numVertices()) : 0.0;
  return d;
}

}  // namespace

void bindGraph(py::module_& m) {
  py::class_<dw::DelaunayGraph, std::shared_ptr<dw::DelaunayGraph>> c(m, "DelaunayGraph", R"doc(
The walk graph of a reference cloud: Delaunay neighbourhoods in CSR form.

DelaunayGraph(points, threads=0, builder="auto") builds it from an (n, 3) float32/float64 array
(read in place when its rows are xyz-adjacent; NaN/Inf points are skipped, duplicates collapse onto one
vertex). Vertices are stored in a local float frame relative to `origin`.)doc");
  c.def(py::init(&build), py::arg("points"), py::arg("threads") = 0u, py::arg("builder") = "auto",
        "Build the graph (the GIL is released; threads=0 uses every hardware thread).");
  c.def(
      "save",
      [](const dw::DelaunayGraph& g, const std::string& path) {
        py::gil_scoped_release release;
        dw::saveGraph(g, path);
      },
      py::arg("path"), "Write the graph file (versioned, checksummed).");
  c.def_static(
      "load",
      [](const std::string& path, bool mapped) {
        py::gil_scoped_release release;
        return std::make_shared<dw::DelaunayGraph>(
            dw::loadGraph(path, mapped ? dw::GraphStorage::Mapped : dw::GraphStorage::Copied));
      },
      py::arg("path"), py::arg("mapped") = true,
      "Read a graph file, checksum verified and structure validated; a corrupt, truncated or foreign file "
      "raises GraphFileError. With mapped=True the edge records (most of the file) stay in a private "
      "memory map of the file that the graph keeps (is_mapped), not copied: the path may be removed or "
      "replaced afterwards, but the file must not be rewritten in place. mapped=False copies them.");
  c.def_property_readonly("is_mapped", &dw::DelaunayGraph::isMapped,
                          "True when the edge records are a view of the loaded file's memory map.");
  c.def("validate", &dw::DelaunayGraph::validate, py::arg("threads") = 0u,
        py::call_guard<py::gil_scoped_release>(),
        "Check every invariant on `threads` threads (0: all cores); raises Error naming the first broken "
        "one, the same for any thread count.");
  c.def_property_readonly("num_vertices", &dw::DelaunayGraph::numVertices, "Distinct finite points.");
  c.def_property_readonly("num_directed_edges", &dw::DelaunayGraph::numDirectedEdges);
  c.def_property_readonly(
      "num_edges", [](const dw::DelaunayGraph& g) { return g.numDirectedEdges() / 2; }, "Undirected edges.");
  c.def_property_readonly("num_input_points", &dw::DelaunayGraph::numInputPoints);
  c.def_property_readonly(
      "dimension", [](const dw::DelaunayGraph& g) { return g.dimension; },
      "Affine dimension of the vertices: 0, 1, 2 (coplanar) or 3.");
  c.def_property_readonly(
      "origin", [](const dw::DelaunayGraph& g) { return g.origin; },
      "The local frame's origin (world = origin + local).");
  c.def_property_readonly("memory_bytes", &dw::DelaunayGraph::memoryBytes);
  c.def("degree_statistics", &degreeStatistics, "Vertex degrees: {'min', 'max', 'mean'}.");
  c.def_property_readonly(
      "points",
      [](py::object self) {
        const auto& g = self.cast<const dw::DelaunayGraph&>();
        return view(reinterpret_cast<const float*>(g.points.data()),
                    {static_cast<py::ssize_t>(g.numVertices()), 3}, self);
      },
      "Vertex positions in the local frame, (num_vertices, 3) float32, a read-only view.");
  c.def_property_readonly(
      "input_to_vertex",
      [](py::object self) {
        const auto& g = self.cast<const dw::DelaunayGraph&>();
        return view(g.input_to_vertex.data(), {static_cast<py::ssize_t>(g.numInputPoints())}, self);
      },
      "Vertex of each input point (uint32; 4294967295 for a skipped NaN/Inf point), a read-only view.");
  c.def("__repr__", [](const dw::DelaunayGraph& g) {
    return "<DelaunayGraph " + std::to_string(g.numVertices()) + " vertices, " +
           std::to_string(g.numDirectedEdges() / 2) + " edges, dimension " + std::to_string(g.dimension) +
           ">";
  });
}

}  // namespace dw_py
