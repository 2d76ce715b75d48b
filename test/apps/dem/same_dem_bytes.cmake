# `dw_tin --dem` and dw_dem share the DEM stage: on the same input and options they write the same
# GeoTIFF, byte for byte.
execute_process(COMMAND ${TIN} ${IN} --dem ${OUT}_tin.tif --resolution 2 --max-edge 30 --quiet RESULT_VARIABLE a)
execute_process(COMMAND ${DEM} ${IN} -o ${OUT}_dem.tif --resolution 2 --max-edge 30 --quiet RESULT_VARIABLE b)
if(NOT a EQUAL 0 OR NOT b EQUAL 0)
  message(FATAL_ERROR "dw_tin --dem exited ${a}, dw_dem ${b}")
endif()
file(SHA256 ${OUT}_tin.tif h1)
file(SHA256 ${OUT}_dem.tif h2)
if(NOT h1 STREQUAL h2)
  message(FATAL_ERROR "dw_tin --dem and dw_dem wrote different rasters")
endif()
message(STATUS "same raster ${h1}")
