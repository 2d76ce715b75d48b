# Installable CMake package: find_package(pcl_delaunay_walk) then link pcl_delaunay_walk::pcl_delaunay_walk
# (or ::core, ::mpi, ::gpu, ::gdal). Only the public headers of the targets that were built are installed;
# private headers (src/) never are.
include(CMakePackageConfigHelpers)

set(DW_INSTALL_TARGETS pcl_delaunay_walk_core)
foreach(t pcl_delaunay_walk pcl_delaunay_walk_gpu pcl_delaunay_walk_mpi pcl_delaunay_walk_gdal)
  if(TARGET ${t})
    list(APPEND DW_INSTALL_TARGETS ${t})
  endif()
endforeach()

install(TARGETS ${DW_INSTALL_TARGETS} EXPORT pcl_delaunay_walkTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})

set(_dw_inc ${CMAKE_INSTALL_INCLUDEDIR}/pcl_delaunay_walk)
install(DIRECTORY include/pcl_delaunay_walk/core DESTINATION ${_dw_inc})
if(TARGET pcl_delaunay_walk)
  foreach(area search registration surface io)
    install(DIRECTORY include/pcl_delaunay_walk/${area} DESTINATION ${_dw_inc})
  endforeach()
endif()
if(TARGET pcl_delaunay_walk_mpi)
  install(DIRECTORY include/pcl_delaunay_walk/mpi DESTINATION ${_dw_inc})
endif()
# The GDAL layer (GeoTIFF/COG writer, LAS CRS to WKT, hillshade, VRT mosaic): a static library that
# links GDAL privately, so the config finds GDAL for the link (DW_WITH_GDAL below).
if(TARGET pcl_delaunay_walk_gdal)
  install(DIRECTORY include/pcl_delaunay_walk/gdal DESTINATION ${_dw_inc})
  set(DW_INSTALL_GDAL ON)
else()
  set(DW_INSTALL_GDAL OFF)
endif()
if(TARGET pcl_delaunay_walk_gpu)
  install(DIRECTORY gpu/include/pcl_delaunay_walk/gpu DESTINATION ${_dw_inc})
endif()

set(DW_CONFIG_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/pcl_delaunay_walk)
# The config's find_dependency(Qhull) only where the core links it.
if(TARGET Qhull::qhull_r)
  set(DW_WITH_QHULL ON)
else()
  set(DW_WITH_QHULL OFF)
endif()
install(EXPORT pcl_delaunay_walkTargets NAMESPACE pcl_delaunay_walk:: DESTINATION ${DW_CONFIG_DIR})
configure_package_config_file(cmake/pcl_delaunay_walkConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfig.cmake INSTALL_DESTINATION ${DW_CONFIG_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfigVersion.cmake DESTINATION ${DW_CONFIG_DIR})
install(FILES package.xml DESTINATION ${CMAKE_INSTALL_DATADIR}/pcl_delaunay_walk)
