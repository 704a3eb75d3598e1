// `rost run` end to end on real footage (the first 60 frames of mire-2 from
// visp-images-data): every output exists, parses and is consistent; same
// seed gives the same bytes; the outputs feed `rost refine` and
// --in.topicmodel; --realtime runs the same outputs through the threads.

#include <gtest/gtest.h>

#include <sched.h>

#include <cstdio>

#include <cmath>
#include <filesystem>
#include <numeric>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "test_vision_support.hpp"

using namespace rost::testing;

namespace {

constexpr int kFrames = 60, K = 16, V = 5436, kW = 384, kH = 288;

std::string tool() { return std::string("'") + ROST_TOOL + "'"; }

std::vector<std::vector<long long>> intRows(const std::string& path, bool header = false) {
    std::vector<std::vector<long long>> out;
    auto ls = lines(readText(path));
    for (std::size_t i = header ? 1 : 0; i < ls.size(); ++i) {
        std::vector<long long> row;
        for (const auto& f : fields(ls[i])) row.push_back(std::stoll(f));
        out.push_back(std::move(row));
    }
    return out;
}

std::vector<std::vector<double>> realRows(const std::string& path, const std::string& header) {
    auto ls = lines(readText(path));
    EXPECT_FALSE(ls.empty());
    if (ls.empty()) return {};
    EXPECT_EQ(ls[0], header) << path;
    std::vector<std::vector<double>> out;
    for (std::size_t i = 1; i < ls.size(); ++i) {
        std::vector<double> row;
        for (const auto& f : fields(ls[i])) row.push_back(std::stod(f));
        out.push_back(std::move(row));
    }
    return out;
}

// Checks one run's output directory.
void checkOutputs(const std::string& dir, int frames) {
    namespace fs = std::filesystem;
    for (const char* f : {"words.csv", "positions.csv", "topics.csv", "perplexity.csv", "surprise.csv",
                          "surprise_cells.csv", "frames.csv", "topicmodel.csv", "overlay.mp4", "summary.png", "run.txt"})
        ASSERT_TRUE(fs::exists(dir + "/" + f)) << f;
    for (const auto& e : fs::directory_iterator(dir))
        EXPECT_EQ(e.path().filename().string().rfind(".rost-partial", 0), std::string::npos) << "staging left";

    const auto words = intRows(dir + "/words.csv");
    const auto pos = intRows(dir + "/positions.csv");
    const auto topics = intRows(dir + "/topics.csv");
    ASSERT_EQ(static_cast<int>(words.size()), frames);
    ASSERT_EQ(pos.size(), words.size());
    ASSERT_EQ(topics.size(), words.size());
    long long total = 0;
    for (std::size_t t = 0; t < words.size(); ++t) {
        EXPECT_EQ(words[t][0], static_cast<long long>(t)) << "timestamp is the frame index";
        EXPECT_EQ(pos[t][0], words[t][0]);
        EXPECT_EQ(topics[t][0], words[t][0]);
        const std::size_t n = words[t].size() - 1;
        EXPECT_GT(n, 100u) << "frame " << t << " has words";
        ASSERT_EQ(pos[t].size() - 1, 2 * n) << "frame " << t;
        ASSERT_EQ(topics[t].size() - 1, n) << "frame " << t;
        for (std::size_t i = 1; i <= n; ++i) {
            ASSERT_GE(words[t][i], 0);
            ASSERT_LT(words[t][i], V);
            ASSERT_GE(topics[t][i], 0);
            ASSERT_LT(topics[t][i], K);
            const long long x = pos[t][2 * i - 1], y = pos[t][2 * i];
            ASSERT_TRUE(x >= 0 && x < kW && y >= 0 && y < kH) << x << "," << y;
        }
        total += static_cast<long long>(n);
    }

    const auto ppx = realRows(dir + "/perplexity.csv", "frame,instantaneous,final,plugin,topics");
    ASSERT_EQ(static_cast<int>(ppx.size()), frames);
    for (std::size_t t = 0; t < ppx.size(); ++t) {
        EXPECT_EQ(ppx[t][0], static_cast<double>(t));
        for (int c : {1, 2, 3}) {
            EXPECT_TRUE(std::isfinite(ppx[t][c]) && ppx[t][c] > 0.0) << "perplexity row " << t;
            EXPECT_LE(ppx[t][c], V) << "a perplexity above V means worse than uniform guessing";
        }
        // The plug-in perplexity (the 2013 code's) counts each word in its own
        // cell's topic mix and its topic's words: below ours at the same instant.
        EXPECT_LT(ppx[t][3], ppx[t][1]) << "row " << t;
        EXPECT_EQ(ppx[t][4], K) << "without growth every topic is open";
    }
    const auto sur = realRows(dir + "/surprise.csv", "frame,surprise");
    ASSERT_EQ(static_cast<int>(sur.size()), frames);
    for (const auto& r : sur) EXPECT_TRUE(std::isfinite(r[1]) && r[1] > 0.0);
    EXPECT_NEAR(sur[0][1], V, 1e-6 * V) << "the first frame meets a uniform model: surprise = V";
    const auto cellLines = lines(readText(dir + "/surprise_cells.csv"));
    ASSERT_EQ(static_cast<int>(cellLines.size()), frames + 1);
    EXPECT_EQ(fields(cellLines[0]).size(), 1u + 6u * 5u) << "384x288 in 64 px cells: 6 x 5";

    const auto frameRows = intRows(dir + "/frames.csv", true);
    ASSERT_EQ(static_cast<int>(frameRows.size()), frames);
    long long inCells = 0;
    for (std::size_t t = 0; t < frameRows.size(); ++t) {
        const auto& r = frameRows[t];
        EXPECT_EQ(r[2], r[3] + r[4] + r[5]) << "words = orb + intensity + hue";
        EXPECT_EQ(r[5], 0) << "mire-2 is grey: no hue words";
        EXPECT_EQ(r[6], 1) << "ingested";
        EXPECT_EQ(r[2], static_cast<long long>(words[t].size()) - 1) << "all extracted words are listed";
        EXPECT_LE(r[7], r[2]) << "words in cells";
        inCells += r[7];
    }

    // The topic model holds exactly the words that entered cells (no prior,
    // counts kept); words beyond a cell's capacity are listed with their
    // maximum-likelihood topic but not counted.
    const auto tm = intRows(dir + "/topicmodel.csv");
    ASSERT_EQ(static_cast<int>(tm.size()), K);
    long long counted = 0;
    for (const auto& row : tm) {
        ASSERT_EQ(static_cast<int>(row.size()), V);
        counted += std::accumulate(row.begin(), row.end(), 0LL);
    }
    EXPECT_EQ(counted, inCells);
    EXPECT_GE(total, inCells);

    cv::VideoCapture cap(dir + "/overlay.mp4");
    ASSERT_TRUE(cap.isOpened());
    EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_WIDTH)), kW);
    EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_HEIGHT)), kH);
    int n = 0;
    cv::Mat f;
    while (cap.read(f)) ++n;
    EXPECT_EQ(n, frames);
    const cv::Mat summary = cv::imread(dir + "/summary.png");
    ASSERT_FALSE(summary.empty());
    EXPECT_GE(summary.cols, 1000);

    // run.txt: the refiner's busy time is its observations' (take-up to
    // publication), within the run's, and the shares add up to 100 %.
    double busy = -1, seconds = -1;
    int busyPct = -1, idlePct = -1;
    for (const auto& l : lines(readText(dir + "/run.txt"))) {
        if (l.rfind("refiner: ", 0) != 0) continue;
        ASSERT_EQ(std::sscanf(l.c_str(), "refiner: busy %lf s of %lf s (%d %%), idle %d %%", &busy, &seconds, &busyPct,
                              &idlePct),
                  4)
            << l;
    }
    ASSERT_GT(busy, 0.0) << "run.txt has the refiner's line";
    EXPECT_LE(busy, seconds * 1.001);
    EXPECT_EQ(busyPct + idlePct, 100);
}

