# Runs dw_graph_mpi in the ways that must succeed or fail, and checks the files it leaves:
#   1. 3 ranks, pieces: a manifest appears; test_mpi's GraphPieces test re-reads the pieces and compares
#      the assembled graph with dw::buildDelaunayGraph (independent of the app's own --verify).
#   2. the same prefix with a failing rank, a killed rank, and bad input: non-zero exit, and the earlier
#      manifest is gone (nothing claims completeness).
#   3. a flat cloud (the degenerate path: rank 0 builds it alone), pieces and --verify.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(prefix ${WORK}/graph)
set(manifest ${prefix}.manifest.json)

include(${CMAKE_CURRENT_LIST_DIR}/run_app_common.cmake)

function(check_pieces input)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env DW_MPI_GRAPH_MANIFEST=${manifest} DW_MPI_GRAPH_INPUT=${input}
                  ${CHECKER} --gtest_filter=GraphPieces.ManifestPiecesEqualSingleProcessGraph
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR out MATCHES "SKIPPED")
    message(FATAL_ERROR "re-reading the graph pieces failed (${rc}):\n${out}\n${err}")
  endif()
endfunction()

run_app(TRUE 3 ${INPUT} --pieces ${prefix} --quiet)
expect_manifest(TRUE)
check_pieces(${INPUT})

foreach(fault fail:read:1 fail:sort:2 kill:block:1 fail:grow:0 kill:grow:2 fail:write:1)
  run_app(TRUE 3 ${INPUT} --pieces ${prefix} --quiet)
  expect_manifest(TRUE)
  run_app(FALSE 3 ${INPUT} --pieces ${prefix} --quiet --inject ${fault})
  expect_manifest(FALSE)
endforeach()

file(WRITE ${WORK}/not_a.ply "this is not a PLY file")
run_app(TRUE 2 ${INPUT} --pieces ${prefix} --quiet)
run_app(FALSE 2 ${WORK}/not_a.ply --pieces ${prefix} --quiet)
expect_manifest(FALSE)
run_app(FALSE 2 ${WORK}/missing.ply --pieces ${prefix} --quiet)
expect_manifest(FALSE)
run_app(FALSE 2 ${INPUT} --quiet)  # no output named: usage error

# A flat 30 x 30 grid (coplanar, cocircular everywhere): the degenerate path, as pieces and gathered.
set(grid "ply\nformat ascii 1.0\nelement vertex 900\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
foreach(i RANGE 29)
  foreach(j RANGE 29)
    string(APPEND grid "${i} ${j} 0\n")
  endforeach()
endforeach()
file(WRITE ${WORK}/flat.ply "${grid}")
run_app(TRUE 2 ${WORK}/flat.ply --pieces ${prefix} --quiet)
check_pieces(${WORK}/flat.ply)
run_app(TRUE 3 ${WORK}/flat.ply -o ${WORK}/flat.graph --verify --quiet)
# The teapot (seam duplicates) with pieces.
run_app(TRUE 2 ${TEAPOT} --pieces ${prefix} --quiet)
check_pieces(${TEAPOT})

# A 16^3 integer grid plus repeated points: every cell of it is cospherical, so only the symbolic
# perturbation, keyed on the same global vertex ids on every rank, makes the blocks agree.
set(cube "")
set(count 0)
foreach(i RANGE 15)
  foreach(j RANGE 15)
    foreach(k RANGE 15)
      string(APPEND cube "${i} ${j} ${k}\n")
      math(EXPR count "${count} + 1")
    endforeach()
  endforeach()
endforeach()
string(APPEND cube "3 4 5\n0 0 0\n15 15 15\n")
math(EXPR count "${count} + 3")
file(WRITE ${WORK}/grid.ply
  "ply\nformat ascii 1.0\nelement vertex ${count}\nproperty float x\nproperty float y\nproperty float z\nend_header\n${cube}")
run_app(TRUE 3 ${WORK}/grid.ply -o ${WORK}/grid.graph --verify --quiet)
run_app(TRUE 4 ${WORK}/grid.ply -o ${WORK}/grid.graph --verify --quiet --cell-shift 0)
