// A word stream's mission (rost/mission.hpp, openStreamMission): the stream
// read whole, the engine planned for it or resumed, the checkpoint's own
// observations skipped. `rost refine` and Python's rost.Mission are faces.

#include <algorithm>

#include "rost/mission.hpp"

namespace rost {

namespace {

Status readStream(const MissionOptions& m, const StreamMissionInput& in, StreamMission& out) {
    WordStreamLimits limits;
    const Config& given = m.settings.engine.model;
    const Config& fixed = out.plan.config.model;
    const bool resuming = out.plan.resuming;
    // V and the frame: the checkpoint's or the user's, else the most the
    // schema allows (the data decide within it: a word id or a position
    // beyond it is an error naming file:line:col, not a setting out of range).
    const auto mostV = static_cast<int32_t>(settingSpec("V").hi);
    const auto mostWidth = static_cast<int32_t>(settingSpec("frame.width").hi);
    const auto mostHeight = static_cast<int32_t>(settingSpec("frame.height").hi);
    limits.vocabulary = static_cast<uint32_t>(resuming ? fixed.V : m.isGiven("V") ? given.V : mostV);
    limits.width = resuming ? fixed.frame_width : in.width > 0 ? in.width : mostWidth;
    limits.height = resuming ? fixed.frame_height : in.height > 0 ? in.height : mostHeight;
    limits.width_largest = !resuming && in.width <= 0;
    limits.height_largest = !resuming && in.height <= 0;
    // max.words (the checkpoint's, or set): longer observations are an error
    // here; otherwise max.words is the longest observation's size (planFromData).
    if (resuming || m.isGiven("max.words"))
        limits.max_words = static_cast<uint32_t>(std::max(1, resuming ? fixed.max_words_per_frame : given.max_words_per_frame));
    else
        limits.max_words = static_cast<uint32_t>(settingSpec("max.words").hi);
    limits.threads = in.read_threads;
    WordStream& ws = out.stream;
    WordStreamFile unread = WordStreamFile::None;
    if (Status st = readWordStream(in.words, in.positions, limits, ws, &unread); !st.ok()) {
        // The positions file could not be read (missing, a directory, out of memory): named by
        // the face's option, as a starting topic model is; a line of it is named by its place.
        return unread == WordStreamFile::Positions ? st.prefixed(m.names.positions + ": ") : st;
    }
    if (ws.observations.empty()) return Status::error(in.words + ": no observations (the file has no data lines)");
    if (std::all_of(ws.observations.begin(), ws.observations.end(), [](const auto& ob) { return ob.words.empty(); }))
        return Status::error(in.words + ": no words in its " + std::to_string(ws.observations.size()) +
                             " observations (each line is timestamp,word,word,...)");
    if (!ws.has_positions)  // no positions: every word at (0, 0)
        for (auto& ob : ws.observations) ob.positions.assign(ob.words.size(), Position{});
    return {};
}

// What the checkpoint already has. Either this is the stream it was made
// from (its first `observations` observations are the checkpoint's: skip
// them), or what came after it (every time stamp later than the checkpoint's last).
Status resumeSkip(const MissionOptions& m, const StreamMissionInput& in, StreamMission& out) {
    const Config& c = out.plan.config.model;
    const CheckpointInfo& resumed = out.plan.checkpoint;
    if (!out.stream.has_positions && (c.frame_width != 1 || c.frame_height != 1))
        return Status::error(in.words + ": no " + m.names.positions + ", but " + m.resume + " models " + std::to_string(c.frame_width) +
                             "x" + std::to_string(c.frame_height) + " frames: give the words' positions");
    const auto n = static_cast<std::size_t>(resumed.observations);
    const auto& obs = out.stream.observations;
    const std::string last = std::to_string(resumed.last_timestamp);
    if (n == 0) {
        out.skipped = 0;
    } else if (n <= obs.size() && obs[n - 1].timestamp == resumed.last_timestamp) {
        out.skipped = n;
    } else if (obs.front().timestamp > resumed.last_timestamp) {
        out.skipped = 0;
    } else if (n > obs.size()) {
        return Status::error(in.words + ": " + std::to_string(obs.size()) + " observations, fewer than the " +
                             std::to_string(n) + " " + m.resume +
                             " holds, and not the ones after them (they would start after time stamp " + last + ")");
    } else {
        return Status::error(in.words + ": neither the stream " + m.resume + " was made from (its observation " +
                             std::to_string(n) + " has time stamp " + last + ", here " +
                             std::to_string(obs[n - 1].timestamp) + ") nor what came after it (the first time stamp here, " +
                             std::to_string(obs.front().timestamp) + ", is not after " + last + ")");
    }
    if (out.skipped == obs.size())
        return Status::error(in.words + ": nothing to resume with: its " + std::to_string(out.skipped) +
                             " observations are all in " + m.resume);
    return {};
}

// V and the frame geometry from the data unless given.
Status planFromData(const MissionOptions& m, const StreamMissionInput& in, StreamMission& out) {
    uint32_t maxWord = 0;
    int32_t maxX = 0, maxY = 0;
    uint64_t longest = 0;
    for (const auto& ob : out.stream.observations) {
        longest = std::max<uint64_t>(longest, ob.words.size());
        for (uint32_t w : ob.words) maxWord = std::max(maxWord, w);
        for (const Position& p : ob.positions) maxX = std::max(maxX, p.x), maxY = std::max(maxY, p.y);
    }
    // Without positions every word of an observation is in one cell of a 1x1
    // frame: another frame size asked for would be ignored, so it is refused.
    if (!out.stream.has_positions && (in.width > 1 || in.height > 1)) {
        std::string size = in.width > 0 ? "width " + std::to_string(in.width) : "";
        if (in.height > 0) size += (size.empty() ? "height " : ", height ") + std::to_string(in.height);
        return Status::error(in.words + ": no " + m.names.positions + ", but a frame size was given (" + size +
                             "): give the words' positions, or leave the frame size out");
    }
    MissionInput mi = in.base;
    mi.V = static_cast<int>(maxWord) + 1;
    mi.width = in.width > 0 ? in.width : maxX + 1;
    mi.height = in.height > 0 ? in.height : maxY + 1;
    if (!out.stream.has_positions) mi.width = mi.height = 1;  // one cell per time step (a temporal topic model)
    mi.length = static_cast<int64_t>(out.stream.observations.size());
    mi.max_words = longest;
    return planMission(m, mi, out.plan);
}

// A stream whose observation n has the checkpoint's last time stamp is
// taken for the one the checkpoint was made from; two streams numbered by
// frame both have it. The checkpoint's last observation is still in the
// model (the newest step), its kept words and positions a subsequence of
// what was read (subsampling keeps input order): that observation here
// must hold them, or the stream is another one.
Status checkSameStream(const MissionOptions& m, const StreamMissionInput& in, const StreamMission& out) {
    const Model& model = out.engine->model();
    const uint64_t frame = out.plan.checkpoint.observations - 1;
    const uint32_t kept = model.observationSize(frame);
    std::vector<uint32_t> words(kept);
    std::vector<Position> positions(kept);
    model.observationWords(frame, words);
    model.observationPositions(frame, positions);
    const StreamObservation& ob = out.stream.observations[out.skipped - 1];
    std::size_t at = 0;
    for (uint32_t i = 0; i < kept; ++i, ++at) {
        while (at < ob.words.size() && (ob.words[at] != words[i] || ob.positions[at].x != positions[i].x ||
                                        ob.positions[at].y != positions[i].y))
            ++at;
        if (at == ob.words.size()) {
            const std::string t = std::to_string(ob.timestamp);
            return Status::error(
                in.words + ": not the stream " + m.resume + " was made from: its observation " +
                std::to_string(out.skipped) + " (time stamp " + t + ") lacks word " + std::to_string(words[i]) + " at (" +
                std::to_string(positions[i].x) + ", " + std::to_string(positions[i].y) +
                ") that the checkpoint's has; to carry the mission on with another stream, give only what came after "
                "it (time stamps after " + t + ")");
        }
    }
    return {};
}

} // namespace

Status openStreamMission(const MissionOptions& m, const StreamMissionInput& given, StreamMission& out) {
    StreamMissionInput in = given;
    in.width = m.frameWidth(given.width);
    in.height = m.frameHeight(given.height);
    // Resuming: the checkpoint fixes V and the frame size before the words are read.
    if (Status st = checkMission(m, out.plan); !st.ok()) return st;
    if (out.plan.resuming) {
        MissionInput mi = in.base;
        mi.width = in.width;
        mi.height = in.height;
        if (Status st = planMission(m, mi, out.plan); !st.ok()) return st;
    }
    if (Status st = readStream(m, in, out); !st.ok()) return st;
    if (Status st = out.plan.resuming ? resumeSkip(m, in, out) : planFromData(m, in, out); !st.ok()) return st;
    Status st;
    out.engine = openMission(m, out.plan, st);
    if (!out.engine) return st;
    if (out.plan.resuming && out.skipped > 0) return checkSameStream(m, in, out);
    return {};
}

} // namespace rost
