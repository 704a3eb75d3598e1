# Visual words (issue 4): descriptor quantisation (linear and tree), ORB, whole-frame extraction.
if(TARGET rost_vision)
  rost_add_bench(bench_vision SOURCES bench_vision.cpp LIBS rost::vision)
  target_compile_definitions(bench_vision PRIVATE ROST_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()
