fringe_add_bench(bench_phase SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_phase.cc
  DEPS fringe_phase fringe_io fringe_util opencv_structured_light opencv_phase_unwrapping
       TBB::tbb nlohmann_json::nlohmann_json)
