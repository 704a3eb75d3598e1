#pragma once

// The engine's refiner-side state (internal; src/core/engine.cpp, and
// engine_state.cpp for its checkpoint sections).

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "aligned_buffer.hpp"
#include "rost/cache_line.hpp"
#include "rost/engine.hpp"
#include "rost/snapshot.hpp"

namespace rost {

// Refiner-side state: written only by the thread that refines (the refiner
// thread, or the caller in synchronous mode).
struct Engine::Refiner {
    explicit Refiner(const Config& cfg)
        : staging(cfg), win_cap(static_cast<std::size_t>(cfg.ring_steps) * static_cast<std::size_t>(cfg.cell_time)),
          win_ts(win_cap), win_seq(win_cap) {}

    Snapshot staging;
    std::size_t win_cap;
    AlignedBuffer<int64_t> win_ts;   // time stamp of each observation in the window (frame % win_cap)
    AlignedBuffer<uint64_t> win_seq; // its producer sequence number

    // Time-budget predictors: running averages of the cost of a token and of
    // a publication, so the last cell started still ends before the deadline
    // (a cell is started only if 1.5x its predicted cost fits).
    double ns_per_token = 40.0;
    double publish_ns = 0.0;  // set from the budget in Engine(); measured after the first publication
    uint64_t token_samples = 0;
    uint64_t publish_samples = 0;
    uint64_t next_sequence = 0;    // producer sequence after the last observation taken up (checkpoints)
    uint64_t truncated_taken = 0;  // words subsampled away at push from the observations taken up (checkpoints)
    // The counters and predictors as describeState() lists them (copied there, applied by applyState()).
    EngineStateCounters saved_counters;
    EngineStatePredictors saved_predictors;

    alignas(kCacheLine) std::atomic<uint64_t> ingested{0};
    std::atomic<uint64_t> rejected{0};
    std::atomic<uint64_t> words_dropped_cell{0};
    std::atomic<uint64_t> refinements{0};
    std::atomic<uint64_t> tokens{0};
    std::atomic<uint64_t> overruns{0};
    std::atomic<int64_t> max_overrun_ns{0};
    std::atomic<uint64_t> published{0};
    alignas(kCacheLine) std::atomic<bool> ready{false};
};

} // namespace rost
