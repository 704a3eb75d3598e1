#pragma once

// Offline replay: feeds a recorded word stream through an Engine (the same
// ingest/refine/publish path the camera uses) with the engine's count
// budget, as fast as the machine allows, and records per observation its
// instantaneous and final perplexity, surprise and final labels.
//
// With a count budget the result is the same bit for bit whether the stream
// goes through processNow() on the calling thread or through the producer
// and refiner threads (ReplayOptions::threaded).

#include <cstdint>
#include <limits>
#include <vector>

#include "rost/engine.hpp"
#include "rost/status.hpp"
#include "rost/word_stream.hpp"

namespace rost {

struct ReplayOptions {
    // Through start() / pushWait() / stop() instead of processNow().
    bool threaded = false;
    // Batch Gibbs sweeps over the window after the last observation, before
    // the final perplexities and labels of the steps still in the ring.
    int final_sweeps = 0;
    // Record the final maximum-likelihood labels of every observation.
    bool labels = true;
};

struct ReplayObservation {
    int64_t timestamp = 0;
    int64_t step = -1;  // Model step; -1 when the model rejected the observation
    AddResult add;      // error and index when rejected; kept / subsampled words otherwise
    double surprise = std::numeric_limits<double>::quiet_NaN();
    // Perplexity of its step one step after arrival (just before the next
    // step was added; for the last step, after its budget).
    double instantaneous_perplexity = std::numeric_limits<double>::quiet_NaN();
    // Perplexity of its step when the step left the window, or at the end.
    double final_perplexity = std::numeric_limits<double>::quiet_NaN();
    // Final labels of its (frame-kept) words, in input order.
    std::vector<uint16_t> labels;
};

struct ReplayResult {
    std::vector<ReplayObservation> observations;  // one per stream observation, in order
    EngineCounters counters;                      // the engine's, at the end
    double seconds = 0.0;                         // wall time of the replay
};

// Replays `stream` through `engine` (which must not be running). The engine's
// hooks are wrapped for the replay (hooks already set are still called) and
// restored afterwards. Errors: a stream whose positions do not match its
// words, an engine already running, a thread that could not start.
Status replay(Engine& engine, const WordStream& stream, const ReplayOptions& options, ReplayResult& out);

} // namespace rost
