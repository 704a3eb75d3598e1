// Fuzzes the checkpoint loader. The first input byte chooses whether the
// target recomputes every CRC-32C of the rest before loading (odd) or not
// (even), so mutations reach both the checksum and structure checks and the
// checks on the contents behind valid checksums. Whatever the input: no
// crash, no sanitizer report; a file the loader accepts leaves an engine
// whose counts are consistent, that keeps running, and whose own checkpoint
// loads again.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "rost/checkpoint.hpp"
#include "kernel_tables.hpp"

namespace {

uint32_t le32(const uint8_t* p) {
    return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}
uint64_t le64(const uint8_t* p) { return le32(p) | uint64_t{le32(p + 4)} << 32; }
void put32(uint8_t* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

// Recomputes the checksums of whatever sections fit, by the documented layout.
void reseal(std::vector<uint8_t>& b) {
    if (b.size() < 32) return;
    std::size_t at = 32;
    const uint32_t count = le32(b.data() + 12);
    for (uint32_t i = 0; i < count && i < 256 && b.size() - at >= 56; ++i) {
        uint8_t* h = b.data() + at;
        const uint64_t n = le64(h + 40);
        if (n > b.size() - at - 56) break;
        put32(h + 48, rost::crc32c({h + 56, static_cast<std::size_t>(n)}));
        put32(h + 52, rost::crc32c({h, 52}));
        at += 56 + static_cast<std::size_t>(n);
    }
    put32(b.data() + 28, rost::crc32c({b.data(), 28}));
}

// Only configurations whose engine is small enough to build per input.
bool small(const rost::Config& c) {
    const uint64_t cells = static_cast<uint64_t>(c.cellsPerStep());
    return c.K <= 64 && cells <= 256 && static_cast<uint64_t>(c.V) * rost::kernel::paddedK(c.K) <= (1u << 16) &&
           cells * static_cast<uint64_t>(c.ring_steps) * static_cast<uint64_t>(c.cell_capacity) <= (1u << 16) &&
           static_cast<uint64_t>(c.ring_steps) * static_cast<uint64_t>(c.cell_time) *
                   static_cast<uint64_t>(c.max_words_per_frame) <=
               (1u << 16);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    std::vector<uint8_t> bytes(data + 1, data + size);
    if (data[0] & 1) reseal(bytes);
    rost::CheckpointInfo info;
    if (!rost::inspectCheckpoint(bytes, "fuzz.ckpt", info).ok()) return 0;
    if (!small(info.config.model)) return 0;
    // This process runs synchronously with a small budget: the runtime and
    // refinement keys may differ from the file's.
    rost::EngineConfig cfg = info.config;
    cfg.budget = rost::Budget::steps(2);
    cfg.queue_slots = 2;
    cfg.thread = rost::ThreadSettings{};
    rost::Status st;
    auto engine = rost::Engine::create(cfg, st);
    if (!engine) __builtin_trap();  // inspectCheckpoint validated the configuration
    rost::CheckpointLoadOptions opt;
    opt.allow_refinement_change = true;
    st = rost::loadCheckpoint(bytes, "fuzz.ckpt", *engine, opt);
    if (!st.ok()) {
        if (st.message().empty()) __builtin_trap();
        return 0;
    }
    std::string why;
    if (!engine->model().checkInvariants(&why)) __builtin_trap();
    // Keep running from the loaded state.
    const rost::Config& c = cfg.model;
    rost::Rng rng(data[0]);
    std::vector<uint32_t> words(8);
    std::vector<rost::Position> pos(8);
    for (int f = 0; f < 3; ++f) {
        for (std::size_t i = 0; i < words.size(); ++i) {
            words[i] = rng.below(static_cast<uint32_t>(c.V));
            pos[i] = {static_cast<int32_t>(rng.below(static_cast<uint32_t>(c.frame_width))),
                      static_cast<int32_t>(rng.below(static_cast<uint32_t>(c.frame_height)))};
        }
        if (!engine->processNow({f, words, pos}).add.ok()) __builtin_trap();
    }
    if (!engine->model().checkInvariants(&why)) __builtin_trap();
    std::vector<uint8_t> again;
    if (!rost::encodeCheckpoint(*engine, again).ok()) __builtin_trap();
    auto other = rost::Engine::create(cfg, st);
    if (!other || !rost::loadCheckpoint(again, "again.ckpt", *other, opt).ok()) __builtin_trap();
    return 0;
}
