# gonio_add_tests(LIBS lib... [LABELS l...] [TIMEOUT seconds])
# Every test_*.c in the calling folder becomes one cmocka executable and one
# ctest test. Tests find the shared data and the configs through the
# environment, so a test run from any directory sees the same files; a test
# that exits 77 is reported as skipped.
#
# Every test has a TIMEOUT, so that a hung test (or a helper it forked that
# holds ctest's output pipe) fails instead of stalling the suite.
# GONIO_UNIT_TIMEOUT holds for the slowest unit test under valgrind's
# memcheck on a loaded 2-core machine (make check-valgrind runs this build:
# test_study_run, test_merl and test_auto_model take 1.5-3 minutes there,
# docs/testing-memory.md); natively they take seconds.
set(GONIO_UNIT_TIMEOUT 900)
function(gonio_add_tests)
  cmake_parse_arguments(T "" "TIMEOUT" "LIBS;LABELS" ${ARGN})
  if(NOT T_LABELS)
    set(T_LABELS unit)
  endif()
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT ${GONIO_UNIT_TIMEOUT})
  endif()
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test_*.c)
  foreach(src ${sources})
    get_filename_component(name ${src} NAME_WE)
    add_executable(${name} ${src})
    set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
    target_link_libraries(${name} PRIVATE ${T_LIBS} PkgConfig::CMOCKA gonio_warnings)
    add_test(NAME ${name} COMMAND ${name})
    set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}"
      ENVIRONMENT "GONIO_SHARED=${GONIO_SHARED_DEFAULT};GONIO_CONFIG=${GONIO_CONFIG_DEFAULT};GONIO_BIN=${PROJECT_BINARY_DIR}/bin;GONIO_TMP=${PROJECT_BINARY_DIR}/tmp"
      SKIP_RETURN_CODE 77 TIMEOUT ${T_TIMEOUT})
  endforeach()
endfunction()
