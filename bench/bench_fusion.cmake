# Multi-view fusion of the simulated demo part: ours vs concatenation, voxel averaging, Open3D
# TSDF and Poisson on the concatenation (issue 12).
fringe_add_bench(bench_fusion SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_fusion.cc
  DEPS fringe_fusion fringe_registration fringe_stereo fringe_eval fringe_sim fringe_phase fringe_io
       fringe_geometry
       fringe_util TBB::tbb Open3D::Open3D CLI11::CLI11 nlohmann_json::nlohmann_json)
