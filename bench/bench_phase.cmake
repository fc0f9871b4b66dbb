# OpenCV contrib's structured_light is the peer this benchmark measures against: without it
# (FRINGE_HAVE_OPENCV_CONTRIB off, see the top-level CMakeLists.txt) the benchmark is not built.
if(FRINGE_HAVE_OPENCV_CONTRIB)
  fringe_add_bench(bench_phase
    SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_phase.cc
            ${CMAKE_CURRENT_SOURCE_DIR}/phase_accuracy.cc
    DEPS fringe_phase fringe_io fringe_util fringe_testing opencv_structured_light opencv_phase_unwrapping
         TBB::tbb nlohmann_json::nlohmann_json)
elseif(FRINGE_BUILD_BENCH)
  message(STATUS "fringe: bench_phase skipped (needs OpenCV contrib structured_light)")
endif()
# The virtual-scanner case when the simulator module is built.
if(TARGET bench_phase AND TARGET fringe_sim)
  target_link_libraries(bench_phase PRIVATE fringe_sim)
  target_compile_definitions(bench_phase PRIVATE FRINGE_BENCH_HAS_SIM)
endif()
