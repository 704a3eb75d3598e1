// The mission session's one policy (rost/mission.hpp): what a new mission
// takes from its input, what a checkpoint fixes and what a resumed run may
// change, refused at start-up and named in the face's spelling.

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/mission.hpp"

using namespace rost;

namespace {

// "~cell_space" (appended: GCC 12 at -O3 warns falsely on "~" + string; -Wrestrict).
std::string tilde(const SettingSpec& s) {
    std::string out(1, '~');
    out += paramName(s);
    return out;
}

// A face that spells settings as rost_node does (~K), with a --resume of its own.
MissionOptions nodeLike() {
    MissionOptions m;
    m.names.setting = tilde;
    m.names.given = [](const SettingSpec& s, const std::string& v) { return tilde(s) + " = " + v; };
    m.names.leave = tilde;
    m.names.resume = "~resume";
    return m;
}

void give(MissionOptions& m, const char* key, const char* value) {
    ASSERT_TRUE(setSetting(m.settings, key, value).ok()) << key;
    m.given.emplace_back(key);
}

struct TempDir {
    std::string path = std::filesystem::temp_directory_path() / ("rost-mission-" + std::to_string(::getpid()));
    TempDir() { std::filesystem::create_directories(path); }
    ~TempDir() { std::filesystem::remove_all(path); }
};

// A checkpoint of K = 6 on 64x48 frames, V = 30, sampler now, 5 observations
// (and the settings `extra` gives).
std::string makeCheckpoint(const TempDir& t, const std::function<void(MissionOptions&)>& extra = {}) {
    MissionOptions m;
    give(m, "K", "6");
    if (extra) extra(m);
    give(m, "sampler", "now");
    give(m, "budget.refines", "3");
    MissionInput in;
    in.width = 64;
    in.height = 48;
    in.V = 30;
    MissionPlan plan;
    EXPECT_TRUE(planMission(m, in, plan).ok());
    Status st;
    auto engine = openMission(m, plan, st);
    EXPECT_TRUE(engine) << st.message();
    std::vector<uint32_t> words(20);
    std::vector<Position> pos(20);
    for (int f = 0; f < 5; ++f) {
        for (int i = 0; i < 20; ++i) words[i] = static_cast<uint32_t>((f * 7 + i) % 30), pos[i] = {i * 3, i * 2};
        engine->processNow({f, words, pos});
    }
    const std::string path = t.path + "/m.ckpt";
    EXPECT_TRUE(saveCheckpoint(*engine, path).ok());
    return path;
}

} // namespace

TEST(Mission, ANewMissionTakesFromItsInputWhatTheUserDidNotSet) {
    MissionOptions m;
    MissionInput in;
    in.width = 320;
    in.height = 240;
    in.V = 5436;
    in.length = 99;
    in.max_words = 1600;
    in.threads = 3;
    in.flags.snapshot_labels = false;
    MissionPlan plan;
    ASSERT_TRUE(planMission(m, in, plan).ok());
    const Config& c = plan.config.model;
    EXPECT_EQ(c.V, 5436);
    EXPECT_EQ(c.frame_width, 320);
    EXPECT_EQ(c.frame_height, 240);
    EXPECT_EQ(c.ring_steps, 100) << "the whole input stays refinable";
    EXPECT_EQ(c.max_words_per_frame, 1600);
    EXPECT_EQ(c.threads, 3);
    EXPECT_FALSE(plan.config.flags.snapshot_labels);
    EXPECT_FALSE(plan.resuming);

    // What the user set wins; a long input keeps 2048 steps at most.
    give(m, "V", "6000");
    give(m, "max.words", "500");
    give(m, "threads", "2");
    in.length = 1000000;
    ASSERT_TRUE(planMission(m, in, plan).ok());
    EXPECT_EQ(plan.config.model.V, 6000);
    EXPECT_EQ(plan.config.model.max_words_per_frame, 500);
    EXPECT_EQ(plan.config.model.threads, 2);
    EXPECT_EQ(plan.config.model.ring_steps, 2048);
}

// Observations become time steps of cell.time each: 10 observations at
// cell.time 3 are 4 steps (the last holds one), rounded up, so the last
// observation has a step of its own; a streamed window keeps one more.
TEST(Mission, TheRingCountsAPartLastStep) {
    MissionOptions m;
    give(m, "cell.time", "3");
    MissionInput in;
    in.V = 50;
    in.length = 10;
    MissionPlan plan;
    ASSERT_TRUE(planMission(m, in, plan).ok());
    EXPECT_EQ(plan.config.model.ring_steps, 5) << "4 steps and one more";
    in.keep_all = true;
    ASSERT_TRUE(planMission(m, in, plan).ok());
    EXPECT_EQ(plan.config.model.ring_steps, 4) << "exactly the input's steps";
}

