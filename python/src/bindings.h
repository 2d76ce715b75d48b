/// \file bindings.h
/// \brief The registration functions of the module's parts, one per concept, each in its own file.
#pragma once

#include <pybind11/pybind11.h>

namespace dw_py {

void bindGraph(pybind11::module_& m);   ///< DelaunayGraph (graph_bindings.cpp)
void bindSearch(pybind11::module_& m);  ///< NeighbourSearch (search_bindings.cpp)
void bindTinLas(pybind11::module_& m);  ///< tin(), read_las() (tin_las_bindings.cpp)
void bindIcp(pybind11::module_& m);     ///< icp() through the PCL layer (icp_bindings.cpp)
/// Localizer, SlidingWindowOdometry, FrameResult (localization_bindings.cpp)
void bindLocalization(pybind11::module_& m);
/// raster_from_tin(); write_dem(), las_crs_wkt() with the GDAL adapter (dem_bindings.cpp)
void bindDem(pybind11::module_& m);
/// _cpp_nearest_seconds, the C++ side of the overhead benchmark (reference_bindings.cpp)
void bindReference(pybind11::module_& m);

}  // namespace dw_py
