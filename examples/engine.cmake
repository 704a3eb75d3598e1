# Realtime engine examples (issue 3). Each is also run by ctest when tests are built.
add_executable(example_01_replay 01_replay.cpp)
set_target_properties(example_01_replay PROPERTIES OUTPUT_NAME 01_replay)
target_link_libraries(example_01_replay PRIVATE rost::core rost_warnings)
if(ROST_BUILD_TESTS)
  add_test(NAME example_01_replay_runs COMMAND example_01_replay)
endif()
