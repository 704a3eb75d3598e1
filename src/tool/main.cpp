// The `rost` command-line tool. See docs/tool.md, or `rost --help` and
// `rost run --help`.
//
// Built twice (docs/tool.md, "Two programs"): `rost` itself (ROST_TOOL_LIGHT)
// runs `refine` and `config` and links no OpenCV I/O, so it starts in
// milliseconds; for `run`, `vocab` and `cameras` it parses the command line
// (errors and --help are its own) and then becomes `rost-vision`, the same
// program with the frame sources, the video writer and ROS bags.

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <new>
#include <string>

#if ROST_TOOL_LIGHT
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#endif

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "cli_given.hpp"
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

// A count or size where 0 means "all" or "from the input": a negative one is
// refused with the option's name (the settings schema checks its own keys;
// these are the commands' own options). CLI11's NonNegativeNumber would print
// a range up to DBL_MAX.
const CLI::Validator& nonNegative() {
    static const CLI::Validator v(
        [](std::string& s) {
            std::size_t at = 0;
            while (at < s.size() && (s[at] == ' ' || s[at] == '\t')) ++at;
            return at < s.size() && s[at] == '-' ? "expected 0 or more, found '" + s + "'" : std::string();
        },
        "");
    return v;
}

// An option whose value is another option's name is refused
// (cli_given.hpp, refuseOptionsAsValues); one that takes a path says how a
// file named like an option is given.
bool takesAPath(CLI::Option* opt) {
    try {
        opt->get_validator(kPathValidator);
        return true;
    } catch (const CLI::OptionNotFound&) {
        return false;
    }
}

// `rost run`'s options.
struct RunCli {
    RunOptions o;
    CLI::App* cmd = nullptr;
    std::unique_ptr<SettingsOptions> settings;
    bool noOverlay = false, noSummary = false;
};

void addRun(CLI::App& app, RunCli& r) {
    RunOptions& run = r.o;
    CLI::App* runCmd = app.add_subcommand("run", "model a video, image sequence or camera; write labels, perplexity, "
                                                 "surprise, the topic model, an overlay video and a summary plot");
    runCmd->add_option("input", run.inputs,
                       "INPUT...: a video file, a directory of images, a glob ('frames/*.png', quoted), camera:N, or a "
                       "bag (FILE.bag with --topic). "
                       "Several inputs play one after the other at the first one's size")
        ->required()
        ->check(givenPath(PathKind::Input));
    runCmd->add_option("--out,-o", run.out, "output directory (created if needed)")->required()->check(givenPath(PathKind::Directory));
    r.settings = std::make_unique<SettingsOptions>(*runCmd, run.model, SettingsOptions::Command::Run);
    runCmd->add_option("--vocabulary", run.vocabulary,
                       "ORB vocabulary file from `rost vocab`; default: the built-in one (share/rost/README.md)")
        ->type_name("FILE")
        ->check(givenPath())
        ->group("Words");
    const char* f = "Frames";
    runCmd->add_option("--max-frames", run.max_frames, "stop after this many frames (0: all)")->group(f)->check(nonNegative());
    runCmd->add_option("--width", run.width, "resize frames to this width (0: as the input)")->group(f)->check(nonNegative());
    runCmd->add_option("--height", run.height, "resize frames to this height (0: keep the aspect ratio)")
        ->group(f)
        ->check(nonNegative());
    runCmd->add_option("--camera.width", run.camera_width, "camera:N capture width")->group(f);
    runCmd->add_option("--camera.height", run.camera_height, "camera:N capture height")->group(f);
    runCmd->add_option("--camera.format", run.camera_format,
                       "camera:N pixel format (RGB888, BGR888, XRGB8888, XBGR8888, YUYV, UYVY, NV12, NV21, YUV420, "
                       "R8); default: the first of these the camera offers")
        ->group(f);
    const char* bags = "Bags";
    runCmd->add_option("--topic", run.topic,
                       "INPUT.bag: the image topic to read (sensor_msgs/Image or CompressedImage); without it the "
                       "bag's image topics are listed")
        ->type_name("TOPIC")
        ->group(bags);
    runCmd->add_option("--out.bag", run.out_bag,
                       "also write each frame's results as rost_msgs/FrameTopics on /rost/frame into this bag, "
                       "stamped like the images")
        ->type_name("FILE")
        ->check(givenPath())
        ->group(bags);
    const std::string rt(rost::settingGroupNames(rost::SettingGroup::Runtime).title);  // with the Runtime settings
    runCmd->add_flag("--realtime", run.realtime,
                     "run as onboard: a capture thread (a file paced at its frames' own times) and the refiner thread; "
                     "frames are dropped when the refiner falls behind. Always on for camera:N")
        ->group(rt);
    const char* out = "Output";
    runCmd->add_flag("--no-overlay", r.noOverlay, "do not write the overlay video")->group(out);
    runCmd->add_option("--overlay.format", run.overlay_format, "overlay container: mp4 (mp4v) or avi (MJPG)")
        ->check(CLI::IsMember({"mp4", "avi"}))
        ->group(out);
    runCmd->add_flag("--no-summary", r.noSummary, "do not draw summary.png")->group(out);
    runCmd->add_flag("--quiet,-q", run.quiet, "no progress bar and no notes on stderr but the input's own (errors still)")->group(out);
    runCmd->footer(
        "Writes into DIR: words.csv (timestamp,w1,w2,...), positions.csv (timestamp,x1,y1,...), topics.csv\n"
        "(timestamp,z1,z2,...: final maximum-likelihood labels), perplexity.csv (frame,instantaneous,final,\n"
        "plugin,topics), surprise.csv (frame,surprise), surprise_cells.csv (frame,cell0,...), frames.csv\n"
        "(words per frame and extractor), topicmodel.csv (K rows of V counts), overlay.mp4 (cells tinted by\n"
        "dominant topic), summary.png, run.txt. The timestamp is the input frame index. Files appear only\n"
        "when the run succeeds.");
    r.cmd = runCmd;
}

