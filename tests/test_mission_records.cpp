// A mission's results (rost/mission_records.hpp): the one place the rules of
// perplexity.csv and topics.csv live for every face. Each row's
// instantaneous and final perplexities are checked against values taken
// independently, by the engine's hooks at the instants the paper names; every
// observation gets its final labels exactly once, in order, even when a step
// of many observations leaves the window at once.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "rost/engine.hpp"
#include "rost/mission_records.hpp"
#include "test_engine_support.hpp"

using namespace rost;
using rost::testing::Frame;

namespace {

EngineConfig config(int cellTime, int ringSteps) {
    EngineConfig e;
    e.model = rost::testing::smallConfig();
    e.model.cell_time = cellTime;
    e.model.ring_steps = ringSteps;
    e.budget = Budget::steps(2);
    return e;
}

struct Reference {
    std::map<uint64_t, double> instantaneous, final;  // by observation
    std::map<uint64_t, int64_t> step;
};

// Plays `frames` through `e`, drained after each one, with the engine's own
// hooks taking the reference values: a step's perplexity as the next step
// opens (the observation hook of the step's first observation reports it)
// and as its observations leave (the eviction hook).
void play(Engine& e, MissionRecords& records, const std::vector<Frame>& frames, Reference& ref) {
    e.setObservationHook([&](const ObservationResult& r, const Model&) {
        ref.step[r.observation] = r.step;
        if (r.previous_step >= 0)
            for (const auto& [ob, st] : ref.step)
                if (st == r.previous_step) ref.instantaneous[ob] = r.previous_perplexity;
    });
    e.setEvictionHook([&](const WindowObservation& w, const Model& m) { ref.final[w.observation] = m.stepPerplexity(w.step); });
    for (const Frame& f : frames) {
        (void)e.processNow(f.view());
        records.drain();
    }
}

TEST(MissionRecords, AStepOfManyObservationsLeavingTheWindowLosesNoFinalLabels) {
    // cell.time 8, a ring of 2 steps: each new step evicts 8 observations at once.
    Engine e(config(8, 2));
    MissionRecords records(e, 4);
    ASSERT_TRUE(records.status().ok());
    std::vector<uint64_t> order;
    std::vector<uint32_t> sizes;
    records.setFinalSink(
        [&](const FinalLabels& f) {
            order.push_back(f.where.observation);
            sizes.push_back(f.n);
            for (uint32_t i = 0; i < f.n; ++i) ASSERT_LT(f.labels[i], 8) << "observation " << f.where.observation;
        },
        true);
    const auto frames = rost::testing::makeStream(e.model().config(), 48, 40, 3);
    Reference ref;
    play(e, records, frames, ref);
    records.finish(2);
    EXPECT_EQ(records.lost(), 0u);
    ASSERT_EQ(order.size(), frames.size()) << "every observation's final labels, once";
    for (std::size_t i = 0; i < order.size(); ++i) {
        EXPECT_EQ(order[i], i) << "in observation order";
        EXPECT_EQ(sizes[i], frames[i].words.size());
    }
    EXPECT_EQ(records.finals(), frames.size());
}

TEST(MissionRecords, EachRowsPerplexitiesAreItsStepsAtTheInstantsThePaperNames) {
    Engine e(config(2, 4));
    MissionRecords records(e, 4);
    const auto frames = rost::testing::makeStream(e.model().config(), 30, 60, 5);
    Reference ref;
    play(e, records, frames, ref);
    // The last step's instantaneous perplexity is taken at the end of its
    // budget, before the final sweeps; the window's finals after them.
    Model& m = e.model();
    const int64_t last = m.steps() - 1;
    const double lastInstant = m.stepPerplexity(last);
    records.finish(3);
    std::map<int64_t, double> after;  // each window step's perplexity after the sweeps
    e.visitWindow([&](const WindowObservation& w, const Model& mm) { after[w.step] = mm.stepPerplexity(w.step); });
    const auto& rows = records.rows();
    ASSERT_EQ(rows.size(), frames.size());
    int evicted = 0, inWindow = 0;
    for (const MissionRow& r : rows) {
        SCOPED_TRACE("observation " + std::to_string(r.observation));
        EXPECT_EQ(r.timestamp, frames[r.observation].timestamp) << "the caller's tag is carried";
        EXPECT_EQ(r.step, static_cast<int64_t>(r.observation / 2));
        if (r.step == last) EXPECT_EQ(r.instantaneous, lastInstant);
        else EXPECT_EQ(r.instantaneous, ref.instantaneous.at(r.observation));
        if (ref.final.count(r.observation)) {
            EXPECT_EQ(r.final, ref.final.at(r.observation));
            ++evicted;
        } else {
            EXPECT_EQ(r.final, after.at(r.step));
            ++inWindow;
        }
        EXPECT_TRUE(std::isfinite(r.plugin));
        EXPECT_EQ(r.topics, 8);
        EXPECT_EQ(r.cell_surprise.size(), static_cast<std::size_t>(records.cells()));
    }
    EXPECT_EQ(evicted, 22);  // 15 steps, a ring of 4: 11 steps of 2 left
    EXPECT_EQ(inWindow, 8);
}

TEST(MissionRecords, AResumedMissionsRowsStartAtItsFirstObservationAndARefusedOneIsNamed) {
    Engine e(config(1, 4));
    MissionRecords records(e, 4);
    const auto frames = rost::testing::makeStream(e.model().config(), 6, 20, 9);
    for (int i = 0; i < 3; ++i) (void)e.processNow(frames[static_cast<std::size_t>(i)].view());
    records.drain();  // the "checkpoint's" observations, before the mission's first
    MissionRecords resumed(e, 4);
    resumed.setFirstObservation(3);
    for (int i = 3; i < 6; ++i) (void)e.processNow(frames[static_cast<std::size_t>(i)].view());
    Frame bad = frames[0];
    bad.timestamp = 777;
    bad.words[4] = 400;  // V = 400: out of range
    (void)e.processNow(bad.view());
    resumed.drain();
    ASSERT_EQ(resumed.rows().size(), 3u);
    EXPECT_EQ(resumed.rows().front().observation, 3u);
    EXPECT_EQ(resumed.rejection().any, true);
    EXPECT_EQ(resumed.rejection().timestamp, 777);
    EXPECT_EQ(resumed.rejection().error, AddError::WordOutOfRange);
    EXPECT_EQ(resumed.rejection().index, 4u);
    const std::string csv = resumed.perplexityCsv("timestamp");
    EXPECT_EQ(csv.substr(0, csv.find('\n')), "timestamp,instantaneous,final,plugin,topics");
}

// Each cell's dominant topic (the overlay's tint, the bag's cell_topics) is
// the topic with the most labels there, the lowest on a tie, and none for a
// cell without words: with every word in cell 0, the other cells have none
// and cell 0's is the step's most frequent topic.
TEST(MissionRecords, ACellsDominantTopicIsItsMostFrequentAndAnEmptyCellHasNone) {
    Engine e(config(1, 4));
    MissionRecords records(e, 4);
    ASSERT_TRUE(records.status().ok());
    std::vector<ObservationRecord> seen;
    records.setObservationSink([&](const ObservationRecord& r) { seen.push_back(r); });
    std::vector<Frame> frames = rost::testing::makeStream(e.model().config(), 6, 30, 5);
    for (Frame& f : frames)
        for (std::size_t i = 0; i < f.positions.size(); ++i)
            f.positions[i] = {static_cast<int32_t>(i % 64), static_cast<int32_t>((i * 7) % 64)};  // cell 0
    for (const Frame& f : frames) {
        (void)e.processNow(f.view());
        records.drain();
    }
    ASSERT_EQ(seen.size(), frames.size());
    for (const ObservationRecord& r : seen) {
        ASSERT_EQ(r.dominant.size(), 12u);  // 4 x 3 cells
        for (std::size_t c = 1; c < r.dominant.size(); ++c)
            EXPECT_EQ(r.dominant[c], ObservationRecord::kNoTopic) << "cell " << c << ", observation " << r.observation;
        const auto most = std::max_element(r.topic_share.begin(), r.topic_share.end());  // the first of equals
        ASSERT_GT(*most, 0.f);
        EXPECT_EQ(r.dominant[0], static_cast<uint16_t>(most - r.topic_share.begin())) << "observation " << r.observation;
    }
}

} // namespace
