#pragma once

#include <cstddef>

namespace rost {

// Cache-line constant pinned here rather than taken from
// std::hardware_destructive_interference_size, which differs between targets
// and compilers and would change struct layouts across architectures. The
// counters that different threads write (the engine's stop flag, the
// snapshot's sequence numbers, the checkpoint writer's state) sit on lines
// of their own.
inline constexpr std::size_t kCacheLine = 64;

} // namespace rost