class ToolEndToEnd : public ::testing::Test {
protected:
    void SetUp() override {
        mire_ = footage("visp-images-data", kMire2);
        if (mire_.empty()) {
            if (requireFootage()) FAIL() << "visp-images-data could not be fetched, required in CI";
            GTEST_SKIP() << "visp-images-data could not be fetched (scripts/fetch-footage.sh needs apt and a Debian mirror)";
        }
    }
    RunResult run(const std::string& out, const std::string& extra = "") {
        return runShell(tool() + " run '" + mire_ + "' --max-frames " + std::to_string(kFrames) + " --out '" + out +
                        "' -q " + extra);
    }
    std::string mire_;
};

} // namespace

TEST_F(ToolEndToEnd, RunOnSixtyFramesOfMire2WritesConsistentOutputs) {
    TempDir t;
    const RunResult r = run(t / "out");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "--quiet and not a terminal: nothing on stderr, got: " << r.err;
    checkOutputs(t / "out", kFrames);
}

TEST_F(ToolEndToEnd, SameSeedGivesIdenticalFilesAndAnotherSeedDifferentLabels) {
    TempDir t;
    ASSERT_EQ(runShell(tool() + " run '" + mire_ + "' --max-frames 20 --no-overlay --no-summary -q --out " + (t / "a")).exit_code, 0);
    ASSERT_EQ(runShell(tool() + " run '" + mire_ + "' --max-frames 20 --no-overlay --no-summary -q --out " + (t / "b")).exit_code, 0);
    ASSERT_EQ(runShell(tool() + " run '" + mire_ + "' --max-frames 20 --no-overlay --no-summary -q --seed 2 --out " + (t / "c")).exit_code, 0);
    for (const char* f : {"words.csv", "positions.csv", "topics.csv", "perplexity.csv", "surprise.csv",
                          "surprise_cells.csv", "topicmodel.csv"})
        EXPECT_EQ(readText(t / "a" + "/" + f), readText(t / "b" + "/" + f)) << f;
    EXPECT_EQ(readText(t / "a/words.csv"), readText(t / "c/words.csv")) << "words do not depend on the seed";
    EXPECT_NE(readText(t / "a/topics.csv"), readText(t / "c/topics.csv"));
}

