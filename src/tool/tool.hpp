#pragma once

// The `rost` command-line tool: options shared by its commands and the
// commands themselves. main.cpp parses the command line (CLI11) into these
// structs; each command returns an exit code.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/mission.hpp"
#include "rost/settings.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/vocabulary.hpp"
#include "rost/vision/words.hpp"

namespace CLI {
class App;
class Validator;
}

namespace rost::tool {

// Exit codes.
inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 2;        // bad input, bad option, unreadable file, write failure
inline constexpr int kExitInterrupted = 130; // Ctrl-C on a file input (outputs discarded)

// The settings of a run or refine command: every setting of the schema
// (rost/settings_schema.hpp), layered defaults < --config FILE < options,
// and the mission's files.
struct ModelOptions {
    Settings settings;
    std::string in_topicmodel;    // K x V counts to start from
    std::string config;           // --config: key = value settings under explicit options
    std::string checkpoint;       // --checkpoint: engine state saved every checkpoint.every observations and at the end
    std::string resume;           // --resume: carry on the mission a checkpoint holds
    // Keys set on the command line or by --config ("K", "alpha", ...): the
    // tool derives V, ring.steps and the frame size from its input unless
    // set, and with --resume compares the model's with the checkpoint's.
    std::vector<std::string> given;
    // For keys a --config file set (and the command line did not): the key -> "FILE:LINE: key 'K' = ".
    std::vector<std::pair<std::string, std::string>> given_by_file;

    bool isGiven(std::string_view key) const;
};

// --threads when given; else the CPUs this process may run on, less one
// for the capture thread of a realtime run, at least 1.
int toolThreads(const ModelOptions& m, bool realtime);

// The option that sets `key` on the command line ("-K", "--alpha").
std::string optionName(const SettingSpec& spec);
// Every name of a setting's option: "--queue.slots/--queue", "-K/--topics";
// the frame size is "the input's frame.width".
std::string optionNames(const SettingSpec& spec);
// A setting's problem in the tool's spelling: the option ("--eta = 2, allowed
// [0, 1]"), or the --config file's line and key when the file set it.
std::string settingProblemText(const ModelOptions& m, const SettingProblem& p);

// The mission's options as the library's mission session takes them
// (rost/mission.hpp: one policy for deriving and resuming), named in the
// tool's spelling: options, or the --config file's line and key. The input's
// part the tool decides: its threads (toolThreads) and engine flags.
MissionOptions missionOptions(const ModelOptions& m);
MissionInput missionInput(const ModelOptions& m, bool realtime);

// Every output file of a mission besides the output directory (--checkpoint,
// --out.bag), probed before any work by the library's check
// (checkMissionOutput): an unwritable one fails at once and nothing is
// written; none may be one of `inputs` (or the --in.topicmodel, --config or,
// for the bag, --resume file), which it would replace or change; nor may
// they be one file, or one of `results` (the files the run writes in --out).
// Errors start with the option.
// `wouldRead`: which files the inputs read besides being them
// (MissionOptions::would_read; `rost run`'s vision::inputWouldRead). Nor may
// the run's results replace one of its inputs (a words file in --out named
// perplexity.csv): "--out: ..." names it.
Status probeMissionOutputs(const ModelOptions& m, const std::string& outBag, const std::vector<std::string>& inputs,
                           const std::vector<std::string>& results,
                           std::function<bool(const std::string&, const std::string&)> wouldRead = {});

// --checkpoint FILE: a writer the engine captures into every checkpoint_every
// observations (Engine::captureCheckpoints: a copy on the refining thread at
// an observation boundary, no allocation; a writer thread writes the file). `out` stays empty without --checkpoint. Errors start with "--checkpoint: ".
Status attachCheckpoints(Engine& engine, const ModelOptions& m, std::unique_ptr<CheckpointWriter>& out);
// After the last observation: waits for a save in progress, captures the
// final state and writes it. Errors start with "--checkpoint: ".
Status finishCheckpoints(CheckpointWriter& writer);

struct RunOptions {
    std::vector<std::string> inputs;
    std::string out;
    ModelOptions model;  // the word settings too (model.settings.words)
    std::string vocabulary;  // empty: the built-in default
    // Frames.
    int width = 0;  // resize frames to this width (height keeps the aspect ratio unless given)
    int height = 0;
    int64_t max_frames = 0;  // 0: all
    int camera_width = 640, camera_height = 480;
    std::string camera_format;
    // Bags (built with ROS): the image topic to read, and a bag to write the results into.
    std::string topic;
    std::string out_bag;
    // Realtime (queue, drop and thread settings are in model.settings).
    bool realtime = false;
    // Outputs.
    bool overlay = true;
    std::string overlay_format = "mp4";  // mp4 or avi
    bool summary = true;
    bool quiet = false;
    std::string command_line;  // recorded in run.txt
};

struct RefineOptions {
    std::string words;
    std::string positions;
    std::string out;
    ModelOptions model;
    int width = 0, height = 0;  // frame size for positions; 0: from the largest position
    bool summary = true;
    bool quiet = false;
    std::string command_line;
};

struct VocabOptions {
    std::vector<std::string> inputs;
    std::string out;
    uint32_t words = vision::KMajorityOptions{}.words;  // training's defaults are the library's
    int features = vision::kTrainingFeatures;           // ORB keypoints per frame used for training
    int every = 1;        // use every N-th frame
    int64_t max_frames = 0;
    int64_t max_descriptors = 400000;
    int iterations = vision::KMajorityOptions{}.max_iterations;
    uint64_t seed = vision::KMajorityOptions{}.seed;
    int threads = vision::KMajorityOptions{}.threads;
    int width = 0;
    bool quiet = false;
    std::string command_line;
};

// The settings options of `rost run`, `rost refine` and `rost config`, one
// per setting of the schema (its key as a long option, its documentation as
// help), and the mission options; `apply()` after parsing layers
// defaults < --config FILE < the options given, then validates. Errors name
// the option, or the file, line and key.
class SettingsOptions {
public:
    enum class Command : uint8_t { Run, Refine, Config };
    SettingsOptions(CLI::App& app, ModelOptions& m, Command cmd);
    ~SettingsOptions();
    // `run` or `ref` receive what a config file may set of their own (frame size for refine).
    Status apply(RunOptions* run, RefineOptions* ref);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// A path option's value may not be empty: `--checkpoint "$CKPT"` with CKPT
// unset is refused ("--checkpoint: no file given"), not read as no
// checkpoint; `rost run "$VIDEO"` with VIDEO unset says "input: no input
// given", not a missing file of no name.
// The validator is named kPathValidator: an option that has it takes a path.
enum class PathKind { File, Directory, Input };
inline constexpr const char* kPathValidator = "path";
const CLI::Validator& givenPath(PathKind kind = PathKind::File);

// `rost config`: prints every setting as a configuration file.
int configCommand(const ModelOptions& m);

int runCommand(const RunOptions& o);
int refineCommand(const RefineOptions& o);

// `rost merge MODEL... --out DIR`: topic models (topicmodel.csv or checkpoints)
// matched into one global set (rost/merge.hpp; docs/fleet.md).
struct MergeCliOptions {
    std::vector<std::string> models;
    std::string out;
    double threshold = 0.6;
    double beta = 0.01;
    bool quiet = false;
};
int mergeCommand(const MergeCliOptions& o);
int vocabCommand(const VocabOptions& o);
int camerasCommand();

// Prints "rost: error: <message>" on one line to stderr and returns kExitError.
int fail(const std::string& message);

} // namespace rost::tool
