# Runs dw_tin_mpi in the ways that must succeed or fail, and checks the files it leaves:
#   1. 4 ranks, pieces: a manifest appears; test_mpi's Pieces test re-reads it and compares with the
#      single-process triangulation (independent of the app's own --verify).
#   2. the same prefix with a failing rank, then with a killed rank, then with a bad input file: non-zero
#      exit and the earlier manifest is gone (nothing claims completeness).
#   3. 3 ranks (not a power of two) with --gather --verify.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(prefix ${WORK}/tin)
set(manifest ${prefix}.manifest.json)

include(${CMAKE_CURRENT_LIST_DIR}/run_app_common.cmake)

run_app(TRUE 4 ${INPUT} -o ${prefix} --quiet)
expect_manifest(TRUE)
execute_process(COMMAND ${CMAKE_COMMAND} -E env DW_MPI_MANIFEST=${manifest} ${CHECKER} --gtest_filter=Pieces.*
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR out MATCHES "SKIPPED")
  message(FATAL_ERROR "re-reading the pieces failed (${rc}):\n${out}\n${err}")
endif()

foreach(fault fail:read:1 fail:merge:1 kill:leaf:2 fail:write:3 kill:merge:0)
  run_app(TRUE 4 ${INPUT} -o ${prefix} --quiet)
  expect_manifest(TRUE)
  run_app(FALSE 4 ${INPUT} -o ${prefix} --quiet --inject ${fault})
  expect_manifest(FALSE)
endforeach()

file(WRITE ${WORK}/not_a.las "this is not a LAS file")
run_app(TRUE 2 ${INPUT} -o ${prefix} --quiet)
run_app(FALSE 2 ${WORK}/not_a.las -o ${prefix} --quiet)
expect_manifest(FALSE)
run_app(FALSE 2 ${WORK}/missing.las -o ${prefix} --quiet)
expect_manifest(FALSE)

run_app(TRUE 3 ${INPUT} --gather -o ${WORK}/gathered.ply --verify --quiet)
if(NOT EXISTS ${WORK}/gathered.ply)
  message(FATAL_ERROR "--gather wrote no file")
endif()
