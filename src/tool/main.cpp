// The `rost` command-line tool. See docs/tool.md, or `rost --help` and
// `rost run --help`.

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "rost/version.hpp"
#include "tool.hpp"

using namespace rost::tool;

namespace {

std::string joinArgs(int argc, char** argv) {
    std::string s;
    for (int i = 0; i < argc; ++i) {
        if (i) s += ' ';
        const std::string a = argv[i];
        if (a.find_first_of(" \t'\"*?") != std::string::npos) s += "'" + a + "'";
        else s += a;
    }
    return s;
}

void addModelOptions(CLI::App& app, ModelOptions& m) {
    const char* g = "Model";
    app.add_option("-K,--topics", m.K, "topics (1..1024)")->group(g);
    app.add_option("-V,--vocabulary-size", m.V,
                   "vocabulary size; 0: what the words need (run: the extractors' V, 5436 by default; refine: "
                   "largest word id + 1). Larger values leave ids unused; a word id >= V is an error")
        ->group(g);
    app.add_option("--alpha", m.alpha, "Dirichlet prior on a neighbourhood's topic mix (paper: 0.1)")->group(g);
    app.add_option("--beta", m.beta, "Dirichlet prior on a topic's words (paper: 0.5)")->group(g);
    app.add_option("--cell.space", m.cell_space, "cell width and height in pixels (paper: 64)")->group(g);
    app.add_option("--cell.time", m.cell_time, "observations (frames) per temporal cell")->group(g);
    app.add_option("--g.space", m.g_space, "spatial neighbourhood radius in cells (1: the 4 neighbours)")->group(g);
    app.add_option("--g.time", m.g_time, "temporal neighbourhood radius in cells (1: previous and next)")->group(g);
    app.add_option("--ring.steps", m.ring,
                   "time steps kept refinable; 0: the whole input when its length is known (up to 2048), else 256")
        ->group(g);
    app.add_option("--cell.capacity", m.cell_capacity, "words a cell holds; more are uniformly subsampled")->group(g);
    app.add_option("--max.words", m.max_words, "words an observation holds; more are uniformly subsampled")->group(g);
    app.add_option("--eviction", m.eviction,
                   "what a step leaving the window does to the topic model: keep its counts or subtract them")
        ->check(CLI::IsMember({"keep", "subtract"}))
        ->group(g);
    app.add_option("--in.topicmodel", m.in_topicmodel,
                   "start from a topic model: a topicmodel.csv of an earlier run (K rows of V counts)")
        ->type_name("FILE")
        ->group(g);

    const char* r = "Refinement (paper section VI)";
    app.add_option("--sampler", m.sampler,
                   "which time step to refine next, P(t|T): now, uniform, agep (age-proportional), exp "
                   "(exponential), or a mixture uni+now, agep+now, uni+exp, agep+exp")
        ->check(CLI::IsMember({"now", "uniform", "agep", "exp", "uni+now", "agep+now", "uni+exp", "agep+exp"}))
        ->group(r);
    app.add_option("--eta", m.eta, "mixing weight of the local part (now / exp) in a mixture sampler, 0..1")->group(r);
    app.add_option("--q", m.q, "parameter of the exponential sampler, (0, 1]")->group(r);
    auto* refines = app.add_option("--budget.refines", m.budget_refines,
                                   "count budget: time steps refined per observation (reproducible)")
                        ->group(r);
    auto* ms = app.add_option("--budget.ms", m.budget_ms,
                              "time budget instead: milliseconds of refinement per observation (the paper's T_R; "
                              "not reproducible)")
                   ->check(CLI::PositiveNumber)
                   ->group(r);
    refines->excludes(ms);
    app.add_option("--final.sweeps", m.final_sweeps, "batch Gibbs sweeps over the window at the end of the stream")
        ->group(r);
    app.add_option("--seed", m.seed, "random seed; same seed, input and count budget give the same outputs")->group(r);

    const char* t = "Missions (docs/trust.md)";
    app.add_option("--config", m.config,
                   "settings file: `key = value` lines named like these options (K, alpha, cell.space, sampler, "
                   "budget.refines, queue.slots, ...); options given on the command line win")
        ->type_name("FILE")
        ->group(t);
    app.add_option("--checkpoint", m.checkpoint,
                   "save the engine's whole state to FILE every --checkpoint.every observations and at the end "
                   "(atomically: a crash leaves the previous checkpoint)")
        ->type_name("FILE")
        ->group(t);
    app.add_option("--checkpoint.every", m.checkpoint_every, "observations between checkpoints")
        ->check(CLI::PositiveNumber)
        ->group(t);
    app.add_option("--resume", m.resume,
                   "carry on the mission FILE (a --checkpoint) holds: its model, window and random state; input "
                   "frames or observations it already has (time stamp up to its last) are skipped, a camera's "
                   "frames are numbered after them. Model options may be repeated but not changed")
        ->type_name("FILE")
        ->group(t);
}

// The model options (addModelOptions) given on `cmd`'s command line, by the
// name ModelOptions::given uses.
void recordGiven(const CLI::App* cmd, ModelOptions& m) {
    for (const CLI::Option* o : cmd->get_options()) {
        if (o->count() == 0) continue;
        for (const std::string& n : o->get_lnames()) m.given.push_back("--" + n);
        for (const std::string& n : o->get_snames()) m.given.push_back("-" + n);
    }
}

// Whether an option was given on `cmd`'s command line.
std::function<bool(const std::string&)> givenOn(const CLI::App* cmd) {
    return [cmd](const std::string& name) {
        const CLI::Option* o = cmd->get_option_no_throw(name);
        return o != nullptr && o->count() > 0;
    };
}

} // namespace

