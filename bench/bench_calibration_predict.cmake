# The predicted depth uncertainty of a calibrated pair (calib/diagnostics.h) against the spread of
# depth over repeated simulated calibrations.
if(TARGET fringe_sim AND TARGET fringe_calib)
  fringe_add_bench(bench_calibration_predict
    SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_calibration_predict.cc
    DEPS fringe_calib fringe_sim fringe_geometry fringe_util nlohmann_json::nlohmann_json)
endif()