// Without --threads a run refines on the CPUs the process may use (its
// affinity, which the child inherits), a realtime one leaving one to the
// capture thread; run.txt says how many it took.
TEST_F(ToolEndToEnd, ThreadsFollowTheCpusTheProcessMayUseLessOneForARealtimeCapture) {
    cpu_set_t set;
    CPU_ZERO(&set);
    ASSERT_EQ(::sched_getaffinity(0, sizeof set, &set), 0);
    const int cpus = CPU_COUNT(&set);
    if (cpus > 16) GTEST_SKIP() << cpus << " CPUs: past the schema's thread limit this test does not model";
    TempDir t;
    const auto threadsOf = [&](const std::string& dir) {
        for (const auto& l : lines(readText(dir + "/run.txt"))) {
            const std::size_t at = l.find(", threads ");
            if (at != std::string::npos) return std::atoi(l.c_str() + at + 10);
        }
        return -1;
    };
    const std::string common = " run '" + mire_ + "' --max-frames 3 --no-overlay --no-summary -q --out ";
    ASSERT_EQ(runShell(tool() + common + (t / "offline")).exit_code, 0);
    EXPECT_EQ(threadsOf(t / "offline"), cpus);
    const RunResult rt = runShell(tool() + common + (t / "realtime") + " --realtime");
    ASSERT_EQ(rt.exit_code, 0) << rt.err;
    EXPECT_EQ(threadsOf(t / "realtime"), std::max(cpus - 1, 1));
}

TEST_F(ToolEndToEnd, OutputsFeedRefineAndTheTopicModelLoadsBack) {
    TempDir t;
    ASSERT_EQ(runShell(tool() + " run '" + mire_ + "' --max-frames 20 --no-overlay --no-summary -q --out " + (t / "a")).exit_code, 0);
    // The word stream through `rost refine`, with the same model and seed, gives the same labels.
    RunResult r = runShell(tool() + " refine " + (t / "a/words.csv") + " --positions " + (t / "a/positions.csv") +
                           " --width 384 --height 288 -V 5436 --no-summary -q --out " + (t / "r"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(readText(t / "a/topics.csv"), readText(t / "r/topics.csv"));
    EXPECT_EQ(readText(t / "a/perplexity.csv"), readText(t / "r/perplexity.csv"));
    // A run starting from that topic model: accepted, and its counts include the prior.
    r = runShell(tool() + " run '" + mire_ + "' --max-frames 5 --no-overlay --no-summary -q --in.topicmodel " +
                 (t / "a/topicmodel.csv") + " --out " + (t / "p"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    long long prior = 0, after = 0;
    for (const auto& l : lines(readText(t / "a/topicmodel.csv")))
        for (const auto& f : fields(l)) prior += std::stoll(f);
    for (const auto& l : lines(readText(t / "p/topicmodel.csv")))
        for (const auto& f : fields(l)) after += std::stoll(f);
    EXPECT_GT(after, prior);
}

TEST_F(ToolEndToEnd, RealtimeRunThroughCaptureAndRefinerThreadsWritesConsistentOutputs) {
    TempDir t;
    // 30 images at the 10 fps an image sequence is paced at: about 3 s.
    const RunResult r = runShell(tool() + " run '" + mire_ + "' --max-frames 30 --realtime --no-overlay -q --out " +
                                 (t / "rt"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto words = intRows(t / "rt/words.csv");
    const auto topics = intRows(t / "rt/topics.csv");
    const auto frameRows = intRows(t / "rt/frames.csv", true);
    ASSERT_EQ(frameRows.size(), 30u) << "every captured frame is listed";
    std::size_t ingested = 0;
    for (const auto& f : frameRows) ingested += static_cast<std::size_t>(f[6]);
    EXPECT_EQ(words.size(), ingested);
    EXPECT_GE(ingested, 20u) << "a 10 fps stream should rarely overrun the refiner";
    ASSERT_EQ(topics.size(), words.size());
    for (std::size_t i = 0; i < words.size(); ++i) ASSERT_EQ(topics[i].size(), words[i].size());
    EXPECT_EQ(lines(readText(t / "rt/perplexity.csv")).size(), ingested + 1);
}