int main(int argc, char** argv) {
    // The tool reports problems itself, one line each: keep OpenCV's and
    // FFmpeg's own diagnostics off stderr (FFmpeg reads this when first used).
    ::setenv("OPENCV_FFMPEG_LOGLEVEL", "-8", 0);  // AV_LOG_QUIET
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);

    CLI::App app{"rost: realtime online spatiotemporal topic models of video (Girdhar & Dudek).\n"
                 "Words of each frame (ORB, intensity and hue words, each with its pixel position) are added to a\n"
                 "spatiotemporal topic model as they arrive and refined by Gibbs sampling within a budget; the\n"
                 "tool writes the topic labels, perplexity, and the surprise (curiosity) of each frame and cell.",
                 "rost"};
    app.option_defaults()->always_capture_default();
    app.set_version_flag("--version", std::string("rost ") + rost::versionString());
    app.require_subcommand(1);
    app.footer("Exit status: 0 on success, 2 on bad input or options (one line on stderr says what and where),\n"
               "130 when a file run is interrupted. Run `rost COMMAND --help` for a command's options.\n"
               "Quick start: rost run diver.mov --out out/diver   (see docs/tool.md)");

    const std::string cmdline = joinArgs(argc, argv);

    // ---- run
    RunOptions run;
    run.command_line = cmdline;
    CLI::App* runCmd = app.add_subcommand("run", "model a video, image sequence or camera; write labels, perplexity, "
                                                 "surprise, the topic model, an overlay video and a summary plot");
    runCmd->add_option("input", run.inputs,
                       "INPUT...: a video file, a directory of images, a glob ('frames/*.png', quoted), or camera:N. "
                       "Several inputs play one after the other at the first one's size")
        ->required();
    runCmd->add_option("--out,-o", run.out, "output directory (created if needed)")->required();
    addModelOptions(*runCmd, run.model);
    const char* w = "Words";
    runCmd->add_option("--vocabulary", run.vocabulary,
                       "ORB vocabulary file from `rost vocab`; default: the built-in one (share/rost/README.md)")
        ->group(w);
    runCmd->add_option("--orb.features", run.words.orb_features, "ORB keypoints per frame at most")->group(w);
    runCmd->add_option("--orb.fast", run.words.orb_fast_threshold, "ORB's FAST corner threshold")->group(w);
    std::string searchMethod = "tree";
    runCmd->add_option("--orb.search", searchMethod,
                       "how a descriptor finds its word: tree (coarse-to-fine, approximate) or linear (exact)")
        ->check(CLI::IsMember({"tree", "linear"}))
        ->group(w);
    runCmd->add_option("--orb.probes", run.words.search.probes,
                       "coarse buckets the tree search visits (more: closer to exact, slower)")
        ->group(w);
    runCmd->add_option("--thumb.cell", run.words.thumb_cell,
                       "pixels per thumbnail pixel for intensity and hue words (one word each per block)")
        ->group(w);
    bool noOrb = false, noIntensity = false, noHue = false;
    runCmd->add_flag("--no-orb", noOrb, "no ORB words")->group(w);
    runCmd->add_flag("--no-intensity", noIntensity, "no intensity words")->group(w);
    runCmd->add_flag("--no-hue", noHue, "no hue words")->group(w);
    const char* f = "Frames";
    runCmd->add_option("--max-frames", run.max_frames, "stop after this many frames (0: all)")->group(f);
    runCmd->add_option("--width", run.width, "resize frames to this width (0: as the input)")->group(f);
    runCmd->add_option("--height", run.height, "resize frames to this height (0: keep the aspect ratio)")->group(f);
    runCmd->add_option("--camera.width", run.camera_width, "camera:N capture width")->group(f);
    runCmd->add_option("--camera.height", run.camera_height, "camera:N capture height")->group(f);
    runCmd->add_option("--camera.format", run.camera_format,
                       "camera:N pixel format (RGB888, BGR888, XRGB8888, XBGR8888, YUYV, UYVY, NV12, NV21, YUV420, "
                       "R8); default: the first of these the camera offers")
        ->group(f);
    const char* rt = "Realtime";
    runCmd->add_flag("--realtime", run.realtime,
                     "run as onboard: a capture thread (a file paced at its frame rate) and the refiner thread; "
                     "frames are dropped when the refiner falls behind. Always on for camera:N")
        ->group(rt);
    runCmd->add_option("--queue", run.queue, "observations the capture-to-refiner queue holds")->group(rt);
    runCmd->add_option("--drop", run.drop, "when the queue is full, drop the oldest queued or the newest observation")
        ->check(CLI::IsMember({"oldest", "newest"}))
        ->group(rt);
    runCmd->add_flag("--fifo", run.fifo, "ask for SCHED_FIFO priority for the refiner (falls back with a note)")
        ->group(rt);
    runCmd->add_option("--cpu", run.cpu, "pin the refiner to this CPU (-1: no pinning)")->group(rt);
    const char* out = "Output";
    bool noOverlay = false, noSummary = false;
    runCmd->add_flag("--no-overlay", noOverlay, "do not write the overlay video")->group(out);
    runCmd->add_option("--overlay.format", run.overlay_format, "overlay container: mp4 (mp4v) or avi (MJPG)")
        ->check(CLI::IsMember({"mp4", "avi"}))
        ->group(out);
    runCmd->add_flag("--no-summary", noSummary, "do not draw summary.png")->group(out);
    runCmd->add_flag("--quiet,-q", run.quiet, "no progress bar and no notes on stderr (errors still)")->group(out);
    runCmd->footer(
        "Writes into DIR: words.csv (timestamp,w1,w2,...), positions.csv (timestamp,x1,y1,...), topics.csv\n"
        "(timestamp,z1,z2,...: final maximum-likelihood labels), perplexity.csv (frame,instantaneous,final),\n"
        "surprise.csv (frame,surprise), surprise_cells.csv (frame,cell0,...), frames.csv (words per frame and\n"
        "extractor), topicmodel.csv (K rows of V counts), overlay.mp4 (cells tinted by dominant topic),\n"
        "summary.png, run.txt. The timestamp is the input frame index. Files appear only when the run succeeds.");

    // ---- refine
    RefineOptions ref;
    ref.command_line = cmdline;
    CLI::App* refCmd = app.add_subcommand("refine", "model a word stream made elsewhere (words.csv from earlier ROST "
                                                    "tools or another extractor)");
    refCmd->add_option("words", ref.words, "WORDS.csv: timestamp,w1,w2,... per observation")->required();
    refCmd->add_option("--positions", ref.positions,
                       "POSITIONS.csv: timestamp,x1,y1,x2,y2,... for the same observations; without it every word "
                       "is at (0,0): one cell per time step");
    refCmd->add_option("--out,-o", ref.out, "output directory")->required();
    refCmd->add_option("--width", ref.width, "frame width positions lie in (0: the largest x + 1)");
    refCmd->add_option("--height", ref.height, "frame height positions lie in (0: the largest y + 1)");
    addModelOptions(*refCmd, ref.model);
    bool refNoSummary = false;
    refCmd->add_flag("--no-summary", refNoSummary, "do not draw summary.png");
    refCmd->add_flag("--quiet,-q", ref.quiet, "no progress bar and no notes on stderr");
    refCmd->footer("Writes topics.csv, perplexity.csv, surprise.csv, surprise_cells.csv, topicmodel.csv and "
                   "summary.png into DIR.");

    // ---- vocab
    VocabOptions voc;
    voc.command_line = cmdline;
    CLI::App* vocCmd = app.add_subcommand("vocab", "train an ORB vocabulary from footage (k-majority clustering in "
                                                   "Hamming space)");
    vocCmd->add_option("input", voc.inputs, "INPUT...: videos, image directories or globs")->required();
    vocCmd->add_option("--out,-o", voc.out, "vocabulary file to write (format: docs/vision.md)")->required();
    vocCmd->add_option("--words", voc.words, "vocabulary size (paper: 5000)");
    vocCmd->add_option("--features", voc.features, "ORB keypoints per frame used for training");
    vocCmd->add_option("--every", voc.every, "use every N-th frame");
    vocCmd->add_option("--max-frames", voc.max_frames, "frames read per input at most (0: all)");
    vocCmd->add_option("--max-descriptors", voc.max_descriptors,
                       "descriptors clustered at most (a seeded uniform sample beyond)");
    vocCmd->add_option("--iterations", voc.iterations, "k-majority iterations at most");
    vocCmd->add_option("--seed", voc.seed, "random seed (initial centres, sampling)");
    vocCmd->add_option("--threads", voc.threads, "threads for the assignment step (the result does not depend on it)");
    vocCmd->add_option("--width", voc.width, "resize frames to this width first (0: as the input)");
    vocCmd->add_flag("--quiet,-q", voc.quiet, "no progress on stderr");

    // ---- cameras
    CLI::App* camCmd = app.add_subcommand("cameras", "list the cameras libcamera can see");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);
        return fail(std::string(e.what()) + " (see rost --help)");
    }

    if ((runCmd->parsed() && givenOn(runCmd)("--resume") && run.model.resume.empty()) ||
        (refCmd->parsed() && givenOn(refCmd)("--resume") && ref.model.resume.empty()))
        return fail("--resume: no file given");
    if (runCmd->parsed()) recordGiven(runCmd, run.model);
    if (refCmd->parsed()) recordGiven(refCmd, ref.model);
    if (runCmd->parsed() && !run.model.config.empty()) {
        const rost::Status st = applyConfigFile(run.model.config, givenOn(runCmd), run.model, &run, nullptr);
        if (!st.ok()) return fail("--config: " + st.message());
    }
    if (refCmd->parsed() && !ref.model.config.empty()) {
        const rost::Status st = applyConfigFile(ref.model.config, givenOn(refCmd), ref.model, nullptr, &ref);
        if (!st.ok()) return fail("--config: " + st.message());
    }
    if (runCmd->parsed()) {
        (void)rost::vision::parseSearchMethod(searchMethod, run.words.search.method);  // checked by IsMember
        run.words.orb = !noOrb;
        run.words.intensity = !noIntensity;
        run.words.hue = !noHue;
        run.overlay = !noOverlay;
        run.summary = !noSummary;
        return runCommand(run);
    }
    if (refCmd->parsed()) {
        ref.summary = !refNoSummary;
        return refineCommand(ref);
    }
    if (vocCmd->parsed()) return vocabCommand(voc);
    if (camCmd->parsed()) return camerasCommand();
    return kExitError;
}
