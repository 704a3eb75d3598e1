#pragma once

// Small synthetic word streams for the engine's tests and benches: each
// observation's words come from the topic of the region they fall in (left
// and right halves of the frame see different word blocks, and the blocks
// change halfway through the stream), so refinement has structure to find.
// Only rost::Rng is used, so the same arguments give the same stream everywhere.

#include <cstdint>
#include <vector>

#include "rost/config.hpp"
#include "rost/engine.hpp"
#include "rost/random.hpp"

namespace rost::testing {

struct Frame {
    int64_t timestamp = 0;
    std::vector<uint32_t> words;
    std::vector<Position> positions;
    ObservationView view() const { return {timestamp, words, positions}; }
};

inline std::vector<Frame> makeStream(const Config& cfg, int frames, int words_per_frame, uint64_t seed) {
    Rng rng(seed);
    std::vector<Frame> out(static_cast<std::size_t>(frames));
    const uint32_t V = static_cast<uint32_t>(cfg.V);
    const uint32_t block = V >= 4 ? V / 4 : 1;
    for (int f = 0; f < frames; ++f) {
        Frame& fr = out[static_cast<std::size_t>(f)];
        fr.timestamp = 1000 + 40 * static_cast<int64_t>(f);
        fr.words.resize(static_cast<std::size_t>(words_per_frame));
        fr.positions.resize(static_cast<std::size_t>(words_per_frame));
        const uint32_t phase = f < frames / 2 ? 0u : 2u;
        for (int i = 0; i < words_per_frame; ++i) {
            const int x = static_cast<int>(rng.below(static_cast<uint32_t>(cfg.frame_width)));
            const int y = static_cast<int>(rng.below(static_cast<uint32_t>(cfg.frame_height)));
            const uint32_t region = (x < cfg.frame_width / 2 ? 0u : 1u) + phase;
            const uint32_t w = rng.below(10) == 0 ? rng.below(V) : (region % 4) * block + rng.below(block);
            fr.words[static_cast<std::size_t>(i)] = w % V;
            fr.positions[static_cast<std::size_t>(i)] = {x, y};
        }
    }
    return out;
}

// A small configuration that runs fast in tests.
inline Config smallConfig() {
    Config c;
    c.K = 8;
    c.V = 400;
    c.frame_width = 256;
    c.frame_height = 192;
    c.cell_space = 64;  // 4 x 3 cells
    c.ring_steps = 16;
    c.cell_capacity = 64;
    c.max_words_per_frame = 512;
    c.seed = 7;
    return c;
}

} // namespace rost::testing
