# Precompiled headers for the project's own tests and programs. A cold build of the tests and
# programs parses the library's headers, OpenCV and doctest once per translation unit (about
# 13 s of one core for <shadowsense/shadowsense.hpp> alone); with a shared precompiled header
# they are parsed once per group. Consumers of the library are not affected: nothing here is
# part of the installed targets.
#
# shadowsense_pch_anchor(ANCHOR HEADERS... [LINK libs...])
#   makes ANCHOR, an object library of one empty source that owns the precompiled HEADERS and
#   is compiled with the usage requirements of LINK (the flags must match its users').
# shadowsense_use_pch(TARGET ANCHOR)
#   TARGET reuses ANCHOR's precompiled header (a target that defines a library macro before its
#   includes must not: the header would already be compiled without it).
#
# Off by default: measured on the README's build (Unix Makefiles, -j2, 2 cores, one tree) it
# saved 3% of the CPU time (1117 against 1153 s) and no wall time (603 against 592 s); one unit
# alone saves 8-11 s, but code generation, not parsing, dominates the heavy units.
option(SHADOWSENSE_PRECOMPILE_HEADERS
       "Precompile the library's headers once for the tests and once for the programs" OFF)

function(shadowsense_pch_anchor anchor)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "HEADERS;LINK")
  if(NOT SHADOWSENSE_PRECOMPILE_HEADERS)
    return()
  endif()
  add_library(${anchor} OBJECT ${PROJECT_SOURCE_DIR}/cmake/pch_anchor.cpp)
  target_link_libraries(${anchor} PRIVATE ${arg_LINK})
  target_compile_features(${anchor} PRIVATE cxx_std_20)
  target_precompile_headers(${anchor} PRIVATE ${arg_HEADERS})
endfunction()

function(shadowsense_use_pch target anchor)
  if(SHADOWSENSE_PRECOMPILE_HEADERS)
    set_target_properties(${target} PROPERTIES PRECOMPILE_HEADERS_REUSE_FROM ${anchor})
  endif()
endfunction()