// `rost refine`'s options.
struct RefineCli {
    RefineOptions o;
    CLI::App* cmd = nullptr;
    std::unique_ptr<SettingsOptions> settings;
    bool noSummary = false;
};

void addRefine(CLI::App& app, RefineCli& r) {
    RefineOptions& ref = r.o;
    CLI::App* refCmd = app.add_subcommand("refine", "model a word stream made elsewhere (words.csv from earlier ROST "
                                                    "tools or another extractor)");
    refCmd->add_option("words", ref.words, "WORDS.csv: timestamp,w1,w2,... per observation")
        ->required()
        ->check(givenPath());
    refCmd->add_option("--positions", ref.positions,
                       "POSITIONS.csv: timestamp,x1,y1,x2,y2,... for the same observations; without it every word "
                       "is at (0,0): one cell per time step")
        ->check(givenPath());
    refCmd->add_option("--out,-o", ref.out, "output directory")->required()->check(givenPath(PathKind::Directory));
    refCmd->add_option("--width", ref.width, "frame width positions lie in (0: the largest x + 1)")->check(nonNegative());
    refCmd->add_option("--height", ref.height, "frame height positions lie in (0: the largest y + 1)")->check(nonNegative());
    r.settings = std::make_unique<SettingsOptions>(*refCmd, ref.model, SettingsOptions::Command::Refine);
    refCmd->add_flag("--no-summary", r.noSummary, "do not draw summary.png");
    refCmd->add_flag("--quiet,-q", ref.quiet, "no progress bar and no notes on stderr");
    refCmd->footer("Writes topics.csv, perplexity.csv, surprise.csv, surprise_cells.csv, topicmodel.csv and "
                   "summary.png into DIR.");
    r.cmd = refCmd;
}

CLI::App* addVocab(CLI::App& app, VocabOptions& voc) {
    CLI::App* vocCmd = app.add_subcommand("vocab", "train an ORB vocabulary from footage (k-majority clustering in "
                                                   "Hamming space)");
    vocCmd->add_option("input", voc.inputs, "INPUT...: videos, image directories or globs")
        ->required()
        ->check(givenPath(PathKind::Input));
    vocCmd->add_option("--out,-o", voc.out, "vocabulary file to write (format: docs/vision.md)")
        ->required()
        ->check(givenPath());
    vocCmd->add_option("--words", voc.words, "vocabulary size (paper: 5000)");
    vocCmd->add_option("--features", voc.features, "ORB keypoints per frame used for training");
    vocCmd->add_option("--every", voc.every, "use every N-th frame");
    vocCmd->add_option("--max-frames", voc.max_frames, "frames read per input at most (0: all)")->check(nonNegative());
    vocCmd->add_option("--max-descriptors", voc.max_descriptors,
                       "descriptors clustered at most (a seeded uniform sample beyond)");
    vocCmd->add_option("--iterations", voc.iterations, "k-majority iterations at most");
    vocCmd->add_option("--seed", voc.seed, "random seed (initial centres, sampling)");
    vocCmd->add_option("--threads", voc.threads, "threads for the assignment step (the result does not depend on it)");
    vocCmd->add_option("--width", voc.width, "resize frames to this width first (0: as the input)")->check(nonNegative());
    vocCmd->add_flag("--quiet,-q", voc.quiet, "no progress on stderr");
    return vocCmd;
}

