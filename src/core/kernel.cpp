#include "kernel.hpp"

namespace rost::kernel {

// Compiled with the library's flags, so it names the path the library's Model runs.
const char* simdName() noexcept {
#if defined(ROST_SIMD_SSE2)
    return "sse2";
#elif defined(ROST_SIMD_NEON)
    return "neon";
#else
    return "scalar";
#endif
}

} // namespace rost::kernel
