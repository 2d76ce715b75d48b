# Runs dw_tin (TIN) on LAZ and on its twin LAS with ARGS, and fails unless both PLY files are equal
# byte for byte, but for the input's name in the header's comment. Callers pass --threads 1: with
# several threads the triangles are the same set, but the order in which merges finish (and so the
# order of the faces in the file) can change from run to run.
foreach(kind LAZ LAS)
  execute_process(COMMAND ${TIN} ${${kind}} -o ${OUT}_${kind}.ply --quiet ${ARGS} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "dw_tin ${${kind}} failed (${rc}): ${out}")
  endif()
endforeach()
# The PLY header names its input ("comment dw_tin Delaunay TIN of NAME"); every other byte must match.
foreach(kind LAZ LAS)
  file(READ ${OUT}_${kind}.ply hex_${kind} HEX)
  get_filename_component(name ${${kind}} NAME)
  string(HEX "${name}" name_hex)
  string(REPLACE "${name_hex}" "" hex_${kind} "${hex_${kind}}")
endforeach()
if(NOT hex_LAZ STREQUAL hex_LAS)
  message(FATAL_ERROR "dw_tin wrote different PLY files for ${LAZ} and ${LAS}")
endif()
file(REMOVE ${OUT}_LAZ.ply ${OUT}_LAS.ply)
message(STATUS "same PLY for ${LAZ} and ${LAS}")
