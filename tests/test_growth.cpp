// Topics that grow (settings topics.grow, gamma; docs/design.md, "Topics that
// grow", "Growth from the data"): growth from one topic on planted data finds
// the planted number for any gamma, merges join duplicates, the cap is respected, labels stay compact (0..A-1), the result is
// the same on any number of threads, and the counts stay consistent.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "rost/model.hpp"
#include "rost/topic_model_csv.hpp"
#include "synthetic.hpp"

namespace {

namespace syn = rost::synthetic;

// Four planted topics on disjoint word blocks, as vertical stripes drifting
// over a 32 x 8 grid of 16 px cells, 10 steps, 8-12 words per cell (~25 k words).
syn::Spec plantedSpec(uint64_t seed) { return syn::fourStripes(seed, 32, 8, 10); }

rost::Config growthConfig(const syn::Data& d, int cap, double gamma, uint64_t seed) {
    rost::Config c = d.config();
    c.K = cap;
    c.grow = true;
    c.gamma = gamma;
    c.seed = seed;
    return c;
}

struct Grown {
    int active = 0;
    double purity = 0.0;  // sum over learned topics of their largest planted share / words
    std::vector<uint16_t> labels;
};

Grown grow(const syn::Data& d, const rost::Config& c, int sweeps, int threads = 1) {
    rost::Model m(c);
    if (threads > 1) m.setThreads(threads);
    EXPECT_EQ(m.activeTopics(), 0) << "no topic is open before the first word";
    for (int t = 0; t < d.spec.steps; ++t) EXPECT_TRUE(m.addObservation(d.words[t], d.positions[t]).ok());
    m.refineAll(sweeps);
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
    Grown g;
    g.active = m.activeTopics();
    for (int t = 0; t < d.spec.steps; ++t) {
        std::vector<uint16_t> z(d.words[t].size());
        m.observationLabels(static_cast<uint64_t>(t), z);
        g.labels.insert(g.labels.end(), z.begin(), z.end());
    }
    std::vector<uint16_t> truth;
    for (const auto& step : d.topics) truth.insert(truth.end(), step.begin(), step.end());
    const auto n = syn::contingency(g.labels, truth, c.K, d.spec.K);
    double agree = 0.0;
    for (const auto& row : n) agree += *std::max_element(row.begin(), row.end());
    g.purity = agree / static_cast<double>(truth.size());
    return g;
}

// Words a topic holds under the ML labels, by output label.
std::vector<int> sizes(const Grown& g, int cap) {
    std::vector<int> n(static_cast<std::size_t>(cap), 0);
    for (uint16_t z : g.labels) ++n[z];
    return n;
}

// From one topic, growth opens the four planted topics, each holding a
// quarter of the words, and nothing besides: the split moves find them and
// the merge moves leave no duplicate (docs/design.md, "Growth from the data").
// The answer comes from the data: the same four for gamma 1e-7 to 0.1 (the
// decade problem of a new topic weighing gamma / V is gone).
TEST(TopicGrowth, FromOneTopicFindsThePlantedTopicsForAnyGamma) {
    const syn::Data d = syn::generate(plantedSpec(7));
    for (const double gamma : {1e-7, 1e-4, 0.1}) {
        for (uint64_t seed : {1, 2}) {
            const Grown g = grow(d, growthConfig(d, 16, gamma, seed), 60);
            const std::vector<int> n = sizes(g, 16);
            int big = 0, maxLabel = -1;
            for (int k = 0; k < 16; ++k) {
                big += n[k] >= static_cast<int>(g.labels.size() / 50) ? 1 : 0;
                if (n[k] > 0) maxLabel = k;
            }
            std::printf("[ growth ] gamma %g seed %d: A %d, topics with >= 2%% of the words %d, purity %.3f\n", gamma,
                        static_cast<int>(seed), g.active, big, g.purity);
            EXPECT_EQ(big, d.spec.K) << "gamma " << gamma << " seed " << seed;
            EXPECT_EQ(g.active, d.spec.K) << "gamma " << gamma << " seed " << seed << ": no junk topic";
            EXPECT_GE(g.purity, 0.95) << "gamma " << gamma << " seed " << seed;
            EXPECT_LT(maxLabel, g.active) << "labels are numbered 0..A-1";
        }
    }
}

// Merge moves: each planted topic starts as two labels (the initial labels
// given, split at random), and the merges join them back into four.
TEST(TopicGrowth, MergeMovesJoinTopicsThatShareTheirWords) {
    const syn::Data d = syn::generate(plantedSpec(11));
    rost::Model m(growthConfig(d, 16, 0.01, 5));
    rost::Rng r(6);
    for (int t = 0; t < d.spec.steps; ++t) {
        std::vector<uint16_t> labels(d.words[t].size());
        for (std::size_t i = 0; i < labels.size(); ++i)
            labels[i] = static_cast<uint16_t>(2 * d.topics[t][i] + r.below(2));
        ASSERT_TRUE(m.addObservation(d.words[t], d.positions[t], labels).ok());
    }
    EXPECT_EQ(m.activeTopics(), 2 * d.spec.K);
    m.refineAll(60);
    EXPECT_EQ(m.activeTopics(), d.spec.K);
    EXPECT_GT(m.growthMovesAccepted(), 0u);
    EXPECT_GT(m.learnedGamma(), 0.0);
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
}

// topicmodel.csv of a grown model: a line per open topic, line i the topic
// labelled i, none for a closed slot. The merges above close slots among
// the open ones, so slot order and label order part.
TEST(TopicGrowth, TopicModelCsvHoldsTheOpenTopicsInLabelOrder) {
    const syn::Data d = syn::generate(plantedSpec(11));
    rost::Model m(growthConfig(d, 16, 0.01, 5));
    rost::Rng r(6);
    for (int t = 0; t < d.spec.steps; ++t) {
        std::vector<uint16_t> labels(d.words[t].size());
        for (std::size_t i = 0; i < labels.size(); ++i)
            labels[i] = static_cast<uint16_t>(2 * d.topics[t][i] + r.below(2));
        ASSERT_TRUE(m.addObservation(d.words[t], d.positions[t], labels).ok());
    }
    m.refineAll(60);
    const int A = m.activeTopics();
    ASSERT_EQ(A, d.spec.K);
    std::vector<uint16_t> slots(16);
    m.slotsInLabelOrder(slots);
    bool parted = false;  // a closed slot below an open one
    for (int i = 0; i < A; ++i) parted |= slots[static_cast<std::size_t>(i)] != i;
    EXPECT_TRUE(parted) << "the test needs a closed slot among the open ones";
    std::vector<std::string> lines;
    std::istringstream in(rost::formatTopicModelCsv(m));
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    ASSERT_EQ(lines.size(), static_cast<std::size_t>(A));
    for (int i = 0; i < A; ++i) {
        std::string expected;
        for (int v = 0; v < m.V(); ++v)
            expected += (v ? "," : "") + std::to_string(m.topicWordCount(slots[static_cast<std::size_t>(i)], v));
        EXPECT_EQ(lines[static_cast<std::size_t>(i)], expected) << "line " << i;
    }
}

// With the cap below the planted number, growth stops at the cap.
TEST(TopicGrowth, StopsAtTheCap) {
    const syn::Data d = syn::generate(plantedSpec(8));
    rost::Model m(growthConfig(d, 2, 0.01, 3));
    for (int t = 0; t < d.spec.steps; ++t) ASSERT_TRUE(m.addObservation(d.words[t], d.positions[t]).ok());
    m.refineAll(40);
    EXPECT_EQ(m.activeTopics(), 2);
    EXPECT_TRUE(m.topicCapReached());
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
}

// Growth in parallel windows: the same topics and labels on 1, 2 and 3 threads.
TEST(TopicGrowth, SameResultOnAnyNumberOfThreads) {
    const syn::Data d = syn::generate(plantedSpec(9));
    rost::Config c = growthConfig(d, 16, 1e-3, 4);
    c.refine_window = 64;
    const Grown one = grow(d, c, 15, 1);
    EXPECT_GT(one.active, 1);
    for (int threads : {2, 3}) {
        const Grown many = grow(d, c, 15, threads);
        EXPECT_EQ(many.active, one.active) << threads << " threads";
        EXPECT_TRUE(many.labels == one.labels) << threads << " threads";
    }
}

} // namespace

