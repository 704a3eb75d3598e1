#include <cstdio>

#include "rost/config_file.hpp"
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

Status applyConfigFile(const std::string& path, const std::function<bool(const std::string&)>& given, ModelOptions& m,
                       RunOptions* run, RefineOptions* ref) {
    EngineConfig c;
    std::vector<ConfigKeyLine> keys;
    if (Status st = readConfigFile(path, c, &keys); !st.ok()) return st;
    const bool budgetGiven = given("--budget.refines") || given("--budget.ms");
    for (const auto& [key, line] : keys) {
        const std::string where = path + ":" + std::to_string(line) + ": key '" + key + "'";
        // The command-line option that sets the same thing.
        const std::string option = key == "K"             ? "-K"
                                   : key == "V"           ? "-V"
                                   : key == "queue.slots" ? "--queue"
                                   : key == "thread.fifo" ? "--fifo"
                                   : key == "thread.cpu"  ? "--cpu"
                                                          : "--" + key;
        if (key.rfind("budget.", 0) == 0 ? budgetGiven : given(option)) continue;  // the command line wins
        if (key == "K") m.K = c.model.K;
        else if (key == "V") m.V = c.model.V;
        else if (key == "alpha") m.alpha = c.model.alpha;
        else if (key == "beta") m.beta = c.model.beta;
        else if (key == "cell.space") m.cell_space = c.model.cell_space;
        else if (key == "cell.time") m.cell_time = c.model.cell_time;
        else if (key == "g.space") m.g_space = c.model.g_space;
        else if (key == "g.time") m.g_time = c.model.g_time;
        else if (key == "ring.steps") m.ring = c.model.ring_steps;
        else if (key == "cell.capacity") m.cell_capacity = c.model.cell_capacity;
        else if (key == "max.words") m.max_words = c.model.max_words_per_frame;
        else if (key == "eviction") m.eviction = toString(c.model.eviction);
        else if (key == "seed") m.seed = c.model.seed;
        else if (key == "sampler") m.sampler = toString(c.strategy.kind);
        else if (key == "eta") m.eta = c.strategy.eta;
        else if (key == "q") m.q = c.strategy.q;
        else if (key == "budget.refines") m.budget_refines = c.budget.count, m.budget_ms = 0.0;
        else if (key == "budget.ms") m.budget_ms = c.budget.ms;
        else if (run && key == "queue.slots") run->queue = c.queue_slots;
        else if (run && key == "drop") run->drop = toString(c.drop);
        else if (run && key == "thread.fifo") run->fifo = c.thread.fifo;
        else if (run && key == "thread.cpu") run->cpu = c.thread.cpu;
        else if (ref && key == "frame.width" && !given("--width")) ref->width = c.model.frame_width;
        else if (ref && key == "frame.height" && !given("--height")) ref->height = c.model.frame_height;
        else if (ref && (key == "frame.width" || key == "frame.height")) continue;
        else
            return Status::error(where + " is not a setting of this command" +
                                 (key.rfind("frame.", 0) == 0 ? " (the input sets the frame size; --width/--height resize it)"
                                                               : std::string()));
    }
    return {};
}

} // namespace rost::tool
