// Fuzzes the word/position CSV reader (parseWordStream). The input is the
// words text, then optionally a NUL byte and the positions text. Whatever
// the input: no crash, no sanitizer report, and a stream the reader accepts
// obeys its limits and enters a Model without an error.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "rost/model.hpp"
#include "rost/word_stream.hpp"

namespace {

rost::Config modelConfig() {
    rost::Config c;
    c.K = 4;
    c.V = 1000;
    c.frame_width = 640;
    c.frame_height = 480;
    c.cell_space = 160;
    c.ring_steps = 4;
    c.cell_capacity = 32;
    c.max_words_per_frame = 64;
    return c;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string_view all(reinterpret_cast<const char*>(data), size);
    const std::size_t nul = all.find('\0');
    const std::string_view words = all.substr(0, nul);
    const std::string_view positions = nul == std::string_view::npos ? std::string_view() : all.substr(nul + 1);

    rost::WordStreamLimits lim;
    lim.vocabulary = 1000;
    lim.width = 640;
    lim.height = 480;
    lim.max_words = 4096;
    rost::WordStream s;
    if (!rost::parseWordStream(words, positions, lim, s).ok()) {
        // Without limits the same text may parse; it must not crash either.
        rost::WordStream loose;
        (void)rost::parseWordStream(words, positions, rost::WordStreamLimits{}, loose);
        return 0;
    }
    static rost::Model* model = new rost::Model(modelConfig());
    for (const auto& o : s.observations) {
        if (o.words.size() != o.positions.size() || o.words.size() > lim.max_words) __builtin_trap();
        for (std::size_t i = 0; i < o.words.size(); ++i)
            if (o.words[i] >= lim.vocabulary || o.positions[i].x < 0 || o.positions[i].x >= lim.width ||
                o.positions[i].y < 0 || o.positions[i].y >= lim.height)
                __builtin_trap();
        if (!model->addObservation(o.words, o.positions).ok()) __builtin_trap();
        model->refineStep(model->steps() - 1);
    }
    return 0;
}
