// A user's program built against the installed package: a few observations
// through the engine, and a check that it learned something.
#include <cmath>
#include <cstdio>
#include <vector>

#include <rost/engine.hpp>
#include <rost/version.hpp>

int main() {
    rost::EngineConfig cfg;
    cfg.model.K = 4;
    cfg.model.V = 100;
    cfg.model.frame_width = 128;
    cfg.model.frame_height = 128;
    cfg.budget = rost::Budget::steps(4);
    rost::Engine engine(cfg);
    rost::Rng rng(1);
    std::vector<uint32_t> words(200);
    std::vector<rost::Position> positions(200);
    double last = 0.0;
    for (int t = 0; t < 60; ++t) {
        for (std::size_t i = 0; i < words.size(); ++i) {
            positions[i] = {static_cast<int32_t>(rng.below(128)), static_cast<int32_t>(rng.below(128))};
            // Left half draws words 0..49, right half 50..99.
            words[i] = (positions[i].x < 64 ? 0u : 50u) + rng.below(50);
        }
        const rost::ObservationResult r = engine.processNow({t, words, positions});
        if (!r.add.ok()) return 1;
        last = r.perplexity;
    }
    std::printf("rost %s, %s: perplexity of the last step %.1f (vocabulary 100), model %zu bytes\n",
                rost::versionString(), rost::kernel::simdName(), last, engine.memoryBytes());
    // Two halves of 50 words each; cells see their own half and, through the
    // neighbourhood, a little of the other: about 70 once learned, 100 for a model that learned nothing.
    return std::isfinite(last) && last < 80.0 ? 0 : 1;
}
