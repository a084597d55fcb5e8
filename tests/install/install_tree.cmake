# `cmake --install` of the build folder into PREFIX (the fixture of the other install tests),
# then checks that everything the package promises is there: every program (one per
# examples/*.cpp) in bin/, the shipped model (byte-identical) and the documentation under
# share/shadowsense/, the pkg-config file, the CMake package and the headers; with PYTHON set
# (the Python module is built), `import shadowsense` from <PREFIX>/<PYTHON_DIR> as python/README.md
# documents it.
# Variables: SOURCE_DIR, BUILD_DIR, PREFIX, BINDIR, LIBDIR, DATADIR, INCLUDEDIR; PYTHON,
# PYTHON_DIR (optional).
include(${CMAKE_CURRENT_LIST_DIR}/common.cmake)
file(REMOVE_RECURSE ${PREFIX})
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX})

shadowsense_program_names(programs ${SOURCE_DIR})
set(expected "")
foreach(program IN LISTS programs)
  list(APPEND expected ${BINDIR}/${program})
endforeach()
file(GLOB docs RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/docs/*.md)
foreach(doc IN LISTS docs)
  list(APPEND expected ${DATADIR}/shadowsense/doc/${doc})
endforeach()
list(APPEND expected
  ${DATADIR}/shadowsense/models/default.ssm
  ${DATADIR}/shadowsense/doc/README.md
  ${DATADIR}/shadowsense/doc/LICENSE
  ${DATADIR}/pkgconfig/shadowsense.pc
  ${LIBDIR}/cmake/shadowsense/shadowsenseConfig.cmake
  ${LIBDIR}/cmake/shadowsense/shadowsenseConfigVersion.cmake
  ${LIBDIR}/cmake/shadowsense/shadowsenseTargets.cmake
  ${INCLUDEDIR}/shadowsense/shadowsense.hpp
  ${INCLUDEDIR}/shadowsense/train.hpp)
set(missing "")
foreach(file IN LISTS expected)
  if(NOT EXISTS ${PREFIX}/${file})
    string(APPEND missing "  ${file}\n")
  endif()
endforeach()
if(missing)
  message(FATAL_ERROR "cmake --install did not install:\n${missing}")
endif()
foreach(program IN LISTS programs)
  file(READ ${PREFIX}/${BINDIR}/${program} head LIMIT 4 HEX)
  if(NOT head STREQUAL "7f454c46") # an ELF executable, not a script or an empty file
    message(FATAL_ERROR "${PREFIX}/${BINDIR}/${program} is not an executable (${head})")
  endif()
endforeach()
file(SHA256 ${SOURCE_DIR}/models/default.ssm source_model)
file(SHA256 ${PREFIX}/${DATADIR}/shadowsense/models/default.ssm installed_model)
if(NOT source_model STREQUAL installed_model)
  message(FATAL_ERROR "the installed default.ssm differs from models/default.ssm")
endif()
if(PYTHON)
  foreach(file IN ITEMS __init__.py __init__.pyi py.typed)
    if(NOT EXISTS ${PREFIX}/${PYTHON_DIR}/shadowsense/${file})
      message(FATAL_ERROR "cmake --install did not install ${PYTHON_DIR}/shadowsense/${file}")
    endif()
  endforeach()
  # From another folder, so the source tree's python/ cannot be what is imported.
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${PREFIX}/${PYTHON_DIR}
                          ${PYTHON} -c "import shadowsense; print(shadowsense.__file__)"
                  WORKING_DIRECTORY ${PREFIX} RESULT_VARIABLE rc OUTPUT_VARIABLE where
                  ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT rc EQUAL 0 OR NOT where STREQUAL "${PREFIX}/${PYTHON_DIR}/shadowsense/__init__.py")
    message(FATAL_ERROR "import shadowsense from ${PREFIX}/${PYTHON_DIR} failed (${rc}): "
                        "${where}${err}")
  endif()
endif()
list(LENGTH programs n)
message(STATUS "installed into ${PREFIX}: ${n} programs, the model, ${docs}, pkg-config and CMake "
               "files")