// The plug-in perplexity (the 2013 ROST code's) with topics that grow and A
// open topics of K: theta_c over the open topics and the chance of a new one,
// (n_c^k + alpha) / (n_c + A alpha + f) and f / (n_c + A alpha + f) with its
// words uniform (f = kGrowthFreshMass), rebuilt here from the model's public counts.
TEST(TopicGrowth, PluginPerplexityNormalisesOverTheOpenTopics) {
    rost::Config c;
    c.K = 12;
    c.V = 30;
    c.frame_width = c.frame_height = 8;
    c.cell_space = 64;  // one cell a step: its words are the observation's
    c.ring_steps = 16;
    c.grow = true;
    c.gamma = 0.5;
    c.alpha = 0.3;
    c.beta = 0.2;
    rost::Model m(c);
    rost::Rng r(9);
    std::vector<uint32_t> w(40);
    std::vector<rost::Position> p(40);
    for (int t = 0; t < 10; ++t) {
        for (auto& x : w) x = r.below(10) + (t < 5 ? 0u : 15u);  // two blocks of words, in turn
        ASSERT_TRUE(m.addObservation(w, p).ok());
        m.refineAll(3);
    }
    const int A = m.activeTopics();
    ASSERT_GT(A, 1);
    ASSERT_LT(A, c.K) << "the test needs closed topics";
    for (int64_t t = m.oldestStep(); t < m.steps(); ++t) {
        std::vector<uint32_t> words(m.observationSize(static_cast<uint64_t>(t)));
        m.observationWords(static_cast<uint64_t>(t), words);
        const auto h = m.cellHistogram(t, 0);
        const double n = static_cast<double>(m.cellWordCount(t, 0));
        const double norm = n + A * c.alpha + rost::kGrowthFreshMass;
        double nll = 0.0;
        for (uint32_t v : words) {
            double pw = rost::kGrowthFreshMass / norm / c.V;
            for (int k = 0; k < c.K; ++k)
                if (m.topicOpen(k))
                    pw += (m.topicWordCount(k, static_cast<int>(v)) + c.beta) / (m.topicCount(k) + c.V * c.beta) *
                          (h[static_cast<std::size_t>(k)] + c.alpha) / norm;
            nll -= std::log(pw);
        }
        const rost::LogLoss got = m.cellPluginLogLoss(t, 0);
        ASSERT_EQ(got.words, words.size());
        EXPECT_NEAR(got.nll, nll, 1e-9 * std::abs(nll)) << "step " << t;
    }
}

