# dw_tin_mpi --dem against the single-process dw_dem on the same input and options (ARGS, ';'-separated):
#   1. NP ranks write the tiles and the VRT; test_gdal's MpiDemMosaic checker reads the VRT back through
#      GDAL and compares it with dw_dem's GeoTIFF bit for bit (CRS, geotransform, nodata, every cell),
#      and checks each tile; gdalinfo reads the mosaic.
#   2. A run whose rank 1 fails after writing its tile (--inject fail:dem:1), with another resolution,
#      exits non-zero and leaves the VRT and every tile byte for byte, and no temporary file.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(APP ${TIN_MPI})
include(${CMAKE_CURRENT_LIST_DIR}/run_app_common.cmake)

execute_process(COMMAND ${DEM} ${INPUT} -o ${WORK}/single.tif ${ARGS} --quiet RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "dw_dem failed (${rc}): ${err}")
endif()
run_app(TRUE ${NP} ${INPUT} --dem ${WORK}/dem.vrt ${ARGS} --quiet)
execute_process(COMMAND ${CMAKE_COMMAND} -E env DW_MPI_DEM_VRT=${WORK}/dem.vrt
                DW_MPI_DEM_REFERENCE=${WORK}/single.tif DW_MPI_DEM_TILES=${NP}
                ${CHECKER} --gtest_filter=MpiDemMosaic.*
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR out MATCHES "SKIPPED")
  message(FATAL_ERROR "the mosaic differs from dw_dem's raster (${rc}):\n${out}\n${err}")
endif()
if(GDALINFO)
  execute_process(COMMAND ${GDALINFO} ${WORK}/dem.vrt RESULT_VARIABLE rc OUTPUT_VARIABLE out)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "Driver: VRT.*Origin = .*Pixel Size = .*NoData Value=-9999")
    message(FATAL_ERROR "gdalinfo does not read the mosaic (${rc}):\n${out}")
  endif()
endif()

file(GLOB before RELATIVE ${WORK} ${WORK}/dem.vrt ${WORK}/dem_tiles/*)
set(hashes "")
foreach(f ${before})
  file(SHA256 ${WORK}/${f} h)
  list(APPEND hashes "${f}=${h}")
endforeach()
set(other ${ARGS})
list(FIND other --resolution at)
math(EXPR at "${at} + 1")
list(REMOVE_AT other ${at})
list(INSERT other ${at} 3.5)
run_app(FALSE ${NP} ${INPUT} --dem ${WORK}/dem.vrt ${other} --quiet --inject fail:dem:1)
file(GLOB after RELATIVE ${WORK} ${WORK}/dem.vrt ${WORK}/dem_tiles/* ${WORK}/.* ${WORK}/dem_tiles/.*)
set(hashes_after "")
foreach(f ${after})
  file(SHA256 ${WORK}/${f} h)
  list(APPEND hashes_after "${f}=${h}")
endforeach()
if(NOT hashes STREQUAL hashes_after)
  message(FATAL_ERROR "a failed run changed the mosaic or left files:\nbefore ${hashes}\nafter  ${hashes_after}")
endif()
message(STATUS "mosaic of ${NP} tiles equals dw_dem's raster; a failed run kept it: ${before}")
