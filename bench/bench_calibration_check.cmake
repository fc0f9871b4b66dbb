# Drift detection, the predicted uncertainty of a calibration and refinement of the rig from a
# scan against the simulator's truth (issue 26).
fringe_add_bench(bench_calibration_check
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_calibration_check.cc
  DEPS fringe_pipeline fringe_registration fringe_stereo fringe_calib fringe_sim fringe_phase
       fringe_geometry fringe_util nlohmann_json::nlohmann_json)
