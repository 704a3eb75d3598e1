#pragma once

// A mission's engine, made or resumed by one policy for every face (the rost
// tool's `run` and `refine`, rost_node). A face parses its own arguments into
// MissionOptions, says what its input decides (MissionInput), and the
// library does the rest, once:
//   * a new mission: V, the frame size, ring.steps, max.words and threads
//     come from the input unless the user set them; the result is checked by
//     the settings' one check and the problem named in the face's spelling;
//   * a resumed one: the checkpoint fixes the model (K, V, alpha, ..., the
//     frame size, the seed); a model setting given with another value is
//     refused at start-up, naming it; refinement settings (sampler, eta, q,
//     budget) are the checkpoint's unless given, and then the run continues
//     under them (not bit for bit); runtime settings (queue, drop, threads,
//     thread priority, engine flags) are this process's;
//   * the engine: made from the plan, the checkpoint's state loaded, a
//     starting topic model added.
// Set-up code: allocates, reads files.

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/settings.hpp"
#include "rost/status.hpp"
#include "rost/word_stream.hpp"

namespace rost {

// How a face names things in its messages.
struct MissionNames {
    // A setting in a problem: "-K/--topics" (the tool), "~K" (rost_node), "K" (a key).
    std::function<std::string(const SettingSpec&)> setting = [](const SettingSpec& s) { return std::string(s.key); };
    // A value the user gave, as they gave it: "-K 8", "k.conf:2: key 'K' = 8", "~K = 8".
    std::function<std::string(const SettingSpec&, const std::string&)> given = [](const SettingSpec& s,
                                                                                 const std::string& v) {
        return std::string(s.key) + " = " + v;
    };
    // What to leave out to keep a resumed mission's value: "-K", "the key", "~K".
    std::function<std::string(const SettingSpec&)> leave = [](const SettingSpec& s) { return std::string(s.key); };
    // A whole setting's problem, when the face says more than `setting` can (the tool
    // names a --config file's line); unset: the problem with each setting spelled by `setting`.
    std::function<std::string(const SettingProblem&)> problem;
    // A setting as a checkpoint's value is named: "m.ckpt's ring.steps = 12" (a
    // key: the tool's config files, rost_node's checkpoint notes); Python's
    // keyword ("m.ckpt's ring_steps = 12").
    std::function<std::string(const SettingSpec&)> key = [](const SettingSpec& s) { return std::string(s.key); };
    std::string resume = "--resume";              // the option that names the checkpoint
    std::string topicmodel = "--in.topicmodel";   // the option that names a starting topic model
    std::string positions = "--positions";        // the option that names a word stream's positions
    std::string max_frames = "--max-frames";      // the option that limits a frame mission
};

struct MissionOptions {
    Settings settings;               // validated
    std::vector<std::string> given;  // keys the user set; the others the input may decide
    std::string resume;              // a checkpoint to carry on ("": a new mission)
    std::string in_topicmodel;       // a topicmodel.csv to start from ("": none)
    // The other files the face reads (the stream and its positions, a
    // settings file, a vocabulary, a video): no output of the mission may be one.
    std::vector<std::string> inputs;
    // Whether the input `input` (one of `inputs`) would read the file `path`
    // besides being it: a file among an image directory's frames, one an
    // input glob matches (the face's own rule: vision::inputWouldRead).
    // Unset: an input is its one file.
    std::function<bool(const std::string& input, const std::string& path)> would_read;
    MissionNames names;

