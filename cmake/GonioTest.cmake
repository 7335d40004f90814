# gonio_add_tests(LIBS lib... [LABELS l...])
# Every test_*.c in the calling folder becomes one cmocka executable and one
# ctest test. Tests find the shared data and the configs through the
# environment, so a test run from any directory sees the same files; a test
# that exits 77 is reported as skipped.
function(gonio_add_tests)
  cmake_parse_arguments(T "" "" "LIBS;LABELS" ${ARGN})
  if(NOT T_LABELS)
    set(T_LABELS unit)
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
      SKIP_RETURN_CODE 77)
  endforeach()
endfunction()
