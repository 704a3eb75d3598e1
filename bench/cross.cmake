# ARM footprint (issue 5): memory of the model/engine for a configuration and a
# refinement loop for instruction counting (qemu plugin on ARM, callgrind on
# x86-64). A plain program, so it builds in cross builds too; see
# scripts/cross-footprint.sh and bench/RESULTS.md.
add_executable(footprint footprint.cpp)
target_link_libraries(footprint PRIVATE rost::core rost_internal rost_warnings)
if(EXISTS ${PROJECT_SOURCE_DIR}/src/core/engine.cpp)
  target_compile_definitions(footprint PRIVATE ROST_FOOTPRINT_ENGINE=1)
endif()
# `cmake --build <dir> --target footprint_report` prints the memory table; in a
# cross build it runs through CMAKE_CROSSCOMPILING_EMULATOR (qemu).
add_custom_target(footprint_report COMMAND footprint memory USES_TERMINAL VERBATIM)