    bool isGiven(std::string_view key) const;
    // The frame size: a face's own option (`width`, `height`; 0 when not
    // given), else frame.width/frame.height given as settings, else 0 (the
    // input decides). Every face sizes its input by this one rule.
    int frameWidth(int width) const;
    int frameHeight(int height) const;
};

// What the input decides (each 0 or -1 when it does not know).
struct MissionInput {
    int width = 0, height = 0;  // the frames' size (resuming: must be the checkpoint's; 0: the checkpoint's)
    int V = 0;                  // word ids the input needs (unless V is given)
    // The input's words come from a fixed vocabulary of V words (an extractor):
    // a resumed model's V must be exactly V unless V is given (its ids would
    // mean other words), and a V the user gives must hold them.
    bool vocabulary = false;
    std::string words_detail;  // what makes the words, for messages: "ORB 5000 + intensity 256 + hue 180"
    int64_t length = -1;        // observations it holds, when known: ring.steps keeps them all (up to 2048)
    // A batch over the whole input (rost-cli's commands): every observation
    // stays refinable to the end, so ring.steps is exactly the input's time
    // steps, without the 2048 cap (the schema's range is the limit, and a
    // longer input is refused naming it), and max.words is the longest
    // observation, uncapped too (no word is subsampled away).
    bool keep_all = false;
    // The most words one cell receives under the planned geometry (frame
    // size, cell.space, cell.time): cell.capacity unless given, so no word
    // is subsampled away. Unset: the setting's cell.capacity.
    std::function<uint64_t(const Config&)> busiest_cell;
    uint64_t max_words = 0;     // the most words an observation can hold: max.words (0: the setting's)
    int threads = 1;            // refinement threads unless `threads` is given
    EngineFlags flags;          // what the face asks the engine to compute
};

struct MissionPlan {
    EngineConfig config;
    bool resuming = false;
    CheckpointInfo checkpoint;        // what --resume holds (resuming)
    bool refinement_changed = false;  // a refinement setting given differs from the checkpoint's
};

// Start-up, before any input is read: with `resume`, reads the checkpoint and
// refuses what it cannot carry on (a model setting given with another value,
// a starting topic model); `plan` then holds the checkpoint's model and
// refinement. Without, nothing to do.
Status checkMission(const MissionOptions& m, MissionPlan& plan);

// The engine's configuration for this input: derived (a new mission) or the
// checkpoint's (checkMission first, done here if not yet).
Status planMission(const MissionOptions& m, const MissionInput& input, MissionPlan& plan);

// The engine of a plan: made, the checkpoint's state loaded, the starting
// topic model added. nullptr and `status` on failure, naming the option.
std::unique_ptr<Engine> openMission(const MissionOptions& m, const MissionPlan& plan, Status& status);

// An output of the mission besides its results (a checkpoint, a bag),
// checked before any input is read, by every face: an unwritable path fails
// at once; one that is an input is refused, since writing there would
// replace or change it: the file of in_topicmodel, resume or one of
// `inputs`, however spelled (a link to it included), or a file one of them
// would read (`would_read`: an image directory's frame, a file an input glob
// matches). Only the mission's checkpoint may be the one resumed (a mission
// carried on in place). Errors start with `name`, the face's name for the
// output ("--checkpoint", "~checkpoint", "rost.Mission.save"). Relative
// paths are the current directory's.
enum class MissionOutput { Checkpoint, Other };
Status checkMissionOutput(const MissionOptions& m, const std::string& name, const std::string& path,
                          MissionOutput kind = MissionOutput::Checkpoint);

// checkMissionOutput without the probe: only whether writing `path` would
// replace or change an input. For outputs whose writability a face checks
// otherwise (the tool's results, probed with their --out directory).
Status checkMissionOutputOverlap(const MissionOptions& m, const std::string& name, const std::string& path,
                                 MissionOutput kind = MissionOutput::Other);

// Whether two paths name one file: the same text, the same file where both
// exist (another spelling, a link), else the same path once made absolute
// and normal.
bool sameFile(const std::string& a, const std::string& b);

// ---- a word stream's mission (`rost refine`, Python's rost.Mission) ----------------

// A word stream read whole from files (rost/word_stream.hpp formats).
struct StreamMissionInput {
    std::string words;      // words.csv
    std::string positions;  // positions.csv; "": every word at (0, 0), one cell per time step
    int width = 0, height = 0;  // the face's own frame option (0: MissionOptions::frameWidth's rule)
    int read_threads = 1;       // 2: the positions parsed beside the words (same result)
    MissionInput base;          // what the face decides: refinement threads, engine flags
};

// The stream, the plan and the engine made for it (or resumed), and the
// observations still to play: a checkpoint's own are skipped.
struct StreamMission {
    WordStream stream;
    MissionPlan plan;
    std::size_t skipped = 0;
    std::unique_ptr<Engine> engine;
    std::span<const StreamObservation> todo() const {
        return {stream.observations.data() + skipped, stream.observations.size() - skipped};
    }
};

// Reads the stream and opens its mission by the one policy: resuming, the
// checkpoint fixes V and the frame size before the words are read (a word or
// position outside them is an error naming file:line:col), and the stream is
// either the one the checkpoint was made from (its observations skipped) or
// what came after it; a new mission takes V, the frame, ring.steps and
// max.words from the data unless given. An empty stream, one without words,
// and a resume with nothing left are refused, naming the file.
Status openStreamMission(const MissionOptions& m, const StreamMissionInput& in, StreamMission& out);

} // namespace rost
