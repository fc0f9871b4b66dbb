# Multi-view registration of the simulated demo part against truth and Open3D, and the Stanford
# bunny (issue 11).
fringe_add_bench(bench_registration SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_registration.cc
  DEPS fringe_registration fringe_stereo fringe_eval fringe_sim fringe_phase fringe_io
       fringe_geometry fringe_util Open3D::Open3D CLI11::CLI11 nlohmann_json::nlohmann_json)
