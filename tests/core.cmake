rost_add_test(test_core SOURCES test_config.cpp test_model.cpp test_kernel.cpp test_word_stream.cpp)
