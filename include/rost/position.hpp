#pragma once

// Small value types a caller fills: where a word was seen.

#include <cstdint>

namespace rost {

// A word's pixel position in its frame: it lands in cell (x / cell.space,
// y / cell.space); positions lie in [0, frame.width) x [0, frame.height).
struct Position {
    int32_t x = 0;
    int32_t y = 0;
};

} // namespace rost