// A batch over the whole input (rost-cli's commands): every observation
// stays refinable, with no 2048-step window, and cell.capacity comes from the
// busiest cell under the planned geometry, unless the user set them; past
// the schema's range the input is refused, naming the setting.
TEST(Mission, ABatchOverTheWholeInputKeepsEveryObservationAndEveryWord) {
    MissionOptions m;
    MissionInput in;
    in.width = 64;
    in.height = 48;
    in.V = 100;
    in.length = 100000;
    in.max_words = 9000;
    in.keep_all = true;
    Config seen;
    in.busiest_cell = [&](const Config& c) -> uint64_t {
        seen = c;
        return 777;
    };
    MissionPlan plan;
    ASSERT_TRUE(planMission(m, in, plan).ok());
    EXPECT_EQ(plan.config.model.ring_steps, 100000) << "exactly the input's time steps, no cap at 2048";
    EXPECT_EQ(plan.config.model.max_words_per_frame, 9000);
    EXPECT_EQ(plan.config.model.cell_capacity, 777);
    EXPECT_EQ(seen.frame_width, 64) << "the busiest cell is counted under the planned geometry";
    EXPECT_EQ(seen.cell_space, plan.config.model.cell_space);

    give(m, "cell.capacity", "50");
    ASSERT_TRUE(planMission(m, in, plan).ok());
    EXPECT_EQ(plan.config.model.cell_capacity, 50) << "what the user set wins";

    in.length = 70000001;
    m.names.problem = [](const SettingProblem& p) { return "needs: " + p.describe(p.spec->key); };
    EXPECT_EQ(planMission(m, in, plan).message(), "needs: ring.steps = 70000001, allowed [1, 67108864]");
}

TEST(Mission, WhatTheInputDecidesIsCheckedAndNamedInTheFacesSpelling) {
    MissionOptions m = nodeLike();
    give(m, "cell.space", "1");
    MissionInput in;
    in.width = 4000;
    in.height = 3000;
    in.V = 10;
    MissionPlan plan;
    EXPECT_EQ(planMission(m, in, plan).message(),
              "~cell_space = 1, allowed at least 4 for ~frame_width = 4000 by ~frame_height = 3000; "
              "12000000 cells a step, at most 1048576");
}

TEST(Mission, ACheckpointFixesTheModelAtStartUpNamingWhatDiffers) {
    TempDir t;
    const std::string ckpt = makeCheckpoint(t);
    MissionOptions m = nodeLike();
    m.resume = ckpt;
    give(m, "K", "8");
    MissionPlan plan;
    EXPECT_EQ(checkMission(m, plan).message(),
              "~K = 8 differs from " + ckpt + "'s K = 6 (a resumed mission keeps its model; leave ~K out)");

    // Repeating the checkpoint's value is fine; a starting topic model is not.
    m = nodeLike();
    m.resume = ckpt;
    give(m, "K", "6");
    m.in_topicmodel = t.path + "/topicmodel.csv";
    EXPECT_EQ(checkMission(m, plan).message(),
              "--in.topicmodel cannot be used with ~resume: the checkpoint holds the mission's topic model");
    m.in_topicmodel.clear();
    EXPECT_TRUE(checkMission(m, plan).ok());

    m.resume = t.path;
    EXPECT_EQ(checkMission(m, plan).message(), "~resume: " + t.path + " is a directory, not a checkpoint file");

    // Frames of another size than the checkpoint's 64x48 are refused at start-up, naming the side.
    m.resume = ckpt;
    MissionInput in;
    in.width = 64;
    in.height = 40;
    EXPECT_EQ(planMission(m, in, plan).message(),
              "~resume " + ckpt + ": the frames are 40 pixels high but " + ckpt + " models 64x48 frames");
    in.width = 80;
    in.height = 48;
    EXPECT_EQ(planMission(m, in, plan).message(),
              "~resume " + ckpt + ": the frames are 80 pixels wide but " + ckpt + " models 64x48 frames");
    in.width = 64;
    EXPECT_TRUE(planMission(m, in, plan).ok());
}

TEST(Mission, AModelSettingWithoutEffectIsStillKeptSoTheSameCommandLineResumes) {
    // gamma matters only with topics.grow; a checkpoint made without growth
    // but with --gamma 0.5 on the command line must let the same command line
    // plus --resume go on, and still refuse another gamma.
    TempDir t;
    const std::string ckpt = makeCheckpoint(t, [](MissionOptions& m) { give(m, "gamma", "0.5"); });
    MissionOptions m = nodeLike();
    m.resume = ckpt;
    give(m, "gamma", "0.5");
    MissionPlan plan;
    EXPECT_TRUE(checkMission(m, plan).ok()) << checkMission(m, plan).message();
    EXPECT_EQ(plan.checkpoint.config.model.gamma, 0.5);
    m = nodeLike();
    m.resume = ckpt;
    give(m, "gamma", "0.4");
    EXPECT_EQ(checkMission(m, plan).message(),
              "~gamma = 0.4 differs from " + ckpt + "'s gamma = 0.5 (a resumed mission keeps its model; leave ~gamma out)");
}

