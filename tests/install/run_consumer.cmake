# cmake -P driver of install/ConsumerFindsFringe (see CMakeLists.txt here). Fails with the
# failing step's output.
function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(STEP_OUTPUT "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
run_step("cmake --install" ${CMAKE_COMMAND} --install ${FRINGE_BUILD_DIR} --prefix ${prefix})
foreach(f include/fringe/geometry/triangle_mesh.h include/fringe/io/mesh_io.h
          lib/cmake/fringe/fringeConfig.cmake lib/cmake/fringe/fringeTargets.cmake)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "cmake --install did not install ${f}")
  endif()
endforeach()
run_step("configuring the consumer" ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR}
         -B ${WORK_DIR}/build -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release
         -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix}
         "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}")
run_step("building the consumer" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run_step("running the consumer" ${WORK_DIR}/build/fringe_consumer ${WORK_DIR})
if(NOT STEP_OUTPUT MATCHES "consumer ok: 8 triangles, 6 vertices")
  message(FATAL_ERROR "unexpected consumer output: ${STEP_OUTPUT}")
endif()
message(STATUS "${STEP_OUTPUT}")
