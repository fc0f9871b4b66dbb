# Helpers shared by every module: one library target per module, one test binary per module
# whose tests are registered with CTest as "<module>/<Suite>.<Test>", benchmarks in build/bench/.

function(fringe_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-deprecated-enum-enum-conversion)
  if(FRINGE_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# fringe_add_library(<module> SOURCES a.cc b.cc DEPS fringe_util Eigen3::Eigen ...)
# The library is fringe_<module> in this build (alias fringe::<module>) and is installed with
# its headers (src/fringe/<module>/*.h without test helpers) as fringe::<module> in
# fringeTargets.cmake. Position-independent, so a shared library or a Python module can link it.
# Dependencies must be targets of this project or imported targets that fringeConfig.cmake
# finds (FRINGE_PACKAGE_DEPENDENCIES in the top-level CMakeLists.txt).
function(fringe_add_library module)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(fringe_${module} STATIC ${ARG_SOURCES})
  add_library(fringe::${module} ALIAS fringe_${module})
  set_target_properties(fringe_${module} PROPERTIES EXPORT_NAME ${module}
                                                    POSITION_INDEPENDENT_CODE ON)
  target_include_directories(fringe_${module} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(fringe_${module} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  fringe_set_warnings(fringe_${module})
  install(TARGETS fringe_${module} EXPORT fringeTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/
    DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/fringe/${module}
    FILES_MATCHING PATTERN "*.h"
    PATTERN "test_*.h" EXCLUDE
    PATTERN "*_test.h" EXCLUDE)
endfunction()

# fringe_add_tests(<module> SOURCES a_test.cc ... DEPS ...): one binary fringe_<module>_tests.
function(fringe_add_tests module)
  if(NOT FRINGE_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(target fringe_${module}_tests)
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE fringe_${module} fringe_test_main ${ARG_DEPS})
  fringe_set_warnings(${target})
  set_target_properties(${target} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
  gtest_discover_tests(${target}
    TEST_PREFIX "${module}/"
    DISCOVERY_MODE PRE_TEST
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES ENVIRONMENT "FRINGE_SOURCE_DIR=${PROJECT_SOURCE_DIR}")
endfunction()

# fringe_add_bench(<name> SOURCES ... DEPS ...): program build/bench/<name>, arguments parsed
# with CLI11 like the program's.
function(fringe_add_bench name)
  if(NOT FRINGE_BUILD_BENCH)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} CLI11::CLI11)
  fringe_set_warnings(${name})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bench)
endfunction()
