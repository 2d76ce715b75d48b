# dw_tin_mpi on a pre-split set of LAS files (test_mpi's LasSplit helper writes three unequal parts of
# INPUT and two list files): the result must be the single-file result.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 300)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${ARGN} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "ok: ${ARGN}")
endfunction()

run(${CMAKE_COMMAND} -E env "DW_MPI_SPLIT=${INPUT}\;${WORK}" ${CHECKER} --gtest_filter=LasSplit.*)
foreach(f part0.las part1.las part2.las parts.txt shifted1.las shifted.txt)
  if(NOT EXISTS ${WORK}/${f})
    message(FATAL_ERROR "the split helper wrote no ${f}")
  endif()
endforeach()

foreach(np 2 4)
  run(${MPIEXEC} --oversubscribe -np ${np} ${APP} ${INPUT} --gather -o ${WORK}/whole_np${np}.ply --quiet)
  run(${MPIEXEC} --oversubscribe -np ${np} ${APP} --list ${WORK}/parts.txt --gather -o ${WORK}/parts_np${np}.ply
      --verify --quiet)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/whole_np${np}.ply ${WORK}/parts_np${np}.ply
                  RESULT_VARIABLE same)
  if(NOT same EQUAL 0)
    message(FATAL_ERROR "${np} ranks: the pre-split input gave another mesh than the single file")
  endif()
endforeach()

# Parts as positional arguments, one of them with another offset (scaled frame): pieces + manifest,
# compared with the single-process run of the same sequence by the independent Pieces checker.
run(${MPIEXEC} --oversubscribe -np 3 ${APP} ${WORK}/shifted0.las ${WORK}/shifted1.las ${WORK}/shifted2.las
    -o ${WORK}/shifted --verify --quiet)
run(${CMAKE_COMMAND} -E env DW_MPI_MANIFEST=${WORK}/shifted.manifest.json ${CHECKER} --gtest_filter=Pieces.*)

# A bad file in the set fails cleanly (non-zero exit, no manifest).
file(WRITE ${WORK}/bad.las "not a LAS file")
file(WRITE ${WORK}/bad.txt "part0.las\nbad.las\n")
execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${APP} --list ${WORK}/bad.txt -o ${WORK}/bad --quiet
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET TIMEOUT 300)
if(rc EQUAL 0 OR EXISTS ${WORK}/bad.manifest.json)
  message(FATAL_ERROR "a bad file in the input set did not fail cleanly (exit ${rc})")
endif()
