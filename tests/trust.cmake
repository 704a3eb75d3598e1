# Trust on a long mission (issue 7): checkpoints, configuration files, the
# topic model CSV, faults and overload, a short soak.
rost_add_test(test_checkpoint SOURCES test_checkpoint.cpp test_checkpoint_golden.cpp)
# Golden checkpoints written by earlier builds (test_checkpoint_golden.cpp).
target_compile_definitions(test_checkpoint PRIVATE ROST_TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/data")
rost_add_test(test_config_file SOURCES test_config_file.cpp test_settings.cpp)
rost_add_test(test_faults SOURCES test_faults.cpp TIMED)
rost_add_test(test_soak SOURCES test_soak.cpp TIMED)

# The rost tool's mission options (--checkpoint, --config); built with the tool.
if(TARGET rost AND COMMAND rost_add_vision_test)
  rost_add_vision_test(test_tool_trust SOURCES test_tool_trust.cpp LIBS rost::vision)
  add_dependencies(test_tool_trust rost)
endif()
