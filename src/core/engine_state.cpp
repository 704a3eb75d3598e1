// The engine's own checkpoint sections (rost/engine.hpp, describeState and
// applyState; the model's are the model's, the file format rost/checkpoint.hpp's).

#include <algorithm>

#include "engine_refiner.hpp"
#include "observation_queue.hpp"
#include "rost/engine.hpp"
#include "rost/model.hpp"

namespace rost {

void Engine::describeState(StateLayout& out) noexcept {
    Refiner& R = *refiner_;
    // Producer-side losses as of the last observation taken up (the
    // producer may be ahead, and what it queued since is not in the state):
    // sequence numbers skipped before next_sequence were dropped.
    EngineStateCounters& c = R.saved_counters;
    c.ingested = R.ingested.load(std::memory_order_relaxed);
    c.rejected = R.rejected.load(std::memory_order_relaxed);
    const uint64_t takenUp = c.ingested + c.rejected;
    const uint64_t drops = R.next_sequence > takenUp ? R.next_sequence - takenUp : 0;
    c.dropped_oldest = std::min(drops, queue_->droppedOldest());
    c.dropped_newest = drops - c.dropped_oldest;
    c.words_dropped_cell = R.words_dropped_cell.load(std::memory_order_relaxed);
    c.refinements = R.refinements.load(std::memory_order_relaxed);
    c.tokens = R.tokens.load(std::memory_order_relaxed);
    c.overruns = R.overruns.load(std::memory_order_relaxed);
    c.max_overrun_ns = static_cast<uint64_t>(R.max_overrun_ns.load(std::memory_order_relaxed));
    c.published = R.published.load(std::memory_order_relaxed);
    c.words_truncated = R.truncated_taken;
    c.next_sequence = R.next_sequence;
    R.saved_predictors = {R.ns_per_token, R.publish_ns};

    model_->describeState(out);
    out.addBytes("engine.counters", 0, &R.saved_counters, sizeof R.saved_counters, sizeof(uint64_t));
    out.addBytes("engine.predictors", 0, &R.saved_predictors, sizeof R.saved_predictors, sizeof(double));
    out.add("engine.window.timestamp", 0, R.win_ts.data(), R.win_ts.size());
    out.add("engine.window.sequence", 0, R.win_seq.data(), R.win_seq.size());
}

Status Engine::applyState() {
    if (running()) return Status::error("engine: cannot restore state while running");
    if (queue_->size() != 0) return Status::error("engine: cannot restore state while observations are queued");
    evicted_through_ = 0;  // the restored window's observations have not been flushed
    Refiner& R = *refiner_;
    const EngineStateCounters& c = R.saved_counters;
    R.ingested.store(c.ingested, std::memory_order_relaxed);
    R.rejected.store(c.rejected, std::memory_order_relaxed);
    R.words_dropped_cell.store(c.words_dropped_cell, std::memory_order_relaxed);
    R.refinements.store(c.refinements, std::memory_order_relaxed);
    R.tokens.store(c.tokens, std::memory_order_relaxed);
    R.overruns.store(c.overruns, std::memory_order_relaxed);
    R.max_overrun_ns.store(static_cast<int64_t>(c.max_overrun_ns), std::memory_order_relaxed);
    R.published.store(c.published, std::memory_order_relaxed);
    R.next_sequence = c.next_sequence;
    R.truncated_taken = c.words_truncated;
    queue_->restoreProducer(c.next_sequence, c.dropped_newest, c.dropped_oldest, c.words_truncated);
    R.ns_per_token = R.saved_predictors.ns_per_token;
    R.publish_ns = R.saved_predictors.publish_ns;
    R.token_samples = R.publish_samples = 1;  // restored averages, not first samples
    model_->stateRestored();
    return {};
}

} // namespace rost
