// The module _native of the package pcl_delaunay_walk: the library's errors as Python exceptions, then
// one registration function per concept (graph, search, TIN + LAS, ICP, localization, DEM).
#include <pybind11/pybind11.h>

#include "bindings.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/las/las_format.h"
#ifdef DW_PY_WITH_GDAL
#include "pcl_delaunay_walk/gdal/geotiff_writer.h"
#endif

namespace py = pybind11;

PYBIND11_MODULE(_native, m) {
  m.doc() = "pcl_delaunay_walk native module: exact Delaunay-walk search, ICP and TINs from NumPy";
  // Registered base first: pybind11 tries the most recently registered translator first, so a
  // GraphFileError meets its own class before the base's.
  auto error = py::register_exception<dw::Error>(m, "Error", PyExc_RuntimeError);
  error.doc() = "Base of the library's errors (dw::Error); a RuntimeError.";
  py::register_exception<dw::GraphFileError>(m, "GraphFileError", error.ptr());
  py::register_exception<dw::las::LasError>(m, "LasError", error.ptr());
#ifdef DW_PY_WITH_GDAL
  py::register_exception<dw::gdal::RasterError>(m, "RasterError", error.ptr());
  m.attr("HAVE_GDAL") = true;
#else
  m.attr("HAVE_GDAL") = false;
#endif
  dw_py::bindGraph(m);
  dw_py::bindSearch(m);
  dw_py::bindTinLas(m);
  dw_py::bindLocalization(m);
  dw_py::bindDem(m);
  dw_py::bindReference(m);
#ifdef DW_PY_WITH_PCL
  dw_py::bindIcp(m);
  m.attr("HAVE_ICP") = true;
#else
  m.attr("HAVE_ICP") = false;
#endif
  // Whether the CUDA module (_gpu, a separate extension) was built; pcl_delaunay_walk.gpu checks the
  // device itself.
#ifdef DW_PY_WITH_GPU
  m.attr("HAVE_GPU") = true;
#else
  m.attr("HAVE_GPU") = false;
#endif
}
