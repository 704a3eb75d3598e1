#pragma once

// The stages of `rost run`, composed by runCommand (run.cpp):
//   frame source -> word extraction (WordsStage, Capture)
//   -> engine (RunEngine: its capture-to-refiner queue and refiner thread)
//   -> result sinks (sinks.hpp).
// Set-up fails here, before any output, with a message for fail().

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include <opencv2/core.hpp>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/word_stream.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/mission.hpp"
#include "rost/vision/words.hpp"
#include "bag.hpp"
#include "spsc_ring.hpp"
#include "tool.hpp"

namespace rost::tool {

// The refinement budget as the tool prints it (start-up line, run.txt,
// summary.png): "40 refines", "5000 tokens" or "5 ms", then `per`.
std::string budgetText(const Budget& b, const std::string& per = "");

// A captured frame on its way to the writer (overlay, thumbnails, frames.csv).
struct FrameSlot {
    int64_t frame = 0;
    int64_t timestamp_us = 0;
    uint32_t words = 0, orb = 0, intensity = 0, hue = 0;
    bool pushed = false;  // the engine queued it (false: refused by a full queue)
    cv::Mat image;
};
using FrameRing = SpscRing<FrameSlot>;

// Frame source and word extractor (with its vocabulary).
struct WordsStage {
    std::unique_ptr<vision::FrameSource> source;
    vision::SourceInfo info;
    bool live = false;  // a camera among the inputs
    vision::MissionWords words;  // the extractors and their vocabulary (rost/vision/mission.hpp)
    const bag::BagFrameSource* bag = nullptr;  // the source, when the input is a bag

    Status open(const RunOptions& o);
    // The source's notes (images skipped as too small, frames scaled, a video
    // shorter than its duration), one "rost: " line each on stderr, even with
    // -q: they say how the results differ from the input (docs/tool.md).
    void printNotes() const;

private:
    Status openSource(const RunOptions& o, const vision::SourceOptions& so);
};

// The engine, made for the input or resumed from a checkpoint, and where
// the mission stands in the input.
struct RunEngine {
    EngineConfig ec;
    CheckpointInfo resumed;
    bool resuming = false;
    bool refinementChanged = false;
    int V = 0;
    int64_t skipThrough = -1;  // frames up to this index are in the checkpoint
    int64_t before = 0;        // frames the checkpoint has (skipThrough + 1)
    int64_t frames = -1;       // frames this run plays, when known
    std::unique_ptr<Engine> engine;

    // The library's frame mission (rost/vision/mission.hpp) plans or resumes.
    Status open(const RunOptions& o, const WordsStage& w, bool realtime);
    // The set-up lines on stderr (without -q).
    void describe(const RunOptions& o, const WordsStage& w, bool realtime) const;
};

// The capture stage: one frame -> words -> the engine's queue, and the
// frame to the writer's ring. Runs on the capture thread under --realtime.
class Capture {
public:
    using Clock = std::chrono::steady_clock;
    Capture(WordsStage& w, const RunEngine& e, FrameRing& ring, int64_t maxFrames)
        : w_(w), e_(e), ring_(ring), max_frames_(maxFrames) {}
    // False at the end of the input (or of --max-frames, or on a read error).
    bool produceOne(bool pace, Clock::time_point t0);

    int64_t captured() const noexcept { return captured_.load(std::memory_order_relaxed); }
    uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
    const std::string& readError() const noexcept { return read_error_; }

private:
    bool readNext();
    void pace(Clock::time_point t0);

    WordsStage& w_;
    const RunEngine& e_;
    FrameRing& ring_;
    int64_t max_frames_;
    vision::Frame frame_;
    Clock::time_point due_{};  // when the frame in hand is due (pace)
    int64_t last_us_ = 0;      // the time stamp of the frame played before it
    vision::FrameWords words_;
    std::string read_error_;
    std::atomic<int64_t> captured_{0};
    std::atomic<uint64_t> dropped_{0};
};

// `rost refine`'s source: a word stream read from files (earlier ROST
// formats), the engine made for it or resumed, and the observations it
// still has to play (those a checkpoint holds are skipped).
struct StreamStage {
    WordStream ws;
    MissionPlan plan;  // the library's mission session (rost/mission.hpp)
    EngineConfig ec;
    CheckpointInfo resumed;
    bool resuming = false;
    bool refinementChanged = false;
    std::size_t skipped = 0;
    std::unique_ptr<Engine> engine;

    Status open(const RefineOptions& o);
    std::span<const StreamObservation> todo() const {
        return {ws.observations.data() + skipped, ws.observations.size() - skipped};
    }
};

} // namespace rost::tool
