#pragma once

// A mission over frames (rost/mission.hpp's session, for video, images,
// cameras and bags): the words its settings name, and the engine planned for
// the source's frames or resumed from a checkpoint, with where the source
// stands against it. The rost tool's `run` and Python's rost.vision.Mission
// are faces over it. Set-up code: allocates, reads files.

#include <cstdint>
#include <memory>
#include <string>

#include "rost/mission.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/vocabulary.hpp"
#include "rost/vision/words.hpp"
#include "rost/word_settings.hpp"

namespace rost::vision {

// The words of a mission's frames: the extractors the word settings name,
// with the vocabulary ORB words need.
struct MissionWords {
    ExtractorConfig extractors;
    std::shared_ptr<const Vocabulary> vocabulary;
    std::unique_ptr<WordExtractor> extractor;

    // `vocabularyPath` "": the vocabulary shipped with rost.
    Status open(const WordSettings& settings, const std::string& vocabularyPath);
    // What they decide of a mission on `info`'s frames: V (a vocabulary's:
    // a resumed model's must be the same), what makes the words (for
    // messages), the most words a frame can give (max.words).
    void describe(const SourceInfo& info, MissionInput& in) const;
};

// A frame mission's engine, and where its source stands against the checkpoint.
struct FrameMission {
    MissionPlan plan;
    int64_t skip_through = -1;  // a file's frames up to this index are in the checkpoint
    int64_t before = 0;         // frames the checkpoint has (a camera's are numbered after them)
    int64_t frames = -1;        // frames this run plays, when known
    std::unique_ptr<Engine> engine;

};

// Plans the mission for `info`'s frames and `words` by the one policy
// (planMission: the frame size, V, ring.steps and max.words from the input
// unless given; resuming, the checkpoint's, its frame size and V checked
// first), counts what is left to play (`maxFrames` counts the whole mission,
// the checkpoint's frames too; 0: all), and opens the engine. `in` carries
// what the face decides (threads, engine flags).
Status openFrameMission(const MissionOptions& m, MissionInput in, const SourceInfo& info, const MissionWords& words,
                        int64_t maxFrames, FrameMission& out);

// The next frame of `source` a mission models (FrameMission's skip_through
// and before): a file's frames the checkpoint holds are skipped, a live
// source's are numbered after them. Ok, End, or Error (source.error() says
// why). Allocates nothing of its own (the capture thread calls it).
ReadStatus readMissionFrame(FrameSource& source, int64_t skipThrough, int64_t before, Frame& frame);

} // namespace rost::vision
