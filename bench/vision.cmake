# Visual words (issue 4).
# quantize_count: a plain program (vocabulary.cpp, zlib and the standard
# library only) that builds in cross builds too, for instruction counts on ARM.
find_package(ZLIB QUIET)
if(ZLIB_FOUND)
  add_executable(quantize_count quantize_count.cpp ${PROJECT_SOURCE_DIR}/src/vision/vocabulary.cpp)
  target_link_libraries(quantize_count PRIVATE rost::core rost_internal ZLIB::ZLIB rost_warnings)
else()
  message(STATUS "rost: zlib not found for the target, quantize_count is not built")
endif()
# bench_vision: descriptor quantisation (linear and tree), ORB, whole-frame extraction, training.
if(TARGET rost_vision AND COMMAND rost_add_bench)
  rost_add_bench(bench_vision SOURCES bench_vision.cpp LIBS rost::vision)
  target_compile_definitions(bench_vision PRIVATE ROST_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()
# bench_summary: drawing and writing summary.png (the end of `rost refine`).
if(TARGET rost_tool_words AND COMMAND rost_add_bench)
  rost_add_bench(bench_summary SOURCES bench_summary.cpp LIBS rost_tool_words)
endif()
