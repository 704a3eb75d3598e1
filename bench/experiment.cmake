# The paper's experiment (section VII) and the scaling benchmark (issue 6).
# See bench/experiment/README.md.

find_package(CLI11 QUIET CONFIG)
if(NOT CLI11_FOUND AND NOT TARGET CLI11::CLI11)
  find_path(ROST_EXPERIMENT_CLI11_DIR CLI/CLI.hpp)
  if(ROST_EXPERIMENT_CLI11_DIR)
    add_library(CLI11::CLI11 INTERFACE IMPORTED)
    target_include_directories(CLI11::CLI11 INTERFACE ${ROST_EXPERIMENT_CLI11_DIR})
  endif()
endif()

# Scaling: cost per observation and refinement rate against K, words per
# frame and stream length (Google Benchmark, core only).
rost_add_bench(bench_scaling SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/scaling.cpp)

if(NOT TARGET CLI11::CLI11)
  message(STATUS "rost: CLI11 not found, rost_experiment is not built (install libcli11-dev)")
  return()
endif()

# The harness: calibration and online-versus-batch runs on cached word streams (core only).
add_library(rost_experiment_lib STATIC
  ${CMAKE_CURRENT_SOURCE_DIR}/experiment/dataset.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/experiment/harness.cpp)
target_include_directories(rost_experiment_lib PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/experiment)
target_link_libraries(rost_experiment_lib PUBLIC rost::core rost_internal PRIVATE rost_warnings)

add_executable(rost_experiment ${CMAKE_CURRENT_SOURCE_DIR}/experiment/main.cpp
                               ${CMAKE_CURRENT_SOURCE_DIR}/experiment/cli.cpp)
target_link_libraries(rost_experiment PRIVATE rost_experiment_lib CLI11::CLI11 rost_warnings)

# Word extraction from footage needs the vision library.
if(TARGET rost::vision)
  add_executable(rost_experiment_extract ${CMAKE_CURRENT_SOURCE_DIR}/experiment/extract.cpp)
  target_link_libraries(rost_experiment_extract PRIVATE rost_experiment_lib rost::vision CLI11::CLI11 rost_warnings)
endif()

# Checks of the harness's measurements (reproducibility, budget accounting,
# the instants at which perplexity is taken).
if(ROST_BUILD_TESTS AND COMMAND rost_add_test)
  # GoogleTest's imported targets are visible in tests/ only; look them up here too.
  if(NOT TARGET GTest::gtest)
    find_package(GTest QUIET)
  endif()
  if(TARGET GTest::gtest)
    rost_add_test(test_experiment SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/experiment/test_experiment.cpp
                  LIBS rost_experiment_lib)
  endif()
endif()
