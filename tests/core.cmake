rost_add_test(test_core SOURCES test_config.cpp test_model.cpp test_kernel.cpp test_word_stream.cpp test_text_io.cpp)
# Statistical tests of the sampler (eq. 5, LDA at radius 0) and recovery of planted structure.
target_sources(test_core PRIVATE test_sampler.cpp test_recovery.cpp test_growth.cpp test_fixed_model.cpp test_merge.cpp test_concentration.cpp)
# The installed headers are the public API: no intrinsics headers, no src/ headers.
add_test(NAME public_headers_are_public
         COMMAND ${CMAKE_COMMAND} -DINCLUDE_DIR=${PROJECT_SOURCE_DIR}/include
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/check_public_headers.cmake)
