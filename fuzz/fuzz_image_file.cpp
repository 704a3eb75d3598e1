// Fuzzes the image files' truncation check (rost::vision::imageTruncated: a
// walk of a JPEG's markers or a PNG's chunks over untrusted bytes). The first
// input byte chooses a signature to put in front (0: none, 1: JPEG, 2: PNG),
// so mutations reach the walks. Whatever the input: no crash, no sanitizer
// report, and the answer is "" or a "truncated ..." reason; a file called
// truncated is truncated at every shorter length too (a cut of a cut file).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rost/vision/image_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    std::vector<uint8_t> bytes;
    switch (data[0] % 3) {
        case 1: bytes = {0xFF, 0xD8, 0xFF}; break;
        case 2: bytes = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A}; break;
        default: break;
    }
    const std::size_t head = bytes.size();
    bytes.insert(bytes.end(), data + 1, data + size);
    // An exact-size copy: AddressSanitizer sees any read past the end.
    const std::vector<uint8_t> exact(bytes.begin(), bytes.end());
    const std::string why = rost::vision::imageTruncated(exact.data(), exact.size());
    if (!why.empty() && why.rfind("truncated ", 0) != 0) __builtin_trap();
    if (!why.empty() && head > 0) {
        const std::size_t cut = head + (exact.size() - head) / 2;
        const std::vector<uint8_t> shorter(exact.begin(), exact.begin() + static_cast<std::ptrdiff_t>(cut));
        if (rost::vision::imageTruncated(shorter.data(), shorter.size()).empty()) __builtin_trap();
    }
    return 0;
}