namespace {

// Steps in order, over and over (a sweep picker).
class InOrder final : public rost::StepPicker {
public:
    explicit InOrder(const rost::Model& m) : m_(m), t_(m.oldestStep()) {}
    int64_t next() noexcept override {
        const int64_t t = t_;
        t_ = t_ + 1 < m_.steps() ? t_ + 1 : m_.oldestStep();
        return t;
    }

private:
    const rost::Model& m_;
    int64_t t_;
};

// A time budget's stand-in: refines or not, and affords `allowance` tokens.
class Afford final : public rost::RefineControl {
public:
    bool refine = true;
    uint64_t allowance = UINT64_MAX;
    bool beforeRound(uint64_t) noexcept override { return refine; }
    uint64_t tokenAllowance() noexcept override { return allowance; }
};

} // namespace

// Under a control (a time budget) a move earned by one call runs at the start
// of the next, and its split moves only the tokens of the steps the call's
// share affords: on a stream whose last six steps bring new words (new
// terrain), from one topic, a split kept within three steps' words: the new
// topic's words lie in three steps at most (a split of the whole window
// would take the new words of all six).
TEST(TopicGrowth, UnderATimeBudgetTheSplitTakesOnlyTheStepsItAffords) {
    rost::Config c;
    c.K = 8;
    c.V = 400;
    c.grow = true;
    c.frame_width = c.frame_height = 32;
    c.cell_space = 16;  // 4 cells a step
    c.ring_steps = 16;
    c.seed = 8;
    rost::Model m(c);
    rost::Rng r(9);
    constexpr int kSteps = 10, kWords = 200;
    auto burst = [](int t) { return t >= 4; };  // six steps of new words
    for (int t = 0; t < kSteps; ++t) {
        std::vector<uint32_t> w(kWords);
        std::vector<rost::Position> p(kWords);
        for (int i = 0; i < kWords; ++i) {
            w[i] = (burst(t) ? 200u : 0u) + r.below(200);
            p[i] = {static_cast<int32_t>(r.below(32)), static_cast<int32_t>(r.below(32))};
        }
        ASSERT_TRUE(m.addObservation(w, p).ok());
    }
    ASSERT_EQ(m.activeTopics(), 1);
    InOrder order(m);
    Afford control;
    rost::RefineLimits limits;
    limits.control = &control;
    bool split = false;
    for (int call = 0; call < 40 && !split; ++call) {
        limits.steps = kSteps;  // a sweep: the next call owes a move
        control.refine = true;
        control.allowance = UINT64_MAX;
        m.refine(order, limits);
        ASSERT_EQ(m.activeTopics(), 1) << "no move before the next call";
        control.refine = false;  // the next call only moves
        control.allowance = 4 * 3 * kWords;  // a quarter: three steps' words
        m.refine(order, limits);
        split = m.activeTopics() == 2;
    }
    ASSERT_TRUE(split) << "a split was kept";
    // The new topic: the smaller of the two (no refinement ran after the split).
    std::vector<std::vector<uint16_t>> z(kSteps);
    uint64_t count[2] = {0, 0};
    for (int t = 0; t < kSteps; ++t) {
        z[t].resize(m.observationSize(static_cast<uint64_t>(t)));
        m.observationSamples(static_cast<uint64_t>(t), z[t]);
        for (uint16_t k : z[t]) ++count[k];
    }
    const uint16_t fresh = count[1] < count[0] ? 1 : 0;
    int first = -1, last = -1;
    for (int t = 0; t < kSteps; ++t) {
        if (std::find(z[t].begin(), z[t].end(), fresh) == z[t].end()) continue;
        if (first < 0) first = t;
        last = t;
    }
    EXPECT_LE(last - first + 1, 3) << "the new topic's steps " << first << ".." << last;
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
}
