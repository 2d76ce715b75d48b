# Installable CMake package: find_package(pcl_delaunay_walk) then link pcl_delaunay_walk::pcl_delaunay_walk.
include(CMakePackageConfigHelpers)

set(DW_INSTALL_TARGETS pcl_delaunay_walk_core)
foreach(t pcl_delaunay_walk pcl_delaunay_walk_gpu pcl_delaunay_walk_mpi)
  if(TARGET ${t})
    list(APPEND DW_INSTALL_TARGETS ${t})
  endif()
endforeach()

install(TARGETS ${DW_INSTALL_TARGETS} EXPORT pcl_delaunay_walkTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY include/pcl_delaunay_walk DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(EXISTS ${PROJECT_SOURCE_DIR}/gpu/include/pcl_delaunay_walk AND TARGET pcl_delaunay_walk_gpu)
  install(DIRECTORY gpu/include/pcl_delaunay_walk DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endif()

set(DW_CONFIG_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/pcl_delaunay_walk)
install(EXPORT pcl_delaunay_walkTargets NAMESPACE pcl_delaunay_walk:: DESTINATION ${DW_CONFIG_DIR})
configure_package_config_file(cmake/pcl_delaunay_walkConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfig.cmake INSTALL_DESTINATION ${DW_CONFIG_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/pcl_delaunay_walkConfigVersion.cmake DESTINATION ${DW_CONFIG_DIR})
install(FILES package.xml DESTINATION ${CMAKE_INSTALL_DATADIR}/pcl_delaunay_walk)
