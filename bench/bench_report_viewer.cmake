# The report's 3D view in headless chromium (issue 31): page size, load to first frame, frame time
# while orbiting, on the demo's report (`build/fringe demo --out build/demo` first). A node script
# (bench/bench_report_viewer.mjs; needs web/viewer/node_modules and chromium): `cmake --build
# build --target bench_report_viewer`, or run the script itself under benchlock.
if(FRINGE_BUILD_BENCH)
  find_program(FRINGE_NODE node)
  add_custom_target(bench_report_viewer
    COMMAND ${FRINGE_NODE} ${CMAKE_CURRENT_SOURCE_DIR}/bench_report_viewer.mjs
            ${PROJECT_BINARY_DIR}/demo/scan/report.html
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    USES_TERMINAL
    COMMENT "bench_report_viewer: the demo's report in headless chromium")
endif()
