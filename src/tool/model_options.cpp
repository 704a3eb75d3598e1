#include <algorithm>
#include <filesystem>
#include <cstdio>
#include <sstream>
#include <thread>

#include <sched.h>

#include "rost/config_file.hpp"
#include "rost/settings.hpp"
#include "rost/word_stream.hpp"
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

// --threads when given; else the CPUs this process may run on, less one
// for the capture thread of a realtime run, at least 1. The result is the
// same for any number of threads: this only sets how fast it comes.
int toolThreads(const ModelOptions& m, bool realtime) {
    if (m.isGiven("threads")) return m.settings.engine.model.threads;
    int n = 0;
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) == 0) n = CPU_COUNT(&set);
    if (n <= 0) n = static_cast<int>(std::thread::hardware_concurrency());
    return std::clamp(n - (realtime ? 1 : 0), 1, static_cast<int>(settingSpec("threads").hi));
}

int fail(const std::string& message) {
    std::fprintf(stderr, "rost: error: %s\n", message.c_str());
    return kExitError;
}

Status makeEngineConfig(const ModelOptions& m, int width, int height, int V, int64_t frames_hint, uint64_t max_words,
                        bool realtime, EngineConfig& out) {
    EngineConfig e = m.settings.engine;
    Config& c = e.model;
    c.V = V;
    c.frame_width = width;
    c.frame_height = height;
    c.threads = toolThreads(m, realtime);
    if (!m.isGiven("ring.steps") && frames_hint > 0 && c.cell_time > 0) {
        // Keep a short input whole, so every observation stays refinable to the end.
        const int64_t steps = (frames_hint + c.cell_time - 1) / c.cell_time + 1;
        c.ring_steps = static_cast<int>(std::clamp<int64_t>(steps, 2, 2048));
    }
    if (!m.isGiven("max.words") && max_words > 0) {
        // Room for every word the input can give an observation (no silent subsampling).
        const auto hi = static_cast<uint64_t>(settingSpec("max.words").hi);
        c.max_words_per_frame = static_cast<int>(std::min(max_words, hi));
    }
    e.flags = toolFlags(realtime);
    if (auto p = checkEngineSettings(e)) return Status::error(settingProblemText(m, *p));
    out = e;
    return {};
}

bool ModelOptions::isGiven(std::string_view key) const {
    return std::find(given.begin(), given.end(), key) != given.end();
}

std::string optionName(const SettingSpec& spec) {
    if (spec.cli.empty()) return "--" + std::string(spec.key);
    return std::string(spec.cli.substr(0, spec.cli.find(',')));
}

std::string settingProblemText(const ModelOptions& m, const SettingProblem& p) {
    for (const auto& [key, where] : m.given_by_file)  // "FILE:LINE: key 'K' = ", set by the file alone
        if (key == p.spec->key)
            return where.substr(0, where.size() - 3) + ": " + p.describe(std::string(p.spec->key));
    return p.describe([](const SettingSpec& spec) {
        // The frame size is the input's (--width/--height resize it): no option of its own.
        // (Appended piece by piece: GCC 12 at -O3 warns falsely on "lit" + string; -Wrestrict.)
        std::string names;
        if (spec.key == "frame.width" || spec.key == "frame.height") {
            names = "the input's ";
            names += spec.key;
            return names;
        }
        if (spec.cli.empty()) {
            names = "--";
            names += spec.key;
            return names;
        }
        // Every name the option answers to ("--queue.slots/--queue"), whichever was typed.
        for (std::size_t at = 0; at <= spec.cli.size();) {
            std::size_t end = spec.cli.find(',', at);
            if (end == std::string_view::npos) end = spec.cli.size();
            if (const std::string_view n = spec.cli.substr(at, end - at); !n.starts_with('!')) {
                if (!names.empty()) names += '/';
                names += n;
            }
            at = end + 1;
        }
        return names;
    });
}

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
    Settings theirs;
    theirs.engine = info.config;
    const Config& c = info.config.model;

    // The model: what was learned depends on it, so it cannot change.
    for (const SettingSpec& spec : settingSpecs()) {
        if (spec.group != SettingGroup::Model || !isEngineSetting(spec) || !m.isGiven(spec.key)) continue;
        const std::string mine = settingValue(m.settings, spec.key), before = settingValue(theirs, spec.key);
        if (mine == before) continue;
        // Set by a --config file: name the file, line and key; else the option.
        std::string source = optionName(spec) + " ", leave = optionName(spec);
        for (const auto& [key, text] : m.given_by_file)
            if (key == spec.key) source = text, leave = "the key";
        return Status::error(source + mine + " differs from " + m.resume + "'s " + std::string(spec.key) + " = " + before +
                             " (a resumed mission keeps its model; leave " + leave + " out)");
    }
    auto frames = [&] { return std::to_string(c.frame_width) + "x" + std::to_string(c.frame_height) + " frames"; };
    if (frameWidth > 0 && frameWidth != c.frame_width)
        return Status::error(where + ": the frames are " + std::to_string(frameWidth) + " pixels wide but " + m.resume +
                             " models " + frames());
    if (frameHeight > 0 && frameHeight != c.frame_height)
        return Status::error(where + ": the frames are " + std::to_string(frameHeight) + " pixels high but " + m.resume +
                             " models " + frames());

    // Refinement: may change; the run then continues under the new settings.
    for (const SettingSpec& spec : settingSpecs())
        if (spec.group == SettingGroup::Refinement && isEngineSetting(spec) && m.isGiven(spec.key) &&
            !settingValue(m.settings, spec.key).empty())
            if (Status st = setSetting(theirs, spec.key, settingValue(m.settings, spec.key)); !st.ok()) return st;
    refinementChanged = !configDifferences(info.config, theirs.engine, {SettingGroup::Refinement}, "a", "b").empty();

    // Runtime: this command's.
    EngineConfig e = theirs.engine;
    e.queue_slots = m.settings.engine.queue_slots;
    e.drop = m.settings.engine.drop;
    e.thread = m.settings.engine.thread;
    e.model.threads = toolThreads(m, realtime);
    e.flags = toolFlags(realtime);
    if (auto p = checkEngineSettings(e)) return Status::error(settingProblemText(m, *p));
    out = e;
    return {};
}

Status probeMissionOutputs(const ModelOptions& m, const std::string& outBag) {
    if (!m.checkpoint.empty())
        if (Status st = probeOutputFile(m.checkpoint); !st.ok()) return Status::error("--checkpoint: " + st.message());
    if (!outBag.empty())
        if (Status st = probeOutputFile(outBag); !st.ok()) return Status::error("--out.bag: " + st.message());
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
    engine.captureCheckpoints(out.get(), m.settings.checkpoint_every);
    return {};
}

Status finishCheckpoints(CheckpointWriter& writer) {
    (void)writer.flush();  // a periodic save still in progress
    writer.capture();
    const Status st = writer.flush();
    return st.ok() ? st : Status::error("--checkpoint: " + st.message());
}

} // namespace rost::tool
