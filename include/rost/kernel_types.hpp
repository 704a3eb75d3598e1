#pragma once

// What the public Model names of the Gibbs kernel: the path selector (SIMD or
// the scalar reference). The kernel itself (SSE2/NEON intrinsics), its topic
// padding and its count tables are internal to the library and compiled with
// the library's flags (src/core/kernel.hpp, src/core/kernel_tables.hpp);
// users never instantiate them.

#include <cstdint>

namespace rost::kernel {

enum class Path : uint8_t { Scalar, Simd };

// Name of the SIMD instruction set the library's Simd path was compiled to:
// "sse2", "neon" or "scalar".
const char* simdName() noexcept;

} // namespace rost::kernel
