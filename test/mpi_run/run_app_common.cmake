# Shared by the mpi_run scripts (included after `manifest` is set): runs the app under mpiexec expecting
# success or failure, and checks that a manifest exists exactly after a successful run.
get_filename_component(_app_name ${APP} NAME)

function(run_app expect_ok np)
  execute_process(COMMAND ${MPIEXEC} --oversubscribe -np ${np} ${APP} ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 300)
  if(expect_ok AND NOT rc EQUAL 0)
    message(FATAL_ERROR "${_app_name} ${ARGN} failed (${rc}):\n${out}\n${err}")
  endif()
  if(NOT expect_ok AND rc EQUAL 0)
    message(FATAL_ERROR "${_app_name} ${ARGN} should have failed but exited 0:\n${out}\n${err}")
  endif()
  message(STATUS "np ${np} ${ARGN}: exit ${rc}")
endfunction()

function(expect_manifest present)
  if(present AND NOT EXISTS ${manifest})
    message(FATAL_ERROR "no manifest after a successful run")
  endif()
  if(NOT present AND EXISTS ${manifest})
    message(FATAL_ERROR "a manifest claims completeness after a failed run")
  endif()
endfunction()
