# The whole scanner on the demo scan (issue 13): simulate to PNGs on disk, then `fringe scan`'s
# library call, timed per stage, with accuracy against the simulator's truth.
fringe_add_bench(bench_pipeline SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_pipeline.cc
  DEPS fringe_pipeline fringe_eval fringe_sim fringe_io fringe_util CLI11::CLI11
       nlohmann_json::nlohmann_json TBB::tbb)
