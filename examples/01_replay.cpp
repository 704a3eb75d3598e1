// 01_replay: replay a recorded word stream through the realtime engine and
// print the perplexity of every time step.
//
// A recorded stream is what `rost run` writes to words.csv / positions.csv
// (read it with rost::readWordStream). Here one is synthesised in memory: a
// scene of two textures (left and right half of the frame) that changes to
// two other textures halfway through, so the surprise jumps there and the
// perplexity falls as the engine learns each scene.
//
//   build/examples/01_replay [frames]

#include <cstdio>
#include <cstdlib>

#include "rost/engine.hpp"
#include "rost/replay.hpp"
#include "rost/word_stream.hpp"

int main(int argc, char** argv) {
    const int frames = argc > 1 ? std::atoi(argv[1]) : 120;
    if (frames <= 0) {
        std::fprintf(stderr, "01_replay: frames must be a positive number, got '%s'\n", argv[1]);
        return 2;
    }

    // 1. The engine: the paper's model (K = 16, alpha = 0.1, beta = 0.5, 64 px
    //    cells) on 320x240 frames, Uniform+Now refinement (eta = 0.5) with a
    //    count budget of 4 time-step refinements per observation, so the run
    //    is reproducible bit for bit.
    rost::EngineConfig cfg;
    cfg.model.V = 1000;
    cfg.model.frame_width = 320;
    cfg.model.frame_height = 240;
    cfg.model.ring_steps = 64;
    cfg.model.seed = 42;
    cfg.strategy.kind = rost::StrategyKind::UniformNow;
    cfg.strategy.eta = 0.5;
    cfg.budget = rost::Budget::steps(4);
    rost::Status status;
    auto engine = rost::Engine::create(cfg, status);
    if (!engine) {
        std::fprintf(stderr, "01_replay: %s\n", status.message().c_str());
        return 2;
    }
    std::printf("# engine memory: %zu bytes (model %zu, queue %zu, snapshots %zu)\n", engine->memoryBytes(),
                engine->memory().model, engine->memory().queue, engine->memory().snapshot);

    // 2. A recorded stream: 300 words a frame, each from its region's texture
    //    (words 0-249, 250-499, then 500-749, 750-999), 10% from anywhere.
    rost::WordStream stream;
    stream.has_positions = true;
    rost::Rng rng(7);
    for (int f = 0; f < frames; ++f) {
        rost::StreamObservation o;
        o.timestamp = 40 * f;  // milliseconds at 25 frames per second
        for (int i = 0; i < 300; ++i) {
            const rost::Position p{static_cast<int32_t>(rng.below(320)), static_cast<int32_t>(rng.below(240))};
            const uint32_t texture = (p.x < 160 ? 0u : 1u) + (f < frames / 2 ? 0u : 2u);
            o.words.push_back(rng.below(10) == 0 ? rng.below(1000) : texture * 250 + rng.below(250));
            o.positions.push_back(p);
        }
        stream.observations.push_back(std::move(o));
    }

    // 3. Replay it as fast as the machine allows, then a final sweep.
    rost::ReplayOptions options;
    options.final_sweeps = 2;
    rost::ReplayResult result;
    status = rost::replay(*engine, stream, options, result);
    if (!status.ok()) {
        std::fprintf(stderr, "01_replay: %s\n", status.message().c_str());
        return 1;
    }

    // 4. Perplexity per step: one step after arrival (instantaneous) and at
    //    the end (final); surprise when the frame arrived.
    std::printf("step,timestamp,instantaneous,final,surprise\n");
    for (const rost::ReplayObservation& o : result.observations)
        std::printf("%lld,%lld,%.2f,%.2f,%.2f\n", static_cast<long long>(o.step), static_cast<long long>(o.timestamp),
                    o.instantaneous_perplexity, o.final_perplexity, o.surprise);
    const rost::EngineCounters& c = result.counters;
    std::printf("# %llu observations, %llu refinements, %llu tokens in %.3f s\n",
                static_cast<unsigned long long>(c.ingested), static_cast<unsigned long long>(c.refinements),
                static_cast<unsigned long long>(c.tokens), result.seconds);
    return 0;
}
