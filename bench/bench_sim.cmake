if(TARGET fringe_sim AND TARGET fringe_phase)
  fringe_add_bench(bench_sim SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/bench_sim.cc
                   DEPS fringe_sim fringe_phase)
  find_package(Open3D QUIET)
  if(TARGET bench_sim AND Open3D_FOUND)
    target_link_libraries(bench_sim PRIVATE Open3D::Open3D)
    target_compile_definitions(bench_sim PRIVATE FRINGE_BENCH_HAVE_OPEN3D)
  endif()
endif()
