# Run at build time (see terrain_add_gtest_suites in cmake/TerrainTests.cmake): lists the tests of
# a GoogleTest executable and writes one CTest test per suite into CTEST_FILE.
#
# Inputs: TEST_EXECUTABLE, CTEST_FILE, TEST_TIMEOUT, WORKING_DIR.
execute_process(
  COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests
  WORKING_DIRECTORY "${WORKING_DIR}"
  OUTPUT_VARIABLE listing
  RESULT_VARIABLE listed
  TIMEOUT 60)
if(NOT listed EQUAL 0)
  message(FATAL_ERROR "${TEST_EXECUTABLE} --gtest_list_tests failed (${listed}):\n${listing}")
endif()
string(REPLACE ";" "\\;" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")
set(script "# Written by cmake/gtest_suites.cmake from ${TEST_EXECUTABLE}: one test per suite.\n")
foreach(line IN LISTS lines)
  # Suite lines start in column 0 and end in '.' (before an optional "# TypeParam = …" comment);
  # test lines are indented.
  if(line MATCHES "^([^ #][^ ]*)\\.( |$)")
    set(suite "${CMAKE_MATCH_1}")
    string(APPEND script
      "add_test([==[${suite}]==] [==[${TEST_EXECUTABLE}]==] [==[--gtest_filter=${suite}.*]==])\n"
      "set_tests_properties([==[${suite}]==] PROPERTIES TIMEOUT ${TEST_TIMEOUT} "
      "WORKING_DIRECTORY [==[${WORKING_DIR}]==])\n")
  endif()
endforeach()
file(WRITE "${CTEST_FILE}" "${script}")
