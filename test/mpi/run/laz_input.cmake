# dw_tin_mpi on a LAZ file: the ranks split it at chunk boundaries (LasInputSet::alignToChunk), the LAS
# twin at equal shares. With 2 ranks, all points and --class 2, fixed and variable chunks: every run is
# --verify'd (its triangle set equals the single-process TIN of what it read; exit 3 otherwise), and
# the gathered PLY's header and vertices must equal the twin's byte for byte, so both runs read the
# same points and so have the same triangles. (The faces' order follows the ranks' shares, which differ.)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 300)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${ARGN} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "ok: ${ARGN}")
endfunction()

run(${GEN} -n 200k --seed 7 -o ${WORK}/t.las)
run(${GEN} -n 200k --seed 7 --chunk 30k -o ${WORK}/t.laz)
run(${GEN} -n 200k --seed 7 --chunk 30k --variable-chunks -o ${WORK}/tv.laz)
foreach(cls -1 2)
  run(${MPIEXEC} --oversubscribe -np 2 ${APP} ${WORK}/t.las --class ${cls} --gather -o ${WORK}/las_${cls}.ply
      --verify --quiet)
  foreach(laz t tv)
    run(${MPIEXEC} --oversubscribe -np 2 ${APP} ${WORK}/${laz}.laz --class ${cls} --gather
        -o ${WORK}/${laz}_${cls}.ply --verify --quiet)
    foreach(f las_${cls} ${laz}_${cls})
      file(READ ${WORK}/${f}.ply head LIMIT 600)
      string(FIND "${head}" "end_header\n" at)
      string(REGEX MATCH "element vertex ([0-9]+)" m "${head}")
      if(at LESS 0 OR NOT m)
        message(FATAL_ERROR "${f}.ply: no PLY header")
      endif()
      math(EXPR len "${at} + 11 + 24 * ${CMAKE_MATCH_1}")
      file(READ ${WORK}/${f}.ply hex_${f} LIMIT ${len} HEX)
      string(REGEX MATCH "element face ([0-9]+)" m "${head}")
      set(faces_${f} ${CMAKE_MATCH_1})
    endforeach()
    if(NOT hex_las_${cls} STREQUAL hex_${laz}_${cls} OR NOT faces_las_${cls} EQUAL faces_${laz}_${cls})
      message(FATAL_ERROR "2 ranks, --class ${cls}: ${laz}.laz gave other vertices or another face count "
                          "than its LAS twin")
    endif()
    message(STATUS "same ${faces_las_${cls}} faces over the same vertices: t.las and ${laz}.laz, --class ${cls}")
  endforeach()
endforeach()
file(REMOVE_RECURSE ${WORK})
