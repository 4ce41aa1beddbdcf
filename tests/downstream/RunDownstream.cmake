# cmake -P script run by ctest; see CMakeLists.txt beside it.
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)

function(run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${step} failed (${rc}):\n${out}\n${err}")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

run(install ${CMAKE_COMMAND} --install ${AVATAR_BUILD_DIR} --prefix ${prefix})
run(configure ${CMAKE_COMMAND} -S ${PROJECT_DIR} -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release)
run(build ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(run ${WORK_DIR}/build/downstream)

set(expected "pair: group 2 member 5, 4x2 bayer RG 12-bit (owning)\nconfig round trip: identical\ntauunit: closed port gives ConnectionError for HELLO naming the endpoint\n")
if(NOT last_output STREQUAL expected)
  message(FATAL_ERROR "downstream program printed:\n${last_output}\nexpected:\n${expected}")
endif()
message(STATUS "downstream project built against ${prefix} and ran correctly")
