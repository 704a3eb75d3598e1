// The rost tool's mission options (docs/trust.md): --checkpoint FILE
// --checkpoint.every N and --config FILE, their outputs and their errors
// (one line naming what and where, exit code 2, no outputs left).

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "rost/checkpoint.hpp"
#include "rost/config_file.hpp"
#include "rost/random.hpp"
#include "rost/topic_model_csv.hpp"
#include "test_vision_support.hpp"

using rost::testing::RunResult;
using rost::testing::TempDir;

namespace {

std::string tool() { return std::string("'") + ROST_TOOL + "'"; }
RunResult runRost(const std::string& args) { return rost::testing::runShell(tool() + " " + args); }

void expectError(const RunResult& r, const std::string& needle, const std::string& out) {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "stderr: " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_EQ(r.err.rfind("rost: error: ", 0), 0u) << r.err;
    if (std::filesystem::exists(out))
        for (const auto& e : std::filesystem::directory_iterator(out)) ADD_FAILURE() << "left behind: " << e.path();
}

// A small word stream: 40 observations of 12 words in a 64 x 64 frame.
void writeStream(const TempDir& t) {
    std::string words, positions;
    rost::Rng r(3);
    for (int f = 0; f < 40; ++f) {
        words += std::to_string(f);
        positions += std::to_string(f);
        for (int i = 0; i < 12; ++i) {
            const uint32_t x = r.below(64), y = r.below(64);
            words += ',';
            words += std::to_string((x < 32 ? 0u : 20u) + r.below(20));
            positions += ',';
            positions += std::to_string(x);
            positions += ',';
            positions += std::to_string(y);
        }
        words += "\n";
        positions += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    rost::testing::writeText(t / "positions.csv", positions);
}

std::string refine(const TempDir& t, const std::string& out, const std::string& extra) {
    return "refine " + (t / "words.csv") + " --positions " + (t / "positions.csv") + " --width 64 --height 64 -V 40 --out " +
           (t / out) + " --no-summary -q " + extra;
}

int lines(const std::string& path) {
    const std::string text = rost::testing::readText(path);
    return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

TEST(ToolTrust, CheckpointHoldsTheWholeRunAndResumesInTheLibrary) {
    TempDir t;
    writeStream(t);
    const RunResult r = runRost(refine(t, "o", "--checkpoint " + (t / "run.ckpt") + " --checkpoint.every 7 --seed 5"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    rost::CheckpointInfo info;
    const rost::Status st = rost::readCheckpointInfo(t / "run.ckpt", info);
    ASSERT_TRUE(st.ok()) << st.message();
    EXPECT_EQ(info.observations, 40u);  // the final capture, after the last observation
    EXPECT_EQ(info.next_sequence, 40u);
    EXPECT_EQ(info.last_timestamp, 39);
    EXPECT_EQ(info.config.model.seed, 5u);
    EXPECT_EQ(info.config.model.V, 40);
    rost::Status s2;
    auto engine = rost::resumeEngine(t / "run.ckpt", s2);
    ASSERT_TRUE(engine) << s2.message();
    std::string why;
    EXPECT_TRUE(engine->model().checkInvariants(&why)) << why;
    // The topic model in the checkpoint is the one the run wrote.
    const std::string csv = rost::testing::readText(t / "o/topicmodel.csv");
    std::vector<int32_t> counts;
    ASSERT_TRUE(rost::parseTopicModelCsv(csv, engine->model().K(), engine->model().V(), counts).ok());
    for (int k = 0; k < engine->model().K(); ++k)
        for (int v = 0; v < engine->model().V(); ++v)
            ASSERT_EQ(counts[static_cast<std::size_t>(k) * 40 + static_cast<std::size_t>(v)],
                      engine->model().topicWordCount(k, v));
}

TEST(ToolTrust, CheckpointErrorsNameThePathWithExitCode2) {
    TempDir t;
    writeStream(t);
    expectError(runRost(refine(t, "o", "--checkpoint /nonexistent/run.ckpt")),
                "--checkpoint: /nonexistent/run.ckpt: directory /nonexistent does not exist", t / "o");
    expectError(runRost(refine(t, "o", "--checkpoint " + (t / "c.ckpt") + " --checkpoint.every 0")),
                "--checkpoint.every", t / "o");
}

TEST(ToolTrust, ConfigFileSetsWhatTheCommandLineDoesNotAndTheCommandLineWins) {
    TempDir t;
    writeStream(t);
    rost::testing::writeText(t / "m.conf", "# mission\nK = 5\nalpha = 0.25\nbudget.refines = 3\nframe.width = 64\n");
    RunResult r = runRost(refine(t, "a", "--config " + (t / "m.conf") + " --checkpoint " + (t / "a.ckpt")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(lines(t / "a/topicmodel.csv"), 5);
    rost::CheckpointInfo info;
    ASSERT_TRUE(rost::readCheckpointInfo(t / "a.ckpt", info).ok());
    EXPECT_EQ(info.config.model.alpha, 0.25);
    EXPECT_EQ(info.config.budget.count, 3u);
    r = runRost(refine(t, "b", "--config " + (t / "m.conf") + " -K 7 --budget.refines 2 --checkpoint " + (t / "b.ckpt")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(lines(t / "b/topicmodel.csv"), 7);
    ASSERT_TRUE(rost::readCheckpointInfo(t / "b.ckpt", info).ok());
    EXPECT_EQ(info.config.model.K, 7);
    EXPECT_EQ(info.config.model.alpha, 0.25);
    EXPECT_EQ(info.config.budget.count, 2u);
}

TEST(ToolTrust, ConfigFileErrorsNameFileLineAndKeyWithExitCode2) {
    TempDir t;
    writeStream(t);
    const auto conf = [&](const std::string& text) {
        rost::testing::writeText(t / "x.conf", text);
        return refine(t, "o", "--config " + (t / "x.conf"));
    };
    expectError(runRost(conf("K = 5\nalfa = 0.1\n")), "--config: " + (t / "x.conf") + ":2: unknown key 'alfa' (did you mean 'alpha'?)",
                t / "o");
    expectError(runRost(conf("K = five\n")), (t / "x.conf") + ":1: key 'K': expected an integer, found 'five'", t / "o");
    expectError(runRost(conf("beta = 0\n")), (t / "x.conf") + ":1: key 'beta': invalid configuration: beta = 0", t / "o");
    expectError(runRost(conf("\nstop-on-arrival = true\n")),
                (t / "x.conf") + ":2: key 'stop-on-arrival' is not a setting of this command", t / "o");
    expectError(runRost(refine(t, "o", "--config " + (t / "missing.conf"))),
                "--config: " + (t / "missing.conf") + ": cannot open: No such file or directory", t / "o");
}

TEST(ToolTrust, FrameSourceFailingMidStreamStopsCleanlySaysWhyAndKeepsWhatWasLearnedAndWritten) {
    // Eight frames of textured noise; the fifth file is not an image.
    TempDir t;
    std::filesystem::create_directory(t / "frames");
    cv::RNG rng(7);
    for (int i = 1; i <= 8; ++i) {
        cv::Mat img(96, 128, CV_8UC3);
        rng.fill(img, cv::RNG::UNIFORM, 0, 255);
        ASSERT_TRUE(cv::imwrite(t / ("frames/f" + std::to_string(i) + ".png"), img));
    }
    rost::testing::writeText(t / "frames/f5.png", std::string(300, '\x5a'));
    // An earlier run's outputs in the same directory: the failed run must not touch them.
    RunResult r = runRost("run " + (t / "frames") + " --max-frames 3 --out " + (t / "o") + " --no-overlay --no-summary -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::string before = rost::testing::readText(t / "o/topics.csv");
    ASSERT_FALSE(before.empty());
    r = runRost("run " + (t / "frames") + " --out " + (t / "o") + " --checkpoint " + (t / "m.ckpt") +
                " --no-overlay --no-summary -q");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("f5.png: cannot decode image"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(rost::testing::readText(t / "o/topics.csv"), before);
    // What was learned before the failure is in the checkpoint, and loads.
    rost::CheckpointInfo info;
    rost::Status st;
    auto engine = rost::resumeEngine(t / "m.ckpt", st, &info);
    ASSERT_TRUE(engine) << st.message();
    EXPECT_EQ(info.observations, 4u);
    EXPECT_EQ(info.last_timestamp, 3);
}

} // namespace
