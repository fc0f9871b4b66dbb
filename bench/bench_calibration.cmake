# Board detection and stereo calibration on simulator images with ground truth, ours vs OpenCV
# (findCirclesGrid + calibrateCamera / stereoCalibrate) on the same images.
if(TARGET fringe_sim AND TARGET fringe_calib)
  fringe_add_bench(bench_calibration SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_calibration.cc
    DEPS fringe_calib fringe_sim fringe_geometry fringe_util nlohmann_json::nlohmann_json
         opencv_calib3d opencv_features2d)
endif()
