# Trust on a long mission (issue 7): checkpoints, configuration files, the
# topic model CSV, faults and overload, a short soak.
rost_add_test(test_checkpoint SOURCES test_checkpoint.cpp)
rost_add_test(test_config_file SOURCES test_config_file.cpp)
rost_add_test(test_faults SOURCES test_faults.cpp)
rost_add_test(test_soak SOURCES test_soak.cpp)
