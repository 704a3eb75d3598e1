// A mission over frames (rost/vision/mission.hpp): the words, the plan and
// the engine, by the library's one policy, for the rost tool's `run` and
// Python's rost.vision.Mission.

#include "rost/vision/mission.hpp"

#include <algorithm>

namespace rost::vision {

Status MissionWords::open(const WordSettings& settings, const std::string& vocabularyPath) {
    Status st;
    extractors = ExtractorConfig::from(settings);
    if (!vocabularyPath.empty())  // before the file is read
        if (st = unusedVocabulary(extractors, "vocabulary " + vocabularyPath); !st.ok()) return st;
    if (extractors.orb) {
        if (vocabularyPath.empty()) {
            vocabulary = defaultVocabulary(st);
        } else {
            auto v = std::make_shared<Vocabulary>();
            st = Vocabulary::load(vocabularyPath, *v);
            vocabulary = std::move(v);
        }
        if (!st.ok()) return st;
    }
    extractor = WordExtractor::create(extractors, vocabulary, st);
    return extractor ? Status() : st;
}

void MissionWords::describe(const SourceInfo& info, MissionInput& in) const {
    // The words' ids must mean what they meant: the extractors' V (the
    // checkpoint's unless V is given; a V given must hold them). A checkpoint
    // does not record which vocabulary made its words: another of the same
    // size is not detected (docs/tool.md).
    in.V = static_cast<int>(extractor->vocabularySize());
    in.vocabulary = true;
    const WordLayout& l = extractor->layout();
    in.words_detail = "ORB " + std::to_string(l.orb_size) + " + intensity " + std::to_string(l.intensity_size) +
                      " + hue " + std::to_string(l.hue_size);
    in.max_words = maxWordsPerFrame(extractors, info.width, info.height);
}

namespace {

// Frames the checkpoint already has: a file's are skipped (its frame index
// is at most the checkpoint's last time stamp); a camera's are numbered
// after them. maxFrames counts the whole mission: with a resume, the
// checkpoint's frames too.
Status countFrames(const MissionOptions& m, const SourceInfo& info, int64_t maxFrames, FrameMission& out) {
    const CheckpointInfo& resumed = out.plan.checkpoint;
    out.skip_through = out.plan.resuming && resumed.observations > 0 ? resumed.last_timestamp : -1;
    out.before = out.skip_through + 1;
    out.frames = info.frames;
    if (maxFrames > 0) out.frames = out.frames > 0 ? std::min(out.frames, maxFrames) : maxFrames;
    if (out.frames > 0) {
        out.frames -= out.before;
        if (out.frames <= 0) {
            std::string msg = info.description + ": nothing to resume with: " + m.resume + " has every frame up to " +
                              std::to_string(out.skip_through);
            if (maxFrames > 0) msg += " (" + m.names.max_frames + " " + std::to_string(maxFrames) + " counts the mission)";
            return Status::error(msg);
        }
    }
    return {};
}

} // namespace

Status openFrameMission(const MissionOptions& m, MissionInput in, const SourceInfo& info, const MissionWords& words,
                        int64_t maxFrames, FrameMission& out) {
    if (Status st = checkMission(m, out.plan); !st.ok()) return st;
    in.width = info.width;
    in.height = info.height;
    words.describe(info, in);
    const uint64_t maxWords = in.max_words;
    in.max_words = 0;
    if (out.plan.resuming)  // frames of the checkpoint's size and words of its V first: nothing else matters otherwise
        if (Status st = planMission(m, in, out.plan); !st.ok()) return st;
    if (Status st = countFrames(m, info, maxFrames, out); !st.ok()) return st;
    in.length = out.frames;
    in.max_words = maxWords;
    if (!out.plan.resuming)
        if (Status st = planMission(m, in, out.plan); !st.ok()) return st;
    Status st;
    out.engine = openMission(m, out.plan, st);
    return out.engine ? Status() : st;
}

ReadStatus readMissionFrame(FrameSource& source, int64_t skipThrough, int64_t before, Frame& frame) {
    for (;;) {
        const ReadStatus rs = source.read(frame);
        if (rs != ReadStatus::Ok) return rs;
        if (source.info().live) frame.index += before;  // after the checkpoint's frames
        else if (frame.index <= skipThrough) continue;  // in the checkpoint already
        return rs;
    }
}

} // namespace rost::vision
