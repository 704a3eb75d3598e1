// A fixed topic model (setting topicmodel.fixed; docs/design.md, "A fixed
// topic model"): the topic-word counts stay exactly as given, refinement
// labels the words in the given topics (topic k of the given model is label
// k), on any number of threads with the same labels, through evictions, and
// its perplexity leaves a word out of its cell's counts only.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "rost/config_file.hpp"
#include "rost/engine.hpp"
#include "rost/model.hpp"
#include "rost/settings.hpp"
#include "synthetic.hpp"

namespace {

namespace syn = rost::synthetic;

// Four planted topics on disjoint word blocks over a 16 x 8 grid of 16 px cells.
syn::Spec spec(uint64_t seed) { return syn::fourStripes(seed, 16, 8, 8); }

// The given model: K x V counts of another mission's words under their planted topics.
std::vector<int32_t> plantedCounts(const syn::Data& d) {
    const int V = d.config().V;
    std::vector<int32_t> counts(static_cast<std::size_t>(d.spec.K) * static_cast<std::size_t>(V), 0);
    for (std::size_t t = 0; t < d.words.size(); ++t)
        for (std::size_t i = 0; i < d.words[t].size(); ++i)
            ++counts[static_cast<std::size_t>(d.topics[t][i]) * static_cast<std::size_t>(V) + d.words[t][i]];
    return counts;
}

rost::Config fixedConfig(const syn::Data& d, int window) {
    rost::Config c = d.config();
    c.fixed = true;
    c.seed = 5;
    c.refine_window = window;
    return c;
}

struct Labelled {
    std::vector<uint16_t> labels;   // ML labels, every step in order
    std::vector<uint16_t> samples;  // Gibbs samples
    double agree = 0.0;             // share of words whose ML label is their planted topic (no matching)
};

Labelled label(rost::Model& m, const syn::Data& d, int sweeps) {
    for (int t = 0; t < d.spec.steps; ++t) EXPECT_TRUE(m.addObservation(d.words[t], d.positions[t]).ok());
    m.refineAll(sweeps);
    Labelled out;
    std::size_t same = 0, n = 0;
    for (int t = 0; t < d.spec.steps; ++t) {
        std::vector<uint16_t> z(m.observationSize(static_cast<uint64_t>(t))), s(z.size());
        m.observationLabels(static_cast<uint64_t>(t), z);
        m.observationSamples(static_cast<uint64_t>(t), s);
        for (std::size_t i = 0; i < z.size(); ++i) same += z[i] == d.topics[static_cast<std::size_t>(t)][i] ? 1 : 0;
        n += z.size();
        out.labels.insert(out.labels.end(), z.begin(), z.end());
        out.samples.insert(out.samples.end(), s.begin(), s.end());
    }
    out.agree = static_cast<double>(same) / static_cast<double>(n);
    return out;
}

// Every count of n_k^v and n_k is the given one.
::testing::AssertionResult countsAsGiven(const rost::Model& m, const std::vector<int32_t>& counts) {
    for (int k = 0; k < m.K(); ++k) {
        int64_t nk = 0;
        for (int v = 0; v < m.V(); ++v) {
            const int32_t want = counts[static_cast<std::size_t>(k) * static_cast<std::size_t>(m.V()) +
                                        static_cast<std::size_t>(v)];
            nk += want;
            if (m.topicWordCount(k, v) != want)
                return ::testing::AssertionFailure() << "n_k^v of topic " << k << ", word " << v << " is "
                                                     << m.topicWordCount(k, v) << ", given " << want;
        }
        if (m.topicCount(k) != nk)
            return ::testing::AssertionFailure() << "n_k of topic " << k << " is " << m.topicCount(k) << ", given " << nk;
    }
    return ::testing::AssertionSuccess();
}

// Labels of a new mission are the given topics' own numbers (no matching
// needed), and the model is exactly what was given; a learning model started
// from the same counts changes them.
TEST(FixedTopicModel, LabelsInTheGivenTopicsAndLeavesTheirCountsAsGiven) {
    const syn::Data given = syn::generate(spec(11)), mission = syn::generate(spec(12));
    const std::vector<int32_t> counts = plantedCounts(given);
    rost::Model m(fixedConfig(mission, 1));
    ASSERT_TRUE(m.addTopicCounts(counts).ok());
    const Labelled l = label(m, mission, 20);
    EXPECT_TRUE(countsAsGiven(m, counts));
    EXPECT_EQ(m.wordsInModel(), given.totalWords());
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
    EXPECT_GE(l.agree, 0.95) << "ML labels equal to the planted topic";

    rost::Config learning = fixedConfig(mission, 1);
    learning.fixed = false;
    rost::Model free(learning);
    ASSERT_TRUE(free.addTopicCounts(counts).ok());
    label(free, mission, 20);
    EXPECT_FALSE(countsAsGiven(free, counts)) << "a learning model adds the mission's words";
}

// A fixed model's task refines a cell against its whole neighbourhood, the
// next step's cell included. Word 2 is equally likely under both given
// topics; at step 0 each of eight cells holds only word 2, and at step 1 the
// same cell holds a word only one topic gives (1 in the even cells, 0 in the
// odd ones). Step 1's words pull step 0's to their topic in every cell; a
// neighbourhood of past steps only leaves each cell's word 2 to chance.
TEST(FixedTopicModel, ACellsWordsFollowTheTopicOfItsNextStep) {
    rost::Config c;
    c.V = 3;
    c.K = 2;
    c.fixed = true;
    c.alpha = 0.1;
    c.beta = 0.01;
    c.cell_space = 32;
    c.frame_width = 8 * 32;
    c.frame_height = 32;
    c.g_space = 0;
    c.g_time = 1;
    c.ring_steps = 4;
    c.cell_capacity = 64;
    c.max_words_per_frame = 8 * 40;
    c.seed = 9;
    for (const int threads : {1, 2}) {
        SCOPED_TRACE(threads);
        c.threads = threads;
        rost::Model m(c);
        // topic 0: words 0 and 2; topic 1: words 1 and 2, as often.
        ASSERT_TRUE(m.addTopicCounts(std::vector<int32_t>{1000, 0, 1000, 0, 1000, 1000}).ok());
        std::vector<uint32_t> w0, w1;
        std::vector<rost::Position> p;
        for (int cell = 0; cell < 8; ++cell)
            for (int i = 0; i < 40; ++i) {
                w0.push_back(2);
                w1.push_back(cell % 2 == 0 ? 1 : 0);
                p.push_back({cell * 32 + i % 32, i % 32});
            }
        ASSERT_TRUE(m.addObservation(w0, p).ok());
        ASSERT_TRUE(m.addObservation(w1, p).ok());
        m.refineAll(30);
        std::vector<uint16_t> z(m.observationSize(0));
        m.observationLabels(0, z);
        ASSERT_EQ(z.size(), w0.size());
        for (int cell = 0; cell < 8; ++cell) {
            const uint16_t want = cell % 2 == 0 ? 1 : 0;
            int same = 0;
            for (int i = 0; i < 40; ++i) same += z[static_cast<std::size_t>(cell * 40 + i)] == want ? 1 : 0;
            EXPECT_GE(same, 36) << "cell " << cell << ": " << same << " of 40 words in the topic of its next step";
        }
    }
}

// In parallel windows the cells of a round are refined at once against the
// fixed counts: the same labels and samples on 1, 2 and 3 threads, and no
// count changes.
TEST(FixedTopicModel, SameLabelsOnAnyNumberOfThreads) {
    const syn::Data given = syn::generate(spec(13)), mission = syn::generate(spec(14));
    const std::vector<int32_t> counts = plantedCounts(given);
    Labelled one;
    for (int threads : {1, 2, 3}) {
        rost::Model m(fixedConfig(mission, 64));
        m.setThreads(threads);
        ASSERT_TRUE(m.addTopicCounts(counts).ok());
        const Labelled l = label(m, mission, 10);
        EXPECT_TRUE(countsAsGiven(m, counts)) << threads << " threads";
        std::string why;
        EXPECT_TRUE(m.checkInvariants(&why)) << why;
        EXPECT_GE(l.agree, 0.95) << threads << " threads";
        if (threads == 1) {
            one = l;
            continue;
        }
        EXPECT_TRUE(l.labels == one.labels) << threads << " threads";
        EXPECT_TRUE(l.samples == one.samples) << threads << " threads";
    }
}

// Steps that leave the window take nothing from the given counts, whatever the eviction policy.
TEST(FixedTopicModel, EvictionLeavesTheGivenCounts) {
    const syn::Data given = syn::generate(spec(15)), mission = syn::generate(spec(16));
    const std::vector<int32_t> counts = plantedCounts(given);
    rost::Config c = fixedConfig(mission, 1);
    c.ring_steps = 3;
    c.eviction = rost::EvictionPolicy::Subtract;
    rost::Model m(c);
    ASSERT_TRUE(m.addTopicCounts(counts).ok());
    for (int t = 0; t < mission.spec.steps; ++t) {
        ASSERT_TRUE(m.addObservation(mission.words[t], mission.positions[t]).ok());
        m.refineStep(t);
    }
    EXPECT_TRUE(countsAsGiven(m, counts));
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
}

// The left-out perplexity: p(w_i) = sum_k phi_k(w_i) theta(k), phi from the
// given counts as they are (word i is not in them), theta from the cell's
// counts without word i: rebuilt here from the public counts (one cell a
// step, no neighbours).
TEST(FixedTopicModel, PerplexityLeavesAWordOutOfItsCellOnly) {
    rost::Config c;
    c.K = 3;
    c.V = 12;
    c.alpha = 0.4;
    c.beta = 0.3;
    c.frame_width = c.frame_height = 8;
    c.cell_space = 64;
    c.g_space = 0;
    c.g_time = 0;
    c.fixed = true;
    rost::Model m(c);
    std::vector<int32_t> counts(static_cast<std::size_t>(c.K * c.V));
    for (std::size_t i = 0; i < counts.size(); ++i) counts[i] = static_cast<int32_t>((i * 7) % 5 + (i % 4 == 0 ? 20 : 0));
    ASSERT_TRUE(m.addTopicCounts(counts).ok());
    rost::Rng r(3);
    std::vector<uint32_t> w(30);
    std::vector<rost::Position> p(30);
    for (auto& x : w) x = r.below(static_cast<uint32_t>(c.V));
    ASSERT_TRUE(m.addObservation(w, p).ok());
    m.refineAll(5);
    std::vector<uint16_t> z(w.size());
    m.observationSamples(0, z);
    const auto h = m.cellHistogram(0, 0);
    const double n = static_cast<double>(w.size());
    double nll = 0.0;
    for (std::size_t i = 0; i < w.size(); ++i) {
        double pw = 0.0;
        for (int k = 0; k < c.K; ++k) {
            const double phi = (m.topicWordCount(k, static_cast<int>(w[i])) + c.beta) / (m.topicCount(k) + c.V * c.beta);
            const double own = k == z[i] ? 1.0 : 0.0;
            pw += phi * (h[static_cast<std::size_t>(k)] - own + c.alpha) / (n - 1 + c.K * c.alpha);
        }
        nll -= std::log(pw);
    }
    const rost::LogLoss got = m.cellLogLoss(0, 0);
    ASSERT_EQ(got.words, w.size());
    EXPECT_NEAR(got.nll, nll, 1e-9 * nll);
}

TEST(FixedTopicModel, IsRefusedWithTopicsThatGrow) {
    rost::Config c;
    c.fixed = true;
    c.grow = true;
    const rost::Status st = c.validate();
    ASSERT_FALSE(st.ok());
    const std::string want = "topics.grow = true, allowed false with topicmodel.fixed = true; a fixed topic model opens no topics";
    EXPECT_NE(st.message().find(want), std::string::npos) << st.message();
    // Every check of the settings finds it, not only Config::validate (an
    // engine's, a settings file's), each naming both settings.
    rost::EngineConfig e;
    e.model = c;
    const auto p = rost::checkEngineSettings(e);
    ASSERT_TRUE(p.has_value());
    EXPECT_NE(p->describe(p->spec->key).find(want), std::string::npos) << p->describe(p->spec->key);
    rost::Settings s;
    s.engine = e;
    const rost::Status sv = s.validate();
    ASSERT_FALSE(sv.ok());
    EXPECT_NE(sv.message().find(want), std::string::npos) << sv.message();
    rost::EngineConfig parsed;
    const rost::Status pt = rost::parseConfigText("topics.grow = on\ntopicmodel.fixed = yes\n", "fixed.conf", parsed);
    ASSERT_FALSE(pt.ok());
    EXPECT_NE(pt.message().find(want), std::string::npos) << pt.message();
}

} // namespace
