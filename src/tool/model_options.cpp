#include <algorithm>
#include <cstdio>
#include <optional>
#include <sstream>
#include <thread>

#include <sched.h>

#include "rost/config_file.hpp"
#include "rost/settings.hpp"
#include "rost/text_io.hpp"
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
    // Printable, but for the indented lines of a list an error ends with (a
    // bag's image topics: "\n  /cam/image_raw (...)").
    std::string shown;
    for (std::size_t at = 0;;) {
        const std::size_t next = message.find("\n  ", at);
        shown += text::printable(std::string_view(message).substr(at, next - at));
        if (next == std::string::npos) break;
        shown += "\n  ";
        at = next + 3;
    }
    std::fprintf(stderr, "rost: error: %s\n", shown.c_str());
    return kExitError;
}

bool ModelOptions::isGiven(std::string_view key) const {
    return std::find(given.begin(), given.end(), key) != given.end();
}

std::string optionName(const SettingSpec& spec) {
    if (spec.cli.empty()) return "--" + std::string(spec.key);
    return std::string(spec.cli.substr(0, spec.cli.find(',')));
}

std::string optionNames(const SettingSpec& spec) {
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
}

std::string settingProblemText(const ModelOptions& m, const SettingProblem& p) {
    for (const auto& [key, where] : m.given_by_file)  // "FILE:LINE: key 'K' = ", set by the file alone
        if (key == p.spec->key)
            return where.substr(0, where.size() - 3) + ": " + p.describe(std::string(p.spec->key));
    return p.describe(optionNames);
}

Status probeMissionOutputs(const ModelOptions& m, const std::string& outBag, const std::vector<std::string>& inputs,
                           const std::vector<std::string>& results,
                           std::function<bool(const std::string&, const std::string&)> wouldRead) {
    MissionOptions mo = missionOptions(m);
    mo.inputs = inputs;
    mo.inputs.push_back(m.config);
    mo.would_read = std::move(wouldRead);
    for (const std::string& result : results)  // the run's own files over one of its inputs (--out probes them)
        if (Status st = checkMissionOutputOverlap(mo, "--out", result); !st.ok()) return st;
    if (Status st = checkMissionOutput(mo, "--checkpoint", m.checkpoint); !st.ok()) return st;
    if (Status st = checkMissionOutput(mo, "--out.bag", outBag, MissionOutput::Other); !st.ok()) return st;
    if (!m.checkpoint.empty() && !outBag.empty() && sameFile(m.checkpoint, outBag))
        return Status::error("--out.bag: " + outBag + " is the --checkpoint file too: one would replace the other");
    for (const auto& [option, path] : {std::pair{"--checkpoint", &m.checkpoint}, std::pair{"--out.bag", &outBag}})
        for (const std::string& result : results)
            if (!path->empty() && sameFile(*path, result))
                return Status::error(std::string(option) + ": " + *path + " is one of the run's outputs (" + result +
                                     "): one would replace the other");
    return {};
}

MissionOptions missionOptions(const ModelOptions& m) {
    MissionOptions mo;
    mo.settings = m.settings;
    mo.given = m.given;
    mo.resume = m.resume;
    mo.in_topicmodel = m.in_topicmodel;
    // The tool's spelling: options, or the --config file's line and key that set a value.
    const auto fromFile = [files = m.given_by_file](const SettingSpec& spec) -> std::optional<std::string> {
        for (const auto& [key, where] : files)  // "FILE:LINE: key 'K' = "
            if (key == spec.key) return where;
        return std::nullopt;
    };
    mo.names.setting = optionNames;
    mo.names.problem = [copy = m](const SettingProblem& p) { return settingProblemText(copy, p); };
    mo.names.given = [fromFile](const SettingSpec& spec, const std::string& value) {
        const std::optional<std::string> file = fromFile(spec);
        return file ? *file + value : optionName(spec) + " " + value;
    };
    mo.names.leave = [fromFile](const SettingSpec& spec) {
        return fromFile(spec) ? std::string("the key") : optionName(spec);
    };
    return mo;
}

MissionInput missionInput(const ModelOptions& m, bool realtime) {
    MissionInput in;
    in.threads = toolThreads(m, realtime);
    in.flags = toolFlags(realtime);
    return in;
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
    const Status st = writer.finish();
    return st.ok() ? st : Status::error("--checkpoint: " + st.message());
}

} // namespace rost::tool