TEST(Mission, AResumedMissionKeepsTheCheckpointsRefinementUnlessGivenAndTheRuntimeIsThisProcesss) {
    TempDir t;
    const std::string ckpt = makeCheckpoint(t);
    MissionOptions m;
    m.resume = ckpt;
    give(m, "queue.slots", "3");
    MissionInput in;
    in.threads = 2;
    MissionPlan plan;
    ASSERT_TRUE(planMission(m, in, plan).ok());
    EXPECT_TRUE(plan.resuming);
    EXPECT_EQ(plan.config.model.K, 6);
    EXPECT_EQ(plan.config.model.frame_width, 64) << "the checkpoint's frame size";
    EXPECT_EQ(plan.config.strategy.kind, StrategyKind::Now) << "the checkpoint's sampler";
    EXPECT_EQ(plan.config.budget.count, 3u);
    EXPECT_FALSE(plan.refinement_changed);
    EXPECT_EQ(plan.config.queue_slots, 3);
    EXPECT_EQ(plan.config.model.threads, 2);
    Status st;
    auto engine = openMission(m, plan, st);
    ASSERT_TRUE(engine) << st.message();
    EXPECT_EQ(engine->model().observations(), 5u) << "the checkpoint's state";

    // A refinement setting given replaces the checkpoint's: not bit for bit, and said so.
    MissionOptions changed;
    changed.resume = ckpt;
    give(changed, "sampler", "uniform");
    MissionPlan p2;
    ASSERT_TRUE(planMission(changed, in, p2).ok());
    EXPECT_EQ(p2.config.strategy.kind, StrategyKind::Uniform);
    EXPECT_TRUE(p2.refinement_changed);
    ASSERT_TRUE(openMission(changed, p2, st)) << st.message();

    // Frames of another size than the checkpoint models are refused.
    in.width = 80;
    MissionPlan p3;
    EXPECT_EQ(planMission(m, in, p3).message(),
              "--resume " + ckpt + ": the frames are 80 pixels wide but " + ckpt + " models 64x48 frames");
}

// Words from a fixed vocabulary (an extractor's): a resumed model must have
// that V unless V is given, and a V the user gives must hold the words.
TEST(Mission, WordsOfAVocabularyNeedTheirV) {
    TempDir t;
    const std::string ckpt = makeCheckpoint(t);  // V = 30
    MissionOptions m = nodeLike();
    m.resume = ckpt;
    MissionInput in;
    in.V = 40;
    in.vocabulary = true;
    MissionPlan plan;
    EXPECT_EQ(planMission(m, in, plan).message(),
              "~resume " + ckpt + ": its model has V = 30 words but the extractors produce 40 (use the vocabulary and "
              "word options of the run that made it)");
    in.V = 20;  // fewer words: their ids would mean other words
    MissionPlan p2;
    EXPECT_FALSE(planMission(m, in, p2).ok());
    give(m, "V", "30");  // said so: fine
    MissionPlan p3;
    EXPECT_TRUE(planMission(m, in, p3).ok());

    MissionOptions fresh = nodeLike();
    give(fresh, "V", "100");
    in.V = 5436;
    MissionPlan p4;
    in.words_detail = "ORB 5000 + intensity 256 + hue 180";
    EXPECT_EQ(planMission(fresh, in, p4).message(),
              "~V = 100 is smaller than the 5436 words the extractors produce (ORB 5000 + intensity 256 + hue 180)");
}

namespace {

void writeText(const std::string& path, const char* text) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr) << path;
    std::fputs(text, f);
    std::fclose(f);
}

} // namespace

// A word stream's frame: the face's own option, else frame.width/height
// given as settings, else the largest position; one rule for every face.
TEST(Mission, AStreamsFrameIsTheFacesOptionThenTheSettingThenTheData) {
    TempDir t;
    const std::string words = t.path + "/words.csv", positions = t.path + "/positions.csv";
    writeText(words, "0,1,2,3\n1,2,3,4\n");
    writeText(positions, "0,10,5,3,1,0,0\n1,0,0,1,1,2,2\n");
    auto frameOf = [&](MissionOptions& m, int width, int height) {
        StreamMissionInput in;
        in.words = words;
        in.positions = positions;
        in.width = width;
        in.height = height;
        StreamMission s;
        const Status st = openStreamMission(m, in, s);
        EXPECT_TRUE(st.ok()) << st.message();
        return std::to_string(s.plan.config.model.frame_width) + "x" + std::to_string(s.plan.config.model.frame_height);
    };
    MissionOptions none;
    EXPECT_EQ(frameOf(none, 0, 0), "11x6") << "the largest position";
    MissionOptions set;
    give(set, "frame.width", "80");
    give(set, "frame.height", "70");
    EXPECT_EQ(frameOf(set, 0, 0), "80x70") << "given as settings, they are the frame";
    EXPECT_EQ(frameOf(set, 40, 0), "40x70") << "the face's own option wins";
}

