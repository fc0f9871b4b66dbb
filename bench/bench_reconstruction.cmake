# Accuracy (VDI/VDE 2634-2 figures, demo-part deviation, normals) and speed of one-view
# reconstruction on the simulator's reference rig; Open3D normals as a peer when installed.
set(FRINGE_BENCH_RECON_DEPS fringe_stereo fringe_eval fringe_sim fringe_calib fringe_phase
    fringe_io fringe_geometry fringe_util TBB::tbb nlohmann_json::nlohmann_json)
find_package(Open3D QUIET)
if(TARGET Open3D::Open3D)
  list(APPEND FRINGE_BENCH_RECON_DEPS Open3D::Open3D)
endif()
fringe_add_bench(bench_reconstruction SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_reconstruction.cc
  DEPS ${FRINGE_BENCH_RECON_DEPS})
if(TARGET bench_reconstruction AND TARGET Open3D::Open3D)
  target_compile_definitions(bench_reconstruction PRIVATE FRINGE_HAVE_OPEN3D=1)
endif()
