# Helpers shared by the tests/install/*.cmake scripts (cmake -P).
cmake_minimum_required(VERSION 3.20) # policies of this CMake (lists keep empty elements)

# run(<command...>): runs it, fails the test with its output unless it exits 0; leaves its
# stdout/stderr in run_out/run_err.
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGN}\nstdout:\n${out}\nstderr:\n${err}")
  endif()
  set(run_out "${out}" PARENT_SCOPE)
  set(run_err "${err}" PARENT_SCOPE)
endfunction()

# must_fail(<regex> <command...>): the command must exit non-zero with stdout+stderr matching
# <regex> (so it fails for the expected reason).
function(must_fail regex)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc EQUAL 0)
    message(FATAL_ERROR "expected to fail but succeeded: ${ARGN}\n${out}\n${err}")
  endif()
  if(NOT "${out}${err}" MATCHES "${regex}")
    message(FATAL_ERROR "failed, but not with '${regex}': ${ARGN}\nstdout:\n${out}\nstderr:\n"
                        "${err}")
  endif()
endfunction()

# must_contain(<text> <what> <needle>): fails unless <text> contains <needle> literally.
function(must_contain text what needle)
  string(FIND "${text}" "${needle}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${what}: expected to contain '${needle}', got:\n${text}")
  endif()
endfunction()

function(must_not_contain text what needle)
  string(FIND "${text}" "${needle}" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "${what}: must not contain '${needle}', got:\n${text}")
  endif()
endfunction()

# The program names the build installs: one ss_<name> per examples/<name>.cpp.
function(shadowsense_program_names out_var source_dir)
  file(GLOB sources ${source_dir}/examples/*.cpp)
  set(names "")
  foreach(source IN LISTS sources)
    get_filename_component(name ${source} NAME_WE)
    list(APPEND names ss_${name})
  endforeach()
  if(NOT names)
    message(FATAL_ERROR "no examples/*.cpp under ${source_dir}")
  endif()
  set(${out_var} ${names} PARENT_SCOPE)
endfunction()
