#pragma once

// The `rost` command-line tool: options shared by its commands and the
// commands themselves. main.cpp parses the command line (CLI11) into these
// structs; each command returns an exit code.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/words.hpp"

namespace CLI {
class App;
}

namespace rost::tool {

// Exit codes.
inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 2;        // bad input, bad option, unreadable file, write failure
inline constexpr int kExitInterrupted = 130; // Ctrl-C on a file input (outputs discarded)

// Model and refinement options, named as earlier ROST tools named them.
struct ModelOptions {
    int K = 16;
    int V = 0;  // 0: what the words need (the extractors' vocabulary, or the largest id + 1)
    double alpha = 0.1;
    double beta = 0.5;
    int cell_space = 64;
    int cell_time = 1;
    int g_space = 1;
    int g_time = 1;
    std::string sampler = "uni+now";
    double eta = 0.5;
    double q = 0.5;
    uint64_t budget_refines = 40; // time steps refined per observation (count budget): ~3 ms a 640x480 frame on one x86 core
    double budget_ms = 0.0;       // > 0: time budget per observation instead
    uint64_t seed = 1;
    int ring = 0;                 // steps kept refinable; 0: the whole input when its length is known (up to 2048), else 256
    int cell_capacity = 256;
    int max_words = 4096;
    std::string eviction = "keep";
    int final_sweeps = 0;         // batch Gibbs sweeps over the window at the end of the stream
    std::string in_topicmodel;    // K x V counts to start from
    std::string config;           // --config: key = value settings (rost/config_file.hpp) under explicit options
    std::string checkpoint;       // --checkpoint: engine state saved every checkpoint_every observations and at the end
    uint64_t checkpoint_every = 100;
    std::string resume;           // --resume: carry on the mission a checkpoint holds
    // Long names of the options set on the command line or by --config
    // ("-K", "--alpha", ...): with --resume, those the checkpoint fixes are
    // compared with it.
    std::vector<std::string> given;
    // For those a --config file set: the option -> "FILE:LINE: key 'K'" (messages name the file).
    std::vector<std::pair<std::string, std::string>> given_by_file;
};

// Fills an EngineConfig (model geometry comes from the caller). Errors name the option.
Status makeEngineConfig(const ModelOptions& m, int width, int height, int V, int64_t frames_hint, bool realtime,
                        EngineConfig& out);

// --resume FILE: the configuration to carry on with. The checkpoint fixes
// the model (K, V, alpha, beta, cells, neighbourhood, ring, capacities,
// eviction, seed) and the frame size: an option that sets one of these to a
// different value is an error naming it, as are --in.topicmodel and frames
// of another size. Refinement options given (sampler, eta, q, budget) replace
// the checkpoint's (`refinementChanged`: the run then continues under them,
// not bit for bit); runtime settings are the caller's to set. `info`
// describes the checkpoint; `frameWidth`/`frameHeight` are the input's
// (0: take the checkpoint's).
Status resumeConfig(const ModelOptions& m, int frameWidth, int frameHeight, bool realtime, EngineConfig& out,
                    CheckpointInfo& info, bool& refinementChanged);

// Loads the --resume checkpoint into `engine` (made with resumeConfig's
// configuration). Errors start with "--resume: ".
Status loadResumed(const ModelOptions& m, bool refinementChanged, Engine& engine);

// --checkpoint FILE: a writer that captures `engine` every checkpoint_every
// observations from its observation hook (wrapping the hook already set: a
// copy on the refining thread, no allocation; a writer thread writes the
// file). `out` stays empty without --checkpoint. Errors start with "--checkpoint: ".
Status attachCheckpoints(Engine& engine, const ModelOptions& m, std::unique_ptr<CheckpointWriter>& out);
// After the last observation: waits for a save in progress, captures the
// final state and writes it. Errors start with "--checkpoint: ".
Status finishCheckpoints(CheckpointWriter& writer);

struct RunOptions {
    std::vector<std::string> inputs;
    std::string out;
    ModelOptions model;
    // Words.
    std::string vocabulary;  // empty: the built-in default
    vision::ExtractorConfig words;
    // Frames.
    int width = 0;  // resize frames to this width (height keeps the aspect ratio unless given)
    int height = 0;
    int64_t max_frames = 0;  // 0: all
    int camera_width = 640, camera_height = 480;
    std::string camera_format;
    // Realtime.
    bool realtime = false;
    int queue = 8;
    std::string drop = "oldest";
    bool fifo = false;
    int cpu = -1;
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
    uint32_t words = 5000;
    int features = 500;   // ORB keypoints per frame used for training
    int every = 1;        // use every N-th frame
    int64_t max_frames = 0;
    int64_t max_descriptors = 400000;
    int iterations = 40;
    uint64_t seed = 1;
    int threads = 2;
    int width = 0;
    bool quiet = false;
    std::string command_line;
};

// --config FILE: the file's keys set the options the command line did not
// give (`given("--alpha")`, `given("-K")`: was that option on the command
// line). `run` or `ref` receives the command's own keys (queue, drop,
// threads; frame size). Errors name the file, line and key.
Status applyConfigFile(const std::string& path, const std::function<bool(const std::string&)>& given, ModelOptions& m,
                       RunOptions* run, RefineOptions* ref);

int runCommand(const RunOptions& o);
int refineCommand(const RefineOptions& o);
int vocabCommand(const VocabOptions& o);
int camerasCommand();

// Prints "rost: error: <message>" on one line to stderr and returns kExitError.
int fail(const std::string& message);

} // namespace rost::tool