#if ROST_TOOL_LIGHT
// Replaces this process with rost-vision, the same arguments: beside this
// program (the build tree, or copied so), or where the install puts it
// relative to its bin directory (ROST_VISION_FROM_BIN). Returns only on failure.
int runVisionProgram(char** argv) {
    std::error_code ec;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec) return fail("cannot find rost-vision: /proc/self/exe: " + ec.message());
    const std::filesystem::path dir = self.parent_path();
    const std::filesystem::path beside = dir / "rost-vision";
    const std::filesystem::path installed = (dir / ROST_VISION_FROM_BIN).lexically_normal();
    std::fflush(nullptr);
    for (const std::filesystem::path& p : {beside, installed})
        if (::access(p.c_str(), X_OK) == 0) {
            ::execv(p.c_str(), argv);
            return fail(p.string() + ": cannot run it (" + std::strerror(errno) + ")");
        }
    return fail("rost-vision is neither beside " + self.string() + " nor at " + installed.string() +
                ": `rost run`, `rost vocab` and `rost cameras` are that program's; install it with rost, or copy it "
                "beside rost");
}
#endif

} // namespace

namespace {

// The parsed command, run (the vision commands are rost-vision's: ROST_TOOL_LIGHT hands them over before).
int dispatch([[maybe_unused]] RunCli& run, RefineCli& ref, [[maybe_unused]] VocabOptions& voc, ModelOptions& conf,
             SettingsOptions& confSettings, MergeCliOptions& merge, [[maybe_unused]] CLI::App* vocCmd,
             [[maybe_unused]] CLI::App* camCmd, CLI::App* mergeCmd, CLI::App* confCmd) {
#if !ROST_TOOL_LIGHT
    if (run.cmd->parsed()) {
        if (const rost::Status st = run.settings->apply(&run.o, nullptr); !st.ok()) return fail(st.message());
        run.o.overlay = !run.noOverlay;
        run.o.summary = !run.noSummary;
        return runCommand(run.o);
    }
    if (vocCmd->parsed()) return vocabCommand(voc);
    if (camCmd->parsed()) return camerasCommand();
#endif
    if (ref.cmd->parsed()) {
        if (const rost::Status st = ref.settings->apply(nullptr, &ref.o); !st.ok()) return fail(st.message());
        ref.o.summary = !ref.noSummary;
        return refineCommand(ref.o);
    }
    if (mergeCmd->parsed()) return mergeCommand(merge);
    if (confCmd->parsed()) {
        if (const rost::Status st = confSettings.apply(nullptr, nullptr); !st.ok()) return fail(st.message());
        return configCommand(conf);
    }
    return kExitError;
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

    // ---- run, refine, vocab
    RunCli run;
    run.o.command_line = cmdline;
    addRun(app, run);
    RefineCli ref;
    ref.o.command_line = cmdline;
    addRefine(app, ref);
    VocabOptions voc;
    voc.command_line = cmdline;
    CLI::App* vocCmd = addVocab(app, voc);

    // ---- config
    ModelOptions conf;
    CLI::App* confCmd = app.add_subcommand("config", "print every setting as a configuration file (key = value, "
                                                     "documented), after --config FILE and the options given");
    SettingsOptions confSettings(*confCmd, conf, SettingsOptions::Command::Config);

    // ---- merge
    MergeCliOptions merge;
    CLI::App* mergeCmd = app.add_subcommand("merge", "match the topics of several missions' models into one global "
                                                     "set (docs/fleet.md)");
    mergeCmd->add_option("model", merge.models, "MODEL...: topicmodel.csv files or checkpoints, in this order")
        ->required()
        ->check(givenPath());
    mergeCmd->add_option("--out,-o", merge.out, "directory for topicmodel.csv (the global model) and lifting.csv "
                                                "(model,local,global)")
        ->required()
        ->check(givenPath(PathKind::Directory));
    mergeCmd->add_option("--threshold", merge.threshold, "Hellinger distance in [0, 1] up to which a topic joins a "
                                                         "global topic (0: only identical ones)");
    mergeCmd->add_option("--beta", merge.beta, "smoothing of the topic-word distributions compared");
    mergeCmd->add_flag("--quiet,-q", merge.quiet, "no summary on stderr");

    // ---- cameras
    CLI::App* camCmd = app.add_subcommand("cameras", "list the cameras libcamera can see");

    for (CLI::App* cmd : app.get_subcommands([](const CLI::App*) { return true; })) rost::cli::refuseOptionsAsValues(*cmd, takesAPath);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);
        return fail(std::string(e.what()) + " (see rost --help)");
    }

#if ROST_TOOL_LIGHT
    if (run.cmd->parsed() || vocCmd->parsed() || camCmd->parsed()) return runVisionProgram(argv);
#endif
    // Whatever a command did not catch where it happened (out of memory in
    // set-up, OpenCV's own errors) is one line and exit 2, not an abort: the
    // stack unwinds, so a run's staging directory goes with it.
    try {
        return dispatch(run, ref, voc, conf, confSettings, merge, vocCmd, camCmd, mergeCmd, confCmd);
    } catch (const std::bad_alloc&) {
        return fail("out of memory (the settings or the input need more than this machine gives)");
    } catch (const cv::Exception& e) {
        return fail(std::string(e.code == cv::Error::StsNoMem ? "out of memory: " : "") + "OpenCV: " + e.err);
    } catch (const std::exception& e) {
        return fail(e.what());
    }
}

