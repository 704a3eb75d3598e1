#include <cstdio>

#include "tool.hpp"

namespace rost::tool {

int fail(const std::string& message) {
    std::fprintf(stderr, "rost: error: %s\n", message.c_str());
    return kExitError;
}

Status makeEngineConfig(const ModelOptions& m, int width, int height, int V, int64_t frames_hint, bool realtime,
                        EngineConfig& out) {
    EngineConfig e;
    Config& c = e.model;
    c.K = m.K;
    c.V = V;
    c.alpha = m.alpha;
    c.beta = m.beta;
    c.cell_space = m.cell_space;
    c.cell_time = m.cell_time;
    c.g_space = m.g_space;
    c.g_time = m.g_time;
    c.frame_width = width;
    c.frame_height = height;
    c.cell_capacity = m.cell_capacity;
    c.max_words_per_frame = m.max_words;
    c.seed = m.seed;
    if (m.ring > 0) {
        c.ring_steps = m.ring;
    } else if (frames_hint > 0 && m.cell_time > 0) {
        // Keep a short input whole, so every observation stays refinable to the end.
        const int64_t steps = (frames_hint + m.cell_time - 1) / m.cell_time + 1;
        c.ring_steps = static_cast<int>(std::clamp<int64_t>(steps, 2, 2048));
    } else {
        c.ring_steps = 256;
    }
    Status st = parseEvictionPolicy(m.eviction, c.eviction);
    if (!st.ok()) return Status::error("--eviction: " + st.message());
    st = parseStrategy(m.sampler, e.strategy.kind);
    if (!st.ok()) return Status::error("--sampler: " + st.message());
    e.strategy.eta = m.eta;
    e.strategy.q = m.q;
    if (m.budget_ms > 0.0) e.budget = Budget::time(m.budget_ms);
    else e.budget = Budget::steps(m.budget_refines);
    e.flags.instantaneous_perplexity = true;
    e.flags.snapshot_perplexity = false;  // the tool reads perplexities from the model at eviction and at the end
    e.flags.snapshot_labels = realtime;
    e.flags.stop_on_arrival = false;
    st = e.validate();
    if (!st.ok()) return st;  // messages use the option names (cell.space, g.time, ...)
    out = e;
    return {};
}

} // namespace rost::tool
