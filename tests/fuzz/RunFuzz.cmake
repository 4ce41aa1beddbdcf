# cmake -P script run by ctest: builds the fuzz target with clang and runs it
# for a bounded time over the seed corpus (copied, so the tree stays clean).
file(MAKE_DIRECTORY ${WORK_DIR})
function(run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${step} failed (${rc}):\n${out}\n${err}")
  endif()
  set(last_err "${err}" PARENT_SCOPE)
endfunction()
run(configure ${CMAKE_COMMAND} -S ${SOURCE_DIR}/project -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo)
run(build ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${WORK_DIR}/corpus)
file(COPY ${SOURCE_DIR}/corpus/ DESTINATION ${WORK_DIR}/corpus)
run(fuzz ${WORK_DIR}/build/protocol_fuzz ${WORK_DIR}/corpus -max_total_time=${SECONDS} -max_len=4096
    -rss_limit_mb=1024 -print_final_stats=1)
string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${last_err}")
message(STATUS "fuzzed ${SECONDS} s without findings: ${runs}")
