# One CTest test per GoogleTest suite.
#
# gtest_discover_tests registers every test case as a process of its own: 656 processes, each
# loading the test binary and, in the HTTP tests, starting a server that SetUpTestSuite means to
# share. Running a suite in one process is how the fixtures are written, and it took the dev
# preset's CTest time from 191 s to 123 s on two cores (TSan's from 75 s to 51 s). One case:
# `build/dev/tests/server_tests --gtest_filter=Suite.Case`.
include_guard(GLOBAL)

# Lists the suites of `target` after every build and registers "Suite" running
# `target --gtest_filter=Suite.*`, with TIMEOUT seconds for the whole suite.
#
# The test code itself (assertions, fixtures, harnesses) is compiled at -Og in the optimised
# presets: the README test on CI's two cores spends most of its time compiling, and the test
# files were half of the dev preset's compile (a fresh clone, two jobs on two cores: 741 s of
# 1 435 s at -O2, 511 s at -Og; one file alone, 23.5 s against 12–15 s). The libraries under
# test keep their preset's optimisation, and the Debug preset (asan) its -O0.
function(terrain_add_gtest_suites target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "TIMEOUT" "")
  target_compile_options(${target} PRIVATE $<$<NOT:$<CONFIG:Debug>>:-Og>)
  if(NOT arg_TIMEOUT)
    set(arg_TIMEOUT 300)
  endif()
  set(suites_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake")
  set(include_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_include.cmake")
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND "${CMAKE_COMMAND}" -D "TEST_EXECUTABLE=$<TARGET_FILE:${target}>"
            -D "CTEST_FILE=${suites_file}" -D "TEST_TIMEOUT=${arg_TIMEOUT}"
            -D "WORKING_DIR=${CMAKE_CURRENT_BINARY_DIR}"
            -P "${PROJECT_SOURCE_DIR}/cmake/gtest_suites.cmake"
    BYPRODUCTS "${suites_file}"
    VERBATIM)
  # Until the target is built, CTest reports it as a failing test instead of silently running
  # nothing.
  file(WRITE "${include_file}"
    "if(EXISTS [==[${suites_file}]==])\n"
    "  include([==[${suites_file}]==])\n"
    "else()\n"
    "  add_test([==[${target}_NOT_BUILT]==] [==[${target}_NOT_BUILT]==])\n"
    "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${include_file}")
endfunction()
