# cmake -P driver of python/InstalledPackageImports: `cmake --install` into a scratch prefix, then
# Debian's python3 imports fringe from <prefix>/FRINGE_PYTHON_INSTALL_DIR (the README's
# PYTHONPATH for a non-default prefix) and runs a call. Fails with the failing step's output.
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${FRINGE_BUILD_DIR} --prefix ${prefix}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}):\n${out}\n${err}")
endif()
set(site ${prefix}/${PYTHON_INSTALL_DIR})
foreach(f __init__.py __init__.pyi evaluate.pyi py.typed)
  if(NOT EXISTS ${site}/fringe/${f})
    message(FATAL_ERROR "cmake --install did not install ${site}/fringe/${f}")
  endif()
endforeach()
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${site} PYTHONNOUSERSITE=1 PYTHONDONTWRITEBYTECODE=1
          ${PYTHON} -c "import fringe; print(fringe.__file__); print(fringe.Rig.reference())"
  WORKING_DIRECTORY ${WORK_DIR}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "importing the installed package failed (${rc}):\n${out}\n${err}")
endif()
string(FIND "${out}" "${site}/fringe/__init__.py" at)
if(at EQUAL -1 OR NOT out MATCHES "fringe.Rig\\(1280x1024")
  message(FATAL_ERROR "python3 did not use the installed package: ${out}")
endif()
message(STATUS "${out}")
