# Vision examples (issue 4). CI runs the curiosity example on a video file
# (diver.mov, fetched by the tests' footage fixture).
if(NOT TARGET rost_vision)
  return()
endif()
add_executable(example_02_curiosity 02_curiosity.cpp)
set_target_properties(example_02_curiosity PROPERTIES OUTPUT_NAME 02_curiosity)
target_link_libraries(example_02_curiosity PRIVATE rost::vision rost_warnings)
target_compile_definitions(example_02_curiosity PRIVATE ROST_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
if(ROST_BUILD_TESTS)
  # A short run: the first 60 frames of diver.mov.
  add_test(NAME example_02_curiosity_runs
           COMMAND example_02_curiosity ${PROJECT_SOURCE_DIR}/data/pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov 60)
  set_tests_properties(example_02_curiosity_runs PROPERTIES FIXTURES_REQUIRED rost_footage TIMEOUT 300
                       PASS_REGULAR_EXPRESSION "60 frames, [0-9]+ refined")
endif()
