# Capture on the loopback setup of the capture tests (fake GigE Vision cameras, Xvfb); runs in a
# private network namespace it enters itself (root).
if(TARGET fringe_capture AND FRINGE_BUILD_TESTS)
  find_package(X11 REQUIRED)
  fringe_add_bench(bench_capture
    SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_capture.cc
    DEPS fringe_capture fringe_testing_capture ${ARAVIS_LIBRARY} ${FRINGE_GLIB_LINK_LIBRARIES} X11::X11)
  if(TARGET bench_capture)
    target_include_directories(bench_capture SYSTEM PRIVATE ${ARAVIS_INCLUDE_DIR}
                               ${FRINGE_GLIB_INCLUDE_DIRS})
  endif()
endif()
