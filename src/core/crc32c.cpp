// CRC-32C (Castagnoli), the checksum of checkpoint files (rost/checkpoint.hpp):
// slice-by-8, tables built at compile time.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "rost/checkpoint.hpp"

namespace rost {

namespace {

// Slice-by-8 tables: table[0] is the classic byte table; table[j][b] is the
// CRC of byte b followed by j zero bytes.
constexpr std::array<std::array<uint32_t, 256>, 8> makeCrcTables() {
    std::array<std::array<uint32_t, 256>, 8> t{};
    for (uint32_t b = 0; b < 256; ++b) {
        uint32_t c = b;
        for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ 0x82F63B78u : c >> 1;
        t[0][b] = c;
    }
    for (uint32_t b = 0; b < 256; ++b)
        for (int j = 1; j < 8; ++j) t[j][b] = (t[j - 1][b] >> 8) ^ t[0][t[j - 1][b] & 0xFFu];
    return t;
}
constexpr auto kCrc = makeCrcTables();

} // namespace

uint32_t crc32c(std::span<const uint8_t> bytes, uint32_t crc) noexcept {
    uint32_t c = ~crc;
    const uint8_t* p = bytes.data();
    std::size_t n = bytes.size();
    while (n >= 8) {
        const uint32_t lo = c ^ (uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24);
        c = kCrc[7][lo & 0xFFu] ^ kCrc[6][(lo >> 8) & 0xFFu] ^ kCrc[5][(lo >> 16) & 0xFFu] ^ kCrc[4][lo >> 24] ^
            kCrc[3][p[4]] ^ kCrc[2][p[5]] ^ kCrc[1][p[6]] ^ kCrc[0][p[7]];
        p += 8;
        n -= 8;
    }
    while (n-- > 0) c = (c >> 8) ^ kCrc[0][(c ^ *p++) & 0xFFu];
    return ~c;
}

} // namespace rost
