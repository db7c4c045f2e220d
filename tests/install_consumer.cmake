# Installs mountcal into WORK_DIR/prefix, builds tests/consumer against it, and runs it.
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
    "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
run(${WORK_DIR}/build/core_consumer)
# The Python package from the install alone (PYTHONPATH names only the prefix's folder).
if(PYTHON)
  set(preload "")
  if(PYTHON_PRELOAD)  # a sanitizer build: the interpreter takes the sanitizers' runtime first
    set(preload LD_PRELOAD=${PYTHON_PRELOAD} ASAN_OPTIONS=detect_leaks=0)
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${prefix}/${PYTHON_DIR} PYTHONNOUSERSITE=1 ${preload}
                          ${PYTHON} -c "import mountcal; print(mountcal.__version__, mountcal.__file__)"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "^${VERSION} ${prefix}/${PYTHON_DIR}/mountcal/__init__.py$")
    message(FATAL_ERROR "import mountcal from the install failed (${rc}): ${out}\n${err}")
  endif()
  message(STATUS "python: ${out}")
endif()
