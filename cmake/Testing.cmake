# Test and fuzz target helpers, used by tests/ and by each driver's tests/
# folder (io/drivers/<kind>/tests/).
if(RTPLC_BUILD_TESTS)
  include(GoogleTest)
  # What `ctest -L concurrency` runs, and the binary those tests start: the
  # ThreadSanitizer pass of scripts/test builds only this (its libraries are all
  # built anyway, each file on its own), not every other test and benchmark.
  add_custom_target(rtplc_concurrency_tests)
endif()
# rtplc_test(<name> SOURCES a.cpp ... LIBS lib ... [LABELS l ...] [ENV VAR=value ...] [SERIAL])
function(rtplc_test name)
  if(NOT RTPLC_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(T "SERIAL" "TIMEOUT" "SOURCES;LIBS;LABELS;ENV" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  set_target_properties(${name} PROPERTIES UNITY_BUILD OFF)
  if("concurrency" IN_LIST T_LABELS)
    add_dependencies(rtplc_concurrency_tests ${name})
  endif()
  target_link_libraries(${name} PRIVATE ${T_LIBS} GTest::gtest GTest::gtest_main GTest::gmock
                        rtplc_warnings Threads::Threads)
  target_compile_definitions(${name} PRIVATE RTPLC_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                             RTPLC_BINARY_DIR="${PROJECT_BINARY_DIR}")
  set(_serial FALSE)
  if(T_SERIAL)
    set(_serial TRUE)  # timing-sensitive: nothing else runs beside it
  endif()
  # gtest_discover_tests splits list-valued properties, so several labels become
  # one joined label ("runtime+concurrency"); `ctest -L concurrency` matches it
  # (labels are regular expressions). An empty value would swallow the next
  # property's name, so it is left out.
  string(REPLACE ";" "+" _labels "${T_LABELS}")
  set(_props RUN_SERIAL ${_serial})
  if(T_LABELS)
    list(APPEND _props LABELS "${_labels}")
  endif()
  if(T_ENV)
    string(REPLACE ";" "\\;" _env "${T_ENV}")
    list(APPEND _props ENVIRONMENT "${_env}")
  endif()
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${_props})
endfunction()

# libFuzzer targets (clang, -DRTPLC_BUILD_FUZZ=ON or the `fuzz` preset).
# rtplc_fuzzer(<name> SOURCES ... LIBS ...)
function(rtplc_fuzzer name)
  cmake_parse_arguments(F "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT RTPLC_BUILD_FUZZ)
    return()
  endif()
  add_executable(${name} ${F_SOURCES})
  set_target_properties(${name} PROPERTIES UNITY_BUILD OFF)
  target_compile_options(${name} PRIVATE -fsanitize=fuzzer,address,undefined)
  target_link_options(${name} PRIVATE -fsanitize=fuzzer,address,undefined)
  target_link_libraries(${name} PRIVATE ${F_LIBS})
endfunction()

