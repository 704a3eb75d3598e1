// Whether a JPEG or PNG file's bytes are cut short (rost/vision/image_file.hpp).
// Hand-written because neither OpenCV nor the decoders it wraps report a cut
// file through OpenCV's API; the walk reads only markers and chunk headers.
// No OpenCV: fuzzed on its own (fuzz/fuzz_image_file.cpp).

#include "rost/vision/image_file.hpp"

#include <array>
#include <cstring>

namespace rost::vision {

namespace {

uint32_t bigEndian16(const uint8_t* p) noexcept { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t bigEndian32(const uint8_t* p) noexcept {
    return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// In a JPEG's entropy-coded data a 0xFF byte is followed by 0x00 (a stuffed
// byte), a restart marker (0xD0-0xD7) or more 0xFF (fill); anything else is
// the next marker. Its offset, or `n` when the data runs to the end.
std::size_t nextMarkerAfterScan(const uint8_t* b, std::size_t at, std::size_t n) noexcept {
    for (std::size_t j = at; j + 1 < n; ++j) {
        if (b[j] != 0xFF) continue;
        const uint8_t m = b[j + 1];
        if (m != 0x00 && m != 0xFF && !(m >= 0xD0 && m <= 0xD7)) return j;
    }
    return n;
}

const char* const kJpegCut = "truncated JPEG: the file ends before its end-of-image marker";

std::string jpegTruncated(const uint8_t* b, std::size_t n) {
    std::size_t i = 2;  // after the start-of-image marker
    for (;;) {
        if (i >= n) return kJpegCut;
        if (b[i] != 0xFF) return {};  // not a marker where one must be: damaged, OpenCV decides
        while (i + 1 < n && b[i + 1] == 0xFF) ++i;  // fill bytes before a marker
        if (i + 1 >= n) return kJpegCut;
        const uint8_t m = b[i + 1];
        if (m == 0xD9) return {};                                  // end of image
        if (m == 0x00) return {};  // FF 00 is no marker outside a scan: stray bytes, OpenCV skips them
        // A reserved code (FF 02 to FF BF) is no segment: a byte damaged inside
        // a scan's data, not a cut. Read as one, its "length" would be noise.
        if (m >= 0x02 && m <= 0xBF) return {};
        if (m == 0x01 || (m >= 0xD0 && m <= 0xD7)) { i += 2; continue; }  // markers without a length
        if (i + 4 > n) return kJpegCut;
        const std::size_t end = i + 2 + bigEndian16(b + i + 2);
        if (end > n) return kJpegCut;
        i = m == 0xDA ? nextMarkerAfterScan(b, end, n) : end;  // a scan's data runs to the next marker
    }
}

std::string pngTruncated(const uint8_t* b, std::size_t n) {
    std::size_t i = 8;  // after the signature
    for (;;) {
        if (n - i < 12) return "truncated PNG: the file ends before its IEND chunk";
        const uint64_t length = bigEndian32(b + i);
        if (length > n - i - 12) return "truncated PNG: the file ends inside a chunk, before its IEND chunk";
        if (std::memcmp(b + i + 4, "IEND", 4) == 0) return {};
        i += 12 + static_cast<std::size_t>(length);
    }
}

} // namespace

std::string imageTruncated(const uint8_t* b, std::size_t n) {
    static constexpr std::array<uint8_t, 8> kPng{0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return jpegTruncated(b, n);
    if (n >= kPng.size() && std::memcmp(b, kPng.data(), kPng.size()) == 0) return pngTruncated(b, n);
    return {};
}

} // namespace rost::vision
