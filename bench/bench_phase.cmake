fringe_add_bench(bench_phase SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_phase.cc
  DEPS fringe_phase fringe_io fringe_util opencv_structured_light opencv_phase_unwrapping
       TBB::tbb nlohmann_json::nlohmann_json)
# The virtual-scanner case when the simulator module is built.
if(TARGET bench_phase AND TARGET fringe_sim)
  target_link_libraries(bench_phase PRIVATE fringe_sim)
  target_compile_definitions(bench_phase PRIVATE FRINGE_BENCH_HAS_SIM)
endif()
