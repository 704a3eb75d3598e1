// Fuzzes the vocabulary loader (rost::vision::Vocabulary::parse; its header
// and code need no OpenCV). The first input byte chooses whether the target
// recomputes the file's CRC-32 before parsing (odd), so mutations also reach
// the descriptors and the search index behind a valid checksum. Whatever the
// input: no crash, no sanitizer report; for an accepted vocabulary the exact
// tree search (every bucket probed) agrees with the linear one, the default
// tree search returns a valid word no nearer than the exact one, and the
// vocabulary serialises back to itself.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rost/vision/vocabulary.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    std::vector<uint8_t> bytes(data + 1, data + size);
    if ((data[0] & 1) && bytes.size() >= 32) {
        const uint32_t crc = rost::vision::crc32({bytes.data() + 32, bytes.size() - 32});
        for (int i = 0; i < 4; ++i) bytes[24 + static_cast<std::size_t>(i)] = static_cast<uint8_t>(crc >> (8 * i));
    }
    rost::vision::Vocabulary v;
    if (!rost::vision::Vocabulary::parse(bytes, "fuzz.rostvoc", v).ok()) return 0;
    if (v.empty()) __builtin_trap();
    // Query with descriptors cut from the input itself and with their complements.
    for (std::size_t at = 0; at + 32 <= bytes.size() && at < 32 * 64; at += 32) {
        rost::vision::Descriptor d = rost::vision::Descriptor::fromBytes(bytes.data() + at);
        for (int flip = 0; flip < 2; ++flip) {
            int dl = 0, de = 0, dt = 0;
            const uint32_t a = v.quantize(d, dl, {rost::vision::SearchMethod::Linear, 0});
            const uint32_t b = v.quantize(d, de, {rost::vision::SearchMethod::Tree, v.coarseCentres() + 1});
            const uint32_t c = v.quantize(d, dt, rost::vision::Search{});
            if (a >= v.size() || a != b || dl != de) __builtin_trap();
            if (c >= v.size() || dt < dl || rost::vision::hammingDistance(d, v.word(c)) != dt) __builtin_trap();
            for (auto& w : d.w) w = ~w;
        }
    }
    const std::vector<uint8_t> out = v.serialize();
    rost::vision::Vocabulary back;
    if (!rost::vision::Vocabulary::parse(out, "again", back).ok() || back.size() != v.size()) __builtin_trap();
    for (uint32_t i = 0; i < v.size(); ++i)
        if (!(back.word(i) == v.word(i))) __builtin_trap();
    return 0;
}
