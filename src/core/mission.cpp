#include "rost/mission.hpp"

#include <algorithm>
#include <cstdint>
#include <filesystem>

#include "rost/config_file.hpp"
#include "rost/text_io.hpp"
#include "rost/topic_model_csv.hpp"

namespace rost {

namespace {

// A setting's problem in the face's spelling.
Status problemStatus(const MissionOptions& m, const SettingProblem& p) {
    if (m.names.problem) return Status::error(m.names.problem(p));
    return Status::error(p.describe([&](const SettingSpec& s) { return m.names.setting(s); }));
}

// "-K 8 differs from m.ckpt's K = 16 (a resumed mission keeps its model; leave -K out)".
Status modelDiffers(const MissionOptions& m, const SettingSpec& spec, const std::string& mine, const std::string& theirs) {
    return Status::error(m.names.given(spec, mine) + " differs from " + m.resume + "'s " + m.names.key(spec) +
                         " = " + theirs + " (a resumed mission keeps its model; leave " + m.names.leave(spec) + " out)");
}

// The runtime part is this process's, whatever the checkpoint says.
void applyRuntime(const MissionOptions& m, const MissionInput& in, EngineConfig& e) {
    e.queue_slots = m.settings.engine.queue_slots;
    e.drop = m.settings.engine.drop;
    e.thread = m.settings.engine.thread;
    e.model.threads = m.isGiven("threads") ? m.settings.engine.model.threads : in.threads;
    e.flags = in.flags;
}

Status planResumed(const MissionOptions& m, const MissionInput& in, MissionPlan& plan) {
    const Config& c = plan.checkpoint.config.model;
    const std::string where = m.names.resume + " " + m.resume;
    auto frames = [&] { return std::to_string(c.frame_width) + "x" + std::to_string(c.frame_height) + " frames"; };
    if (in.width > 0 && in.width != c.frame_width)
        return Status::error(where + ": the frames are " + std::to_string(in.width) + " pixels wide but " + m.resume +
                             " models " + frames());
    if (in.height > 0 && in.height != c.frame_height)
        return Status::error(where + ": the frames are " + std::to_string(in.height) + " pixels high but " + m.resume +
                             " models " + frames());
    if (in.vocabulary && in.V > 0 && (c.V < in.V || (c.V != in.V && !m.isGiven("V"))))
        return Status::error(where + ": its model has V = " + std::to_string(c.V) + " words but the extractors produce " +
                             std::to_string(in.V) + " (use the vocabulary and word options of the run that made it)");
    applyRuntime(m, in, plan.config);
    if (auto p = checkEngineSettings(plan.config)) return problemStatus(m, *p);
    return {};
}

// A topic model to start from (m.in_topicmodel): V holds its counts a line
// and the input's words unless given; with topicmodel.fixed, K is its lines.
Status fromTopicModel(const MissionOptions& m, const MissionInput& in, Config& c) {
    const std::string& name = m.names.topicmodel;
    const SettingSpec& fixed = settingSpec("topicmodel.fixed");
    if (m.in_topicmodel.empty()) {
        if (c.fixed)
            return Status::error(m.names.leave(fixed) + " needs " + name +
                                 " FILE: the topic model the mission is labelled in");
        return {};
    }
    TopicModelShape shape;
    if (Status st = readTopicModelShape(m.in_topicmodel, shape); !st.ok()) return st.prefixed(name + ": ");
    if (shape.rows == 0) return {};  // loadTopicModelCsv names the empty file
    // Words the extractors cannot produce: the model is another vocabulary's
    // (or other word options'). Fewer columns may be a word stream's model
    // (`rost refine` sizes V by the largest word id seen).
    if (in.vocabulary && !m.isGiven("V") && shape.columns > in.V)
        return Status::error(name + ": " + m.in_topicmodel + " has " + std::to_string(shape.columns) +
                             " words a line, more than the " + std::to_string(in.V) + " the extractors produce" +
                             (in.words_detail.empty() ? std::string() : " (" + in.words_detail + ")") +
                             ": a topic model of another vocabulary or other word options");
    // A fixed model labels in its own words: a word stream's words beyond
    // them would be labelled by the neighbourhoods alone, with no counts to
    // go by (a model of another vocabulary, most likely). Giving V accepts it.
    if (c.fixed && !in.vocabulary && !m.isGiven("V") && in.V > shape.columns)
        return Status::error(name + ": " + m.in_topicmodel + " has " + std::to_string(shape.columns) +
                             " words a line, but the input's word ids go up to " + std::to_string(in.V - 1) +
                             ": a fixed topic model labels in its own words (a topic model of another vocabulary? " +
                             m.names.given(settingSpec("V"), std::to_string(in.V)) +
                             " labels the others too, with no counts in it)");
    if (!m.isGiven("V")) c.V = std::max(in.V, shape.columns);
    if (!c.fixed) return {};
    const SettingSpec& K = settingSpec("K");
    // K comes from the file: more lines than a model holds are the file's, not an option's.
    if (!m.isGiven("K") && shape.rows > static_cast<int64_t>(K.hi))
        return Status::error(name + ": " + m.in_topicmodel + " has " + std::to_string(shape.rows) +
                             " topics (lines), more than the " + std::to_string(static_cast<int64_t>(K.hi)) +
                             " a model holds (a merge of many models? merge at a higher threshold)");
    if (!m.isGiven("K")) c.K = shape.rows;
    if (c.K != shape.rows)
        return Status::error(m.names.given(K, std::to_string(c.K)) + " differs from the " + std::to_string(shape.rows) +
                             " topics of " + m.in_topicmodel + ": a fixed topic model labels in its own topics (leave " +
                             m.names.leave(K) + " out)");
    return {};
}

Status planNew(const MissionOptions& m, const MissionInput& in, MissionPlan& plan) {
    EngineConfig e = m.settings.engine;
    Config& c = e.model;
    if (!m.isGiven("V") && in.V > 0) c.V = in.V;
    if (Status st = fromTopicModel(m, in, c); !st.ok()) return st;
    if (in.width > 0) c.frame_width = in.width;
    if (in.height > 0) c.frame_height = in.height;
    if (!m.isGiven("ring.steps") && in.length > 0 && c.cell_time > 0) {
        // Keep a short input whole, so every observation stays refinable to the end.
        const int64_t steps = (in.length + c.cell_time - 1) / c.cell_time;
        c.ring_steps = in.keep_all ? static_cast<int>(std::min<int64_t>(steps, INT32_MAX))
                                   : static_cast<int>(std::clamp<int64_t>(steps + 1, 2, 2048));
    }
    if (!m.isGiven("max.words") && in.max_words > 0) {
        // Room for every word the input can give an observation (no silent subsampling).
        const auto hi = in.keep_all ? uint64_t{INT32_MAX} : static_cast<uint64_t>(settingSpec("max.words").hi);
        c.max_words_per_frame = static_cast<int>(std::min(in.max_words, hi));
    }
    if (!m.isGiven("cell.capacity") && in.busiest_cell)
        c.cell_capacity = static_cast<int>(std::clamp<uint64_t>(in.busiest_cell(c), 1, INT32_MAX));
    if (in.vocabulary && in.V > c.V)
        return Status::error(m.names.given(settingSpec("V"), std::to_string(c.V)) + " is smaller than the " +
                             std::to_string(in.V) + " words the extractors produce" +
                             (in.words_detail.empty() ? std::string() : " (" + in.words_detail + ")"));
    applyRuntime(m, in, e);
    if (auto p = checkEngineSettings(e)) return problemStatus(m, *p);
    plan.config = e;
    plan.resuming = false;
    return {};
}

// Why writing `out` would change the input `in` ("" when it would not).
std::string inputOverlap(const MissionOptions& m, const std::string& out, const std::string& in) {
    if (sameFile(out, in))
        return out == in ? " is an input of this run: writing there would replace it"
                         : " is the same file as the input " + in + ": writing there would replace it";
    if (m.would_read && m.would_read(in, out)) return " would be read by the input " + in + ": writing there would change it";
    return {};
}

} // namespace

bool sameFile(const std::string& a, const std::string& b) {
    if (a == b) return true;  // a FIFO or /dev/stdin, which equivalent() cannot compare
    std::error_code ec;
    if (std::filesystem::equivalent(a, b, ec) && !ec) return true;
    // Made absolute first: weakly_canonical leaves a relative path none of whose parts exists as it is.
    const std::filesystem::path pa = std::filesystem::weakly_canonical(std::filesystem::absolute(a, ec), ec);
    if (ec) return false;
    const std::filesystem::path pb = std::filesystem::weakly_canonical(std::filesystem::absolute(b, ec), ec);
    return !ec && pa == pb;
}

Status checkMissionOutput(const MissionOptions& m, const std::string& name, const std::string& path,
                          MissionOutput kind) {
    if (path.empty()) return {};
    // "-" is standard output to many tools; a mission's outputs are files written whole and replaced.
    if (path == "-")
        return Status::error(name + ": '-' names no file: this output is written to a named file, not to standard "
                                    "output (./- for a file of that name)");
    if (Status st = probeOutputFile(path); !st.ok()) return st.prefixed(name + ": ");
    return checkMissionOutputOverlap(m, name, path, kind);
}

Status checkMissionOutputOverlap(const MissionOptions& m, const std::string& name, const std::string& path,
                                 MissionOutput kind) {
    if (path.empty()) return {};
    std::vector<std::string> read = m.inputs;
    read.push_back(m.in_topicmodel);
    if (kind != MissionOutput::Checkpoint) read.push_back(m.resume);
    for (const std::string& in : read)
        if (const std::string why = in.empty() ? std::string() : inputOverlap(m, path, in); !why.empty())
            return Status::error(name + ": " + path + why);
    return {};
}

bool MissionOptions::isGiven(std::string_view key) const {
    return std::find(given.begin(), given.end(), key) != given.end();
}

int MissionOptions::frameWidth(int width) const {
    return width > 0 ? width : isGiven("frame.width") ? settings.engine.model.frame_width : 0;
}

int MissionOptions::frameHeight(int height) const {
    return height > 0 ? height : isGiven("frame.height") ? settings.engine.model.frame_height : 0;
}

Status checkMission(const MissionOptions& m, MissionPlan& plan) {
    plan.resuming = !m.resume.empty();
    if (!plan.resuming) return {};
    const std::string& name = m.names.resume;
    std::error_code ec;
    if (std::filesystem::is_directory(m.resume, ec))
        return Status::error(StatusKind::IsADirectory, name + ": " + m.resume + " is a directory, not a checkpoint file");
    if (Status st = readCheckpointInfo(m.resume, plan.checkpoint); !st.ok()) return st.prefixed(name + ": ");
    if (!plan.checkpoint.sizes_problem.empty())
        return Status::error(name + ": " + m.resume + ": " + plan.checkpoint.sizes_problem);
    if (!m.in_topicmodel.empty())
        return Status::error(m.names.topicmodel + " cannot be used with " + name +
                             ": the checkpoint holds the mission's topic model");
    Settings theirs;
    theirs.engine = plan.checkpoint.config;
    // The model: what was learned depends on it, so it cannot change.
    for (const SettingSpec& spec : settingSpecs()) {
        if (spec.group != SettingGroup::Model || !isEngineSetting(spec) || !m.isGiven(spec.key)) continue;
        const std::string mine = settingValue(m.settings, spec.key), before = settingValue(theirs, spec.key);
        if (mine != before) return modelDiffers(m, spec, mine, before);
    }
    // Refinement: the checkpoint's unless given; the run then continues under the new settings.
    for (const SettingSpec& spec : settingSpecs())
        if (spec.group == SettingGroup::Refinement && isEngineSetting(spec) && m.isGiven(spec.key) &&
            !settingValue(m.settings, spec.key).empty())
            if (Status st = setSetting(theirs, spec.key, settingValue(m.settings, spec.key)); !st.ok()) return st;
    plan.refinement_changed =
        !configDifferences(plan.checkpoint.config, theirs.engine, {SettingGroup::Refinement}, "a", "b").empty();
    plan.config = theirs.engine;
    return {};
}

Status planMission(const MissionOptions& m, const MissionInput& input, MissionPlan& plan) {
    if (m.resume.empty()) return planNew(m, input, plan);
    if (!plan.resuming)
        if (Status st = checkMission(m, plan); !st.ok()) return st;
    return planResumed(m, input, plan);
}

std::unique_ptr<Engine> openMission(const MissionOptions& m, const MissionPlan& plan, Status& status) {
    std::unique_ptr<Engine> engine = Engine::create(plan.config, status);
    if (!engine) return nullptr;
    if (plan.resuming) {
        CheckpointLoadOptions lo;
        lo.allow_refinement_change = plan.refinement_changed;
        if (Status st = loadCheckpoint(m.resume, *engine, lo); !st.ok()) {
            status = st.prefixed(m.names.resume + ": ");
            return nullptr;
        }
    }
    if (!m.in_topicmodel.empty())
        if (Status st = loadTopicModelCsv(m.in_topicmodel, engine->model()); !st.ok()) {
            status = st.prefixed(m.names.topicmodel + ": ");
            return nullptr;
        }
    status = {};
    return engine;
}

} // namespace rost