// An output of the mission (a checkpoint, a bag) that would replace or change
// one of its inputs is refused, however it is spelled; only the checkpoint
// may be the one resumed (a mission carried on in place).
TEST(Mission, AnOutputThatWouldChangeAnInputIsRefusedNamingIt) {
    TempDir t;
    const std::string dir = t.path;
    std::filesystem::create_directories(dir + "/frames");
    for (const char* f : {"/w.csv", "/frames/0001.png", "/m.ckpt", "/tm.csv"}) {
        std::FILE* fp = std::fopen((dir + f).c_str(), "w");
        ASSERT_NE(fp, nullptr) << f;
        std::fclose(fp);
    }
    MissionOptions m;
    m.inputs = {dir + "/w.csv", dir + "/frames", dir + "/frames/*.jpg"};
    m.resume = dir + "/m.ckpt";
    m.in_topicmodel = dir + "/tm.csv";
    const auto why = [&](const std::string& path, MissionOutput kind = MissionOutput::Checkpoint) {
        const Status st = checkMissionOutput(m, "--checkpoint", path, kind);
        return st.ok() ? std::string("ok") : st.message();
    };
    EXPECT_EQ(why(dir + "/w.csv"), "--checkpoint: " + dir + "/w.csv is an input of this run: writing there would replace it");
    EXPECT_EQ(why(dir + "/frames/../w.csv"), "--checkpoint: " + dir + "/frames/../w.csv is the same file as the input " + dir +
                                                 "/w.csv: writing there would replace it");
    EXPECT_NE(why(dir + "/./tm.csv").find("is the same file as the input " + dir + "/tm.csv"), std::string::npos);
    // What an input reads besides itself is the face's rule (vision::inputWouldRead): asked of every input.
    std::vector<std::string> asked;
    m.would_read = [&](const std::string& input, const std::string& path) {
        asked.push_back(input);
        return input == dir + "/frames" && path == dir + "/frames/0002.png";
    };
    EXPECT_EQ(why(dir + "/frames/0002.png"), "--checkpoint: " + dir + "/frames/0002.png would be read by the input " + dir +
                                                 "/frames: writing there would change it");
    EXPECT_EQ(asked, (std::vector<std::string>{dir + "/w.csv", dir + "/frames"}));
    EXPECT_EQ(why(dir + "/frames.ckpt"), "ok");
    m.would_read = nullptr;
    // The resumed checkpoint: the checkpoint may carry it on; another output may not replace it.
    EXPECT_EQ(why(dir + "/m.ckpt"), "ok");
    EXPECT_EQ(why(dir + "/m.ckpt", MissionOutput::Other),
              "--checkpoint: " + dir + "/m.ckpt is an input of this run: writing there would replace it");
    // The same text is the same file, even where the file cannot be compared (a pipe).
    m.inputs = {"/dev/stdin"};
    EXPECT_NE(why("/dev/stdin").find("is an input of this run"), std::string::npos) << why("/dev/stdin");
    EXPECT_NE(why(dir + "/no/such/dir/m.ckpt").find("--checkpoint: "), std::string::npos);
    EXPECT_NE(why(dir + "/no/such/dir/m.ckpt"), "ok");
}

// Two spellings of one path are one file, whether or not it exists yet
// (two outputs of a run, neither written): relative or absolute, with "./"
// or "dir/..", from the current directory.
TEST(Mission, TwoSpellingsOfAFileNotYetWrittenAreOneFile) {
    TempDir t;
    std::filesystem::create_directories(t.path + "/sub");
    const std::filesystem::path here = std::filesystem::current_path();
    std::filesystem::current_path(t.path);
    EXPECT_TRUE(sameFile("p.csv", "./p.csv"));
    EXPECT_TRUE(sameFile("p.csv", "sub/../p.csv"));
    EXPECT_TRUE(sameFile("p.csv", t.path + "/p.csv"));
    EXPECT_TRUE(sameFile("new/p.csv", "./new/p.csv")) << "a directory not made yet";
    EXPECT_FALSE(sameFile("p.csv", "sub/p.csv"));
    EXPECT_FALSE(sameFile("p.csv", "q.csv"));
    std::filesystem::current_path(here);
}
