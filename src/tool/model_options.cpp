#include <algorithm>
#include <filesystem>
#include <cstdio>
#include <sstream>

#include "rost/config_file.hpp"
#include "tool.hpp"

namespace rost::tool {

namespace {

// What the tool asks the engine to compute: it reads perplexities from the
// model at eviction and at the end; labels are published only for a live run.
EngineFlags toolFlags(bool realtime) {
    EngineFlags f;
    f.instantaneous_perplexity = true;
    f.snapshot_perplexity = false;
    f.snapshot_labels = realtime;
    f.stop_on_arrival = false;
    return f;
}

} // namespace

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
    e.flags = toolFlags(realtime);
    st = e.validate();
    if (!st.ok()) return st;  // messages use the option names (cell.space, g.time, ...)
    out = e;
    return {};
}

namespace {

// A value as the messages print it (17 significant digits for doubles, so
// two different values never print the same).
template <class T>
std::string show(const T& v) {
    std::ostringstream s;
    if constexpr (std::is_floating_point_v<T>) s.precision(17);
    s << v;
    return s.str();
}

} // namespace

Status resumeConfig(const ModelOptions& m, int frameWidth, int frameHeight, bool realtime, EngineConfig& out,
                    CheckpointInfo& info, bool& refinementChanged) {
    const std::string where = "--resume " + m.resume;
    if (m.resume.empty()) return Status::error("--resume: no file given");
    std::error_code ec;
    if (std::filesystem::is_directory(m.resume, ec))
        return Status::error("--resume: " + m.resume + " is a directory, not a checkpoint file");
    if (Status st = readCheckpointInfo(m.resume, info); !st.ok()) return Status::error("--resume: " + st.message());
    if (!m.in_topicmodel.empty())
        return Status::error("--in.topicmodel cannot be used with --resume: the checkpoint holds the mission's topic model");
    const auto given = [&](const char* option) { return std::find(m.given.begin(), m.given.end(), option) != m.given.end(); };
    EngineConfig e = info.config;
    const Config& c = e.model;

    // The model: what was learned depends on it, so it cannot change.
    EvictionPolicy eviction = c.eviction;
    if (given("--eviction")) (void)parseEvictionPolicy(m.eviction, eviction);  // checked by the parser
    struct Fixed {
        const char* option;
        const char* key;
        bool same;
        std::string mine, theirs;
    };
    const Fixed fixed[] = {
        {"-K", "K", m.K == c.K, show(m.K), show(c.K)},
        {"-V", "V", m.V == 0 || m.V == c.V, show(m.V), show(c.V)},
        {"--alpha", "alpha", m.alpha == c.alpha, show(m.alpha), show(c.alpha)},
        {"--beta", "beta", m.beta == c.beta, show(m.beta), show(c.beta)},
        {"--cell.space", "cell.space", m.cell_space == c.cell_space, show(m.cell_space), show(c.cell_space)},
        {"--cell.time", "cell.time", m.cell_time == c.cell_time, show(m.cell_time), show(c.cell_time)},
        {"--g.space", "g.space", m.g_space == c.g_space, show(m.g_space), show(c.g_space)},
        {"--g.time", "g.time", m.g_time == c.g_time, show(m.g_time), show(c.g_time)},
        {"--ring.steps", "ring.steps", m.ring == 0 || m.ring == c.ring_steps, show(m.ring), show(c.ring_steps)},
        {"--cell.capacity", "cell.capacity", m.cell_capacity == c.cell_capacity, show(m.cell_capacity),
         show(c.cell_capacity)},
        {"--max.words", "max.words", m.max_words == c.max_words_per_frame, show(m.max_words),
         show(c.max_words_per_frame)},
        {"--eviction", "eviction", eviction == c.eviction, m.eviction, toString(c.eviction)},
        {"--seed", "seed", m.seed == c.seed, show(m.seed), show(c.seed)},
    };
    for (const Fixed& f : fixed) {
        if (!given(f.option) || f.same) continue;
        // Set by a --config file: name the file, line and key; else the option.
        std::string source = std::string(f.option) + " ", leave = f.option;
        for (const auto& [option, text] : m.given_by_file)
            if (option == f.option) source = text, leave = "the key";
        return Status::error(source + f.mine + " differs from " + m.resume + "'s " + f.key + " = " + f.theirs +
                             " (a resumed mission keeps its model; leave " + leave + " out)");
    }
    if (frameWidth > 0 && frameWidth != c.frame_width)
        return Status::error(where + ": the frames are " + show(frameWidth) + " pixels wide but " + m.resume + " models " +
                             show(c.frame_width) + "x" + show(c.frame_height) + " frames");
    if (frameHeight > 0 && frameHeight != c.frame_height)
        return Status::error(where + ": the frames are " + show(frameHeight) + " pixels high but " + m.resume +
                             " models " + show(c.frame_width) + "x" + show(c.frame_height) + " frames");

    // Refinement: may change; the run then continues under the new settings.
    const EngineConfig before = e;
    if (given("--sampler")) {
        if (Status st = parseStrategy(m.sampler, e.strategy.kind); !st.ok()) return Status::error("--sampler: " + st.message());
    }
    if (given("--eta")) e.strategy.eta = m.eta;
    if (given("--q")) e.strategy.q = m.q;
    if (given("--budget.ms")) e.budget = Budget::time(m.budget_ms);
    else if (given("--budget.refines")) e.budget = Budget::steps(m.budget_refines);
    refinementChanged = e.strategy.kind != before.strategy.kind || e.strategy.eta != before.strategy.eta ||
                        e.strategy.q != before.strategy.q || e.budget.kind != before.budget.kind ||
                        e.budget.count != before.budget.count || e.budget.ms != before.budget.ms;

    // Runtime: this command's (the caller sets queue, drop and thread).
    e.flags = toolFlags(realtime);
    if (Status st = e.validate(); !st.ok()) return st;
    out = e;
    return {};
}

Status loadResumed(const ModelOptions& m, bool refinementChanged, Engine& engine) {
    CheckpointLoadOptions lo;
    lo.allow_refinement_change = refinementChanged;
    const Status st = loadCheckpoint(m.resume, engine, lo);
    return st.ok() ? st : Status::error("--resume: " + st.message());
}

Status attachCheckpoints(Engine& engine, const ModelOptions& m, std::unique_ptr<CheckpointWriter>& out) {
    out.reset();
    if (m.checkpoint.empty()) return {};
    Status st;
    out = CheckpointWriter::create(engine, m.checkpoint, st);
    if (!out) return Status::error("--checkpoint: " + st.message());
    const ObservationHook inner = engine.observationHook();
    CheckpointWriter* w = out.get();
    const uint64_t every = m.checkpoint_every;
    engine.setObservationHook([inner, w, every](const ObservationResult& r, const Model& model) {
        if (inner) inner(r, model);
        w->captureEvery(every, r);
    });
    return {};
}

Status finishCheckpoints(CheckpointWriter& writer) {
    (void)writer.flush();  // a periodic save still in progress
    writer.capture();
    const Status st = writer.flush();
    return st.ok() ? st : Status::error("--checkpoint: " + st.message());
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
        m.given.push_back(option);
        m.given_by_file.emplace_back(option, path + ":" + std::to_string(line) + ": key '" + key + "' = ");
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
