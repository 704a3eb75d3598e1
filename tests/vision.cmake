# Vision, frame sources and the rost tool (issue 4). Built when src/vision
# found OpenCV (target rost_vision).
if(NOT TARGET rost_vision)
  return()
endif()

# Real footage for the tests that need it: fetched once by a ctest fixture
# (scripts/fetch-footage.sh: `apt-get download` + `dpkg -x` into data/). Outside
# CI a failed fetch is not an error here: those tests then skip and say why.
# Under CI (CI=true) the fetch must work and the tests must run.
add_test(NAME vision_fetch_footage
         COMMAND sh -c "'${PROJECT_SOURCE_DIR}/scripts/fetch-footage.sh' visp-images-data pd-extendedview || [ \"$CI\" != true ]")
set_tests_properties(vision_fetch_footage PROPERTIES FIXTURES_SETUP rost_footage TIMEOUT 900)

# Like rost_add_test, with the footage fixture and the paths the tests need.
function(rost_add_vision_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE rost::core rost_internal GTest::gtest GTest::gtest_main rost_warnings ${ARG_LIBS})
  target_include_directories(${name} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_compile_options(${name} PRIVATE -UNDEBUG ${ROST_TESTS_OPT})
  target_compile_definitions(${name} PRIVATE ROST_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                                             $<$<TARGET_EXISTS:rost>:ROST_TOOL="$<TARGET_FILE:rost>">)
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 120 PROPERTIES TIMEOUT 900 FIXTURES_REQUIRED rost_footage)
endfunction()

rost_add_vision_test(test_vision
  SOURCES test_vision_vocabulary.cpp test_vision_words.cpp test_vision_pixel_format.cpp test_vision_sources.cpp
          test_vision_image_file.cpp
          test_vision_curiosity.cpp
  LIBS rost::vision)
if(TARGET rost)
  rost_add_vision_test(test_tool SOURCES test_tool_cli.cpp test_tool_end_to_end.cpp test_tool_picture.cpp
                       LIBS rost::vision rost_tool_lib)
  add_dependencies(test_tool rost)
  # Counts the threads a tool process starts (LD_PRELOAD). A sanitizer's
  # runtime must be the first library of a process, so not under one.
  if(NOT CMAKE_CXX_FLAGS MATCHES "-fsanitize")
    add_library(rost_test_count_threads MODULE count_threads_preload.cpp)
    target_link_libraries(rost_test_count_threads PRIVATE ${CMAKE_DL_LIBS} rost_warnings)
    target_compile_definitions(test_tool PRIVATE ROST_COUNT_THREADS="$<TARGET_FILE:rost_test_count_threads>")
    add_dependencies(test_tool rost_test_count_threads)
  endif()
endif()
# `rost --version`: the version and the commit the build was configured at.
if(TARGET rost)
  add_test(NAME tool_version COMMAND rost --version)
  set_tests_properties(tool_version PROPERTIES
    PASS_REGULAR_EXPRESSION "^rost ${PROJECT_VERSION} \\(git ([0-9a-f]+|unknown)\\)")
endif()
