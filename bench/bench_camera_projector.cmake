# VDI/VDE 2634-2 figures in camera-projector mode (left camera + projector) beside stereo on the
# simulator's reference rig (issue 14).
fringe_add_bench(bench_camera_projector
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_camera_projector.cc
  DEPS fringe_stereo fringe_calib fringe_eval fringe_sim fringe_phase fringe_geometry fringe_util
       nlohmann_json::nlohmann_json)
