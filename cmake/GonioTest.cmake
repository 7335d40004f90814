# gonio_add_test(NAME SOURCES a.c [b.c] LIBS lib... [LABELS l...])
# One cmocka executable per test source, registered with ctest. Tests find
# the shared data and the configs through the environment, so a test run from
# any directory sees the same files.
function(gonio_add_test name)
  cmake_parse_arguments(T "" "" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
  target_link_libraries(${name} PRIVATE ${T_LIBS} PkgConfig::CMOCKA gonio_warnings)
  add_test(NAME ${name} COMMAND ${name})
  if(NOT T_LABELS)
    set(T_LABELS unit)
  endif()
  set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}"
    ENVIRONMENT "GONIO_SHARED=${GONIO_SHARED_DEFAULT};GONIO_CONFIG=${GONIO_CONFIG_DEFAULT};GONIO_BIN=${PROJECT_BINARY_DIR}/bin"
    SKIP_RETURN_CODE 77)
endfunction()
