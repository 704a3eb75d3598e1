// `rost refine`'s input: a word stream (and its positions) read whole, the
// engine made for it. Apart from stages.cpp, whose frame sources need
// OpenCV's video and image I/O: `rost refine` is built without them.

#include <algorithm>
#include <cstdio>

#include "rost/topic_model_csv.hpp"
#include "stages.hpp"

namespace rost::tool {

Status StreamStage::read(const RefineOptions& o) {
    WordStreamLimits limits;
    const Config& given = o.model.settings.engine.model;
    limits.vocabulary = resuming ? static_cast<uint32_t>(ec.model.V) : o.model.isGiven("V") ? static_cast<uint32_t>(given.V) : 0;
    limits.width = resuming ? ec.model.frame_width : o.width;
    limits.height = resuming ? ec.model.frame_height : o.height;
    // max.words (the checkpoint's, or set): longer observations are an error
    // here; otherwise max.words is the longest observation's size (configFromData).
    if (resuming || o.model.isGiven("max.words"))
        limits.max_words = static_cast<uint32_t>(std::max(1, resuming ? ec.model.max_words_per_frame : given.max_words_per_frame));
    else
        limits.max_words = static_cast<uint32_t>(settingSpec("max.words").hi);
    limits.threads = toolThreads(o.model, false);  // the positions file read beside the words
    if (Status st = readWordStream(o.words, o.positions, limits, ws); !st.ok()) return st;
    if (ws.observations.empty()) return Status::error(o.words + ": no observations (the file has no data lines)");
    if (std::all_of(ws.observations.begin(), ws.observations.end(), [](const auto& ob) { return ob.words.empty(); }))
        return Status::error(o.words + ": no words in its " + std::to_string(ws.observations.size()) +
                             " observations (each line is timestamp,word,word,...)");
    if (!ws.has_positions)  // no positions: every word at (0, 0)
        for (auto& ob : ws.observations) ob.positions.assign(ob.words.size(), Position{});
    return {};
}

// What the checkpoint already has. Either this is the stream it was made
// from (its first `observations` observations are the checkpoint's: skip
// them), or what came after it (every time stamp later than the checkpoint's last).
Status StreamStage::resumeSkip(const RefineOptions& o) {
    if (!ws.has_positions && (ec.model.frame_width != 1 || ec.model.frame_height != 1))
        return Status::error(o.words + ": no --positions, but " + o.model.resume + " models " +
                             std::to_string(ec.model.frame_width) + "x" + std::to_string(ec.model.frame_height) +
                             " frames: give the words' positions");
    const auto n = static_cast<std::size_t>(resumed.observations);
    const auto& obs = ws.observations;
    const std::string last = std::to_string(resumed.last_timestamp);
    if (n == 0) {
        skipped = 0;
    } else if (n <= obs.size() && obs[n - 1].timestamp == resumed.last_timestamp) {
        skipped = n;
    } else if (obs.front().timestamp > resumed.last_timestamp) {
        skipped = 0;
    } else if (n > obs.size()) {
        return Status::error(o.words + ": " + std::to_string(obs.size()) + " observations, fewer than the " +
                             std::to_string(n) + " " + o.model.resume +
                             " holds, and not the ones after them (they would start after time stamp " + last + ")");
    } else {
        return Status::error(o.words + ": neither the stream " + o.model.resume + " was made from (its observation " +
                             std::to_string(n) + " has time stamp " + last + ", here " +
                             std::to_string(obs[n - 1].timestamp) + ") nor what came after it (the first time stamp here, " +
                             std::to_string(obs.front().timestamp) + ", is not after " + last + ")");
    }
    if (skipped == ws.observations.size())
        return Status::error(o.words + ": nothing to resume with: its " + std::to_string(skipped) +
                             " observations are all in " + o.model.resume);
    return {};
}

// V and the frame geometry from the data unless given.
Status StreamStage::configFromData(const RefineOptions& o) {
    uint32_t maxWord = 0;
    int32_t maxX = 0, maxY = 0;
    uint64_t longest = 0;
    for (const auto& ob : ws.observations) {
        longest = std::max<uint64_t>(longest, ob.words.size());
        for (uint32_t w : ob.words) maxWord = std::max(maxWord, w);
        for (const Position& p : ob.positions) maxX = std::max(maxX, p.x), maxY = std::max(maxY, p.y);
    }
    MissionInput in = missionInput(o.model, false);
    in.V = static_cast<int>(maxWord) + 1;
    in.width = o.width > 0 ? o.width : maxX + 1;
    in.height = o.height > 0 ? o.height : maxY + 1;
    if (!ws.has_positions) in.width = in.height = 1;  // one cell per time step (a temporal topic model)
    in.length = static_cast<int64_t>(ws.observations.size());
    in.max_words = longest;
    if (Status st = planMission(missionOptions(o.model), in, plan); !st.ok()) return st;
    ec = plan.config;
    return {};
}

Status StreamStage::makeEngine(const RefineOptions& o) {
    Status st;
    engine = openMission(missionOptions(o.model), plan, st);
    if (!engine) return st;
    if (resuming) {
        if (!o.quiet)
            std::fprintf(stderr, "rost: resuming %s at observation %llu (time stamp %lld); %zu observations skipped%s\n",
                         o.model.resume.c_str(), static_cast<unsigned long long>(resumed.observations),
                         static_cast<long long>(resumed.last_timestamp), skipped,
                         refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
    }
    return {};
}

Status StreamStage::open(const RefineOptions& o) {
    // --resume: the checkpoint fixes V and the frame size before the words are read
    // (the library's mission session: rost/mission.hpp).
    Status st;
    if (st = checkMission(missionOptions(o.model), plan); !st.ok()) return st;
    resuming = plan.resuming;
    if (resuming) {
        MissionInput in = missionInput(o.model, false);
        in.width = o.width;
        in.height = o.height;
        if (st = planMission(missionOptions(o.model), in, plan); !st.ok()) return st;
        ec = plan.config;
        resumed = plan.checkpoint;
        refinementChanged = plan.refinement_changed;
    }
    if (st = read(o); !st.ok()) return st;
    st = resuming ? resumeSkip(o) : configFromData(o);
    if (!st.ok()) return st;
    return makeEngine(o);
}

} // namespace rost::tool
