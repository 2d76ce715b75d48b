# dw_dem --tin writes the TIN of the whole cloud (several tiles) beside the raster; with --stream in
# at least MIN_STRIPS strips, the same triangles (test_ply_same_triangles: canonical sets of vertex
# coordinates) as in memory.
separate_arguments(args UNIX_COMMAND "${ARGS}")
separate_arguments(inputs UNIX_COMMAND "${IN}")
execute_process(COMMAND ${DEM} ${inputs} -o ${OUT}_mem.tif --tin ${OUT}_mem.ply ${args} --quiet
  RESULT_VARIABLE a OUTPUT_QUIET)
execute_process(COMMAND ${DEM} ${inputs} -o ${OUT}_str.tif --tin ${OUT}_str.ply ${args} --stream
  --memory-limit ${MB} --quiet RESULT_VARIABLE b OUTPUT_VARIABLE log)
if(NOT a EQUAL 0 OR NOT b EQUAL 0)
  message(FATAL_ERROR "dw_dem --tin exited ${a}, dw_dem --stream --tin ${b}: ${log}")
endif()
if(NOT log MATCHES "strips ([0-9]+)" OR CMAKE_MATCH_1 LESS ${MIN_STRIPS})
  message(FATAL_ERROR "fewer than ${MIN_STRIPS} strips: ${log}")
endif()
execute_process(COMMAND ${SAME} ${OUT}_mem.ply ${OUT}_str.ply RESULT_VARIABLE rc OUTPUT_VARIABLE same ERROR_VARIABLE same_err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the streamed TIN differs from the in-memory TIN (exit ${rc}): ${same}${same_err}")
endif()
message(STATUS "${same}${log}")
