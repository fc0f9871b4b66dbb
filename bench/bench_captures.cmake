# Issue 10's figures on captures as they come: matching coverage at low phase gradients
# (simulated view, and the real stereo capture when ../shared/data is present) and the 8- vs
# 12-bit comparison on the simulator's demo part.
fringe_add_bench(bench_captures SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_captures.cc
  DEPS fringe_stereo fringe_sim fringe_phase fringe_io fringe_geometry fringe_util fringe_testing
       nlohmann_json::nlohmann_json)
