// The README's ten lines, as a program CI builds and runs: a capture loop
// pushing synthetic frames into the engine's refiner thread, and a reader
// steering by the curiosity signal.
#include <cstdio>
#include <thread>
#include <vector>

#include <rost/engine.hpp>

namespace {
double steered = 0.0;
void steer(double surprise) { steered = surprise; }
} // namespace

int main() {
    // Frames: 640x480, left half shows words 0..999, right half 1000..1999.
    rost::Rng rng(7);
    std::vector<uint32_t> words(2000);
    std::vector<rost::Position> positions(2000);

    // --- README begins ---
    rost::EngineConfig cfg;                                // paper defaults: K = 16, alpha 0.1, beta 0.5, 64 px cells
    cfg.strategy.kind = rost::StrategyKind::UniformNow;    // Uniform+Now, eta = 0.5
    cfg.budget = rost::Budget::steps(8);                   // 8 time-step refinements per observation: reproducible
    cfg.thread = rost::ThreadSettings::onboard();          // SCHED_FIFO, pinned, mlockall where permitted
    rost::Engine engine(cfg);                              // all memory allocated here: engine.memoryBytes()
    rost::Snapshot snap = engine.makeSnapshot();           // sized once
    if (!engine.start().ok()) return 1;                    // the refiner thread
    for (int64_t timestamp = 0; timestamp < 50; ++timestamp) {
        for (std::size_t i = 0; i < words.size(); ++i) {
            positions[i] = {static_cast<int32_t>(rng.below(640)), static_cast<int32_t>(rng.below(480))};
            words[i] = (positions[i].x < 320 ? 0u : 1000u) + rng.below(1000);
        }
        (void)engine.tryPush({timestamp, words, positions});  // capture thread: lock-free, never blocks
        if (engine.readSnapshot(snap)) steer(snap.surprise);  // any thread: labels, perplexity, surprise
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    engine.stop();
    // --- README ends ---

    const rost::EngineCounters c = engine.counters();
    const uint64_t dropped = c.dropped_newest + c.dropped_oldest;
    std::printf("pushed 50 frames: %llu ingested, %llu dropped; last surprise seen %.1f; %zu bytes\n",
                static_cast<unsigned long long>(c.ingested), static_cast<unsigned long long>(dropped), steered,
                engine.memoryBytes());
    // Every frame is either ingested or counted as dropped (stop() drains the queue).
    return c.ingested > 0 && c.ingested + dropped == 50 ? 0 : 1;
}
