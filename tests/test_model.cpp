#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

#include "aligned_buffer.hpp"
#include "rost/model.hpp"
#include "rost/model_eigen.hpp"

namespace {

rost::Config smallConfig() {
    rost::Config c;
    c.K = 6;
    c.V = 50;
    c.frame_width = 64;
    c.frame_height = 48;
    c.cell_space = 16;  // 4 x 3 cells
    c.ring_steps = 8;
    c.cell_capacity = 10;
    c.max_words_per_frame = 40;
    return c;
}

void randomFrame(rost::Rng& r, const rost::Config& c, uint32_t n, std::vector<uint32_t>& w,
                 std::vector<rost::Position>& p) {
    w.resize(n);
    p.resize(n);
    for (uint32_t i = 0; i < n; ++i) {
        w[i] = r.below(static_cast<uint32_t>(c.V));
        p[i] = {static_cast<int32_t>(r.below(static_cast<uint32_t>(c.frame_width))),
                static_cast<int32_t>(r.below(static_cast<uint32_t>(c.frame_height)))};
    }
}

// Rng::state() and setState() carry the whole generator: another Rng given
// the state draws what this one draws, word for word.
TEST(RngState, SetStateCarriesEveryWord) {
    rost::Rng a(7);
    for (int i = 0; i < 10; ++i) (void)a.next();
    rost::Rng b(99);
    b.setState(a.state());
    for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.next(), b.next()) << "draw " << i;
    const rost::Rng::State s = a.state();
    rost::Rng c(1);
    c.setState(s);
    for (int w = 0; w < 4; ++w) EXPECT_EQ(c.stateWords()[static_cast<std::size_t>(w)], s.s[w]) << "word " << w;
}

// A layout holds kMaxSections; one more marks it overflowed (the extra one
// unlisted), and clear() makes it empty and whole again.
TEST(StateLayoutSections, OverflowIsMarkedAndClearedWithTheSections) {
    rost::StateLayout layout;
    int32_t values[rost::StateLayout::kMaxSections + 1] = {};
    for (std::size_t i = 0; i < rost::StateLayout::kMaxSections; ++i) layout.add("s", 1, &values[i], 1);
    EXPECT_FALSE(layout.overflowed());
    EXPECT_EQ(layout.size(), rost::StateLayout::kMaxSections);
    layout.add("extra", 1, &values[rost::StateLayout::kMaxSections], 1);
    EXPECT_TRUE(layout.overflowed());
    EXPECT_EQ(layout.size(), rost::StateLayout::kMaxSections);
    EXPECT_EQ(layout.find("extra"), nullptr);
    layout.clear();
    EXPECT_FALSE(layout.overflowed()) << "a cleared layout still said it overflowed";
    EXPECT_EQ(layout.size(), 0u);
    layout.add("again", 1, &values[0], 1);
    ASSERT_NE(layout.find("again"), nullptr);
    EXPECT_EQ(layout.find("again")->bytes, sizeof(int32_t));
}

// Randomised sequences of adds (including over-full frames and cells),
// refinements of cells, steps and batch sweeps, under both eviction
// policies and several cell.time values: every count table must match the
// labels after every operation.
TEST(ModelInvariants, HoldAfterEveryOperationInRandomSequences) {
    for (auto policy : {rost::EvictionPolicy::Keep, rost::EvictionPolicy::Subtract})
        for (int cellTime : {1, 3}) {
            rost::Config c = smallConfig();
            c.eviction = policy;
            c.cell_time = cellTime;
            c.seed = 7 + static_cast<uint64_t>(cellTime);
            rost::Model m(c);
            rost::Rng r(99);
            std::vector<uint32_t> w;
            std::vector<rost::Position> p;
            uint64_t kept = 0;
            for (int op = 0; op < 400; ++op) {
                const uint32_t choice = r.below(5);
                if (choice == 0 || m.steps() == 0) {
                    randomFrame(r, c, r.below(70), w, p);  // sometimes beyond max words and capacity
                    const rost::AddResult res = m.addObservation(w, p);
                    ASSERT_TRUE(res.ok());
                    EXPECT_EQ(res.kept + res.dropped_cell + res.dropped_frame, w.size());
                    kept += res.kept;
                } else if (choice == 1) {
                    m.refineCell(m.oldestStep() + r.below(static_cast<uint32_t>(m.steps() - m.oldestStep())),
                                 static_cast<int>(r.below(static_cast<uint32_t>(m.cellsPerStep()))));
                } else if (choice == 2) {
                    m.refineStep(m.steps() - 1);
                } else if (choice == 3) {
                    m.refineAll(1);
                } else {
                    m.refineStep(m.oldestStep());
                }
                std::string why;
                ASSERT_TRUE(m.checkInvariants(&why)) << "op " << op << ": " << why;
            }
            if (policy == rost::EvictionPolicy::Keep) EXPECT_EQ(m.wordsInModel(), kept);
            else EXPECT_LT(m.wordsInModel(), kept);
        }
}

TEST(ModelInvariants, CheckerDetectsCorruption) {
    // The invariant check must be able to fail: break a label behind its back.
    rost::Config c = smallConfig();
    rost::Model m(c);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    rost::Rng r(3);
    randomFrame(r, c, 30, w, p);
    ASSERT_TRUE(m.addObservation(w, p).ok());
    ASSERT_TRUE(m.checkInvariants());
    auto hist = m.cellHistogram(0, 0);
    ASSERT_FALSE(hist.empty());
    const_cast<int32_t&>(hist[0]) += 1;
    std::string why;
    EXPECT_FALSE(m.checkInvariants(&why));
    EXPECT_NE(why.find("n_c^k"), std::string::npos) << why;
}

TEST(ModelIngest, RejectsOutOfRangeWordAndPositionWithoutChangingState) {
    rost::Config c = smallConfig();
    rost::Model m(c);
    std::vector<uint32_t> w = {1, 2, 50};
    std::vector<rost::Position> p = {{0, 0}, {1, 1}, {2, 2}};
    rost::AddResult res = m.addObservation(w, p);
    EXPECT_EQ(res.error, rost::AddError::WordOutOfRange);
    EXPECT_EQ(res.index, 2u);
    w[2] = 3;
    p[1] = {64, 0};
    res = m.addObservation(w, p);
    EXPECT_EQ(res.error, rost::AddError::PositionOutOfRange);
    EXPECT_EQ(res.index, 1u);
    p[1] = {-1, 0};
    EXPECT_EQ(m.addObservation(w, p).error, rost::AddError::PositionOutOfRange);
    // Each side's bound: [0, width) and [0, height), the last pixel taken.
    for (const rost::Position q : {rost::Position{0, c.frame_height}, rost::Position{0, -1},
                                   rost::Position{c.frame_width, c.frame_height - 1}}) {
        p[1] = q;
        res = m.addObservation(w, p);
        EXPECT_EQ(res.error, rost::AddError::PositionOutOfRange) << q.x << "," << q.y;
        EXPECT_EQ(res.index, 1u);
    }
    EXPECT_EQ(m.observations(), 0u);
    EXPECT_EQ(m.addObservation(w, std::span(p).first(2)).error, rost::AddError::SizeMismatch);
    EXPECT_EQ(m.observations(), 0u);
    EXPECT_EQ(m.wordsInModel(), 0u);
    p[1] = {c.frame_width - 1, c.frame_height - 1};
    EXPECT_EQ(m.addObservation(w, p).error, rost::AddError::None);
    EXPECT_EQ(m.observations(), 1u);
}

TEST(ModelIngest, WordsLandInTheirCellAndOverflowIsUniformlySubsampled) {
    rost::Config c = smallConfig();
    c.cell_capacity = 4;
    rost::Model m(c);
    // 10 words in cell (1,1) = index 5; 2 words in cell 0.
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (uint32_t i = 0; i < 10; ++i) {
        w.push_back(i);
        p.push_back({20, 20});
    }
    w.push_back(40);
    p.push_back({0, 0});
    w.push_back(41);
    p.push_back({15, 15});
    const rost::AddResult res = m.addObservation(w, p);
    ASSERT_TRUE(res.ok());
    EXPECT_EQ(res.kept, 6u);
    EXPECT_EQ(res.dropped_cell, 6u);
    EXPECT_EQ(m.cellWordCount(0, 5), 4u);
    EXPECT_EQ(m.cellWordCount(0, 0), 2u);
    EXPECT_EQ(m.observationSize(0), 12u);  // every input keeps a label
}

TEST(ModelIngest, CellSubsampleIsUniform) {
    // Each of 10 words competing for 4 places must be kept with probability 0.4.
    rost::Config c = smallConfig();
    c.cell_capacity = 4;
    c.ring_steps = 1;
    c.g_time = 0;
    rost::Model m(c);
    std::vector<uint32_t> w(10);
    std::vector<rost::Position> p(10, rost::Position{20, 20});
    for (uint32_t i = 0; i < 10; ++i) w[i] = i;
    const int trials = 4000;
    for (int t = 0; t < trials; ++t) ASSERT_TRUE(m.addObservation(w, p).ok());
    // With Keep eviction the word-topic counts accumulate every kept word:
    // sum over topics of n_k^v for word v = times v was kept.
    double chi2 = 0.0;
    const double expect = trials * 0.4;
    for (uint32_t k = 0; k < 10; ++k) {
        int kept = 0;
        for (int z = 0; z < c.K; ++z) kept += m.topicWordCount(z, static_cast<int>(k));
        chi2 += (kept - expect) * (kept - expect) / (expect * 0.6);
    }
    // Exactly 4 of 10 kept per trial: the standardised counts have covariance
    // (10/9) I - (1/9) J, so 0.9 chi2 follows chi-square with 9 degrees of
    // freedom; P(chi2_9 > 27.88) = 0.001 is the false-failure rate.
    EXPECT_LT(0.9 * chi2, 27.88);
}

// A cell's surprise is the surprise of the observation's own new words in
// it, not of every word the cell holds: with one cell and two observations a
// step (cell.time 2), the cell's surprise after the second is the second
// observation's, and after the first the first's.
TEST(ModelSurprise, ACellsSurpriseIsItsNewestObservationsWordsAlone) {
    rost::Config c = smallConfig();
    c.cell_space = 64;  // one cell
    c.cell_time = 2;
    c.cell_capacity = 80;
    rost::Model m(c);
    rost::Rng r(4);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (int f = 0; f < 8; ++f) {
        randomFrame(r, c, 20 + static_cast<uint32_t>(f), w, p);
        ASSERT_TRUE(m.addObservation(w, p).ok());
        m.refineAll(2);
        const uint64_t last = m.observations() - 1;
        const auto cs = m.cellSurprise(m.steps() - 1);
        ASSERT_EQ(cs.size(), 1u);
        EXPECT_NEAR(cs[0], m.observationSurprise(last), 1e-3 * m.observationSurprise(last)) << "observation " << f;
    }
}

// A step of two observations (cell.time 2) whose second adds no word to a
// cell: that cell keeps the surprise the first gave it (its words are the
// first observation's), the cell the second adds words to gets the second's,
// and a cell no observation of the step reached holds 0.
TEST(ModelSurprise, ACellTheStepsLaterObservationMissesKeepsItsEarlierSurprise) {
    rost::Config c = smallConfig();  // 4 x 3 cells of 16 pixels
    c.cell_time = 2;
    rost::Model m(c);
    rost::Rng r(8);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (int f = 0; f < 4; ++f) {  // a model to be surprised by
        randomFrame(r, c, 30, w, p);
        ASSERT_TRUE(m.addObservation(w, p).ok());
    }
    const std::vector<rost::Position> both = {{1, 1}, {2, 2}, {3, 1}, {17, 1}, {18, 2}, {19, 3}};
    ASSERT_TRUE(m.addObservation(std::vector<uint32_t>{3, 4, 5, 40, 41, 42}, both).ok());
    const int64_t step = m.steps() - 1;
    const std::vector<float> first(m.cellSurprise(step).begin(), m.cellSurprise(step).end());
    ASSERT_GT(first[0], 0.f);
    ASSERT_GT(first[1], 0.f);
    EXPECT_EQ(first[5], 0.f) << "a cell without words";
    ASSERT_TRUE(m.addObservation(std::vector<uint32_t>{7, 8}, std::vector<rost::Position>{{2, 3}, {4, 4}}).ok());
    ASSERT_EQ(m.steps() - 1, step) << "one step";
    const auto after = m.cellSurprise(step);
    EXPECT_EQ(after[1], first[1]) << "the cell the second observation missed";
    EXPECT_NEAR(after[0], m.observationSurprise(m.observations() - 1), 1e-3 * after[0]) << "the cell it reached";
    EXPECT_NE(after[0], first[0]);
    EXPECT_EQ(after[5], 0.f);
}

// The surprise formula itself (docs/design.md, "Curiosity"), from the
// model's counts as they stood before the observation was added: a cell's
// words' mean negative log of p(w) = sum_k phi_k(w) theta(k), phi_k(w) =
// (n_k^w + beta) / (n_k + V beta), theta(k) = (g_k + alpha) / (g + K alpha),
// g the topic counts of the cell and its spatial neighbours (Manhattan
// g.space) in the g.time steps before; the global n_k where those hold none.
// The observation's surprise is over all its words.
TEST(ModelSurprise, FollowsItsFormulaFromTheCountsBeforeTheWordsArrive) {
    rost::Config c;
    c.K = 3;
    c.V = 6;
    c.alpha = 0.3;
    c.beta = 0.2;
    c.frame_width = 128;
    c.frame_height = 64;
    c.cell_space = 32;  // 4 x 2 cells, row-major
    c.g_space = 1;
    c.g_time = 2;
    c.ring_steps = 8;
    c.cell_capacity = 64;
    c.max_words_per_frame = 64;
    rost::Model m(c);
    rost::Rng r(21);
    const int cellsX = 4, cells = 8;
    auto cellOf = [&](const rost::Position& q) { return q.y / 32 * cellsX + q.x / 32; };
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    auto frame = [&](int maxX) {  // 24 words with x < maxX
        w.resize(24);
        p.resize(24);
        for (int i = 0; i < 24; ++i) {
            w[i] = r.below(6);
            p[i] = {static_cast<int32_t>(r.below(static_cast<uint32_t>(maxX))), static_cast<int32_t>(r.below(64))};
        }
    };
    for (int f = 0; f < 4; ++f) {  // the left half only: cells 2, 3, 6 and 7's right neighbours stay empty
        frame(64);
        ASSERT_TRUE(m.addObservation(w, p).ok());
        m.refineAll(3);
    }
    for (int round = 0; round < 2; ++round) {
        frame(128);  // the whole frame: cells 3 and 7 have no words around them in the steps before
        const int64_t step = m.steps();
        std::vector<double> nll(cells, 0.0);
        std::vector<int> n(cells, 0);
        for (std::size_t i = 0; i < w.size(); ++i) {
            const int cell = cellOf(p[i]);
            std::vector<double> g(3, 0.0);
            for (int dt = 1; dt <= c.g_time; ++dt) {
                for (int other = 0; other < cells; ++other) {
                    if (std::abs(other % cellsX - cell % cellsX) + std::abs(other / cellsX - cell / cellsX) > c.g_space) continue;
                    for (int k = 0; k < 3; ++k) g[k] += m.cellHistogram(step - dt, other)[k];
                }
            }
            double gsum = g[0] + g[1] + g[2];
            if (gsum == 0)
                for (int k = 0; k < 3; ++k) gsum += (g[k] = m.topicCount(k));
            double pw = 0.0;
            for (int k = 0; k < 3; ++k)
                pw += (m.topicWordCount(k, static_cast<int>(w[i])) + c.beta) / (m.topicCount(k) + c.V * c.beta) *
                      (g[k] + c.alpha) / (gsum + c.K * c.alpha);
            nll[cell] -= std::log(pw);
            ++n[cell];
        }
        ASSERT_TRUE(m.addObservation(w, p).ok());
        double total = 0.0;
        int words = 0, fallback = 0;
        for (int cell = 0; cell < cells; ++cell) {
            ASSERT_EQ(m.cellWordCount(step, cell), static_cast<uint32_t>(n[cell])) << "cell " << cell << " (the layout)";
            const double expected = n[cell] ? std::exp(nll[cell] / n[cell]) : 0.0;
            EXPECT_NEAR(m.cellSurprise(step)[cell], expected, 1e-5 * expected) << "round " << round << ", cell " << cell;
            total += nll[cell];
            words += n[cell];
            fallback += round == 0 && (cell % cellsX == 3) && n[cell] > 0;
        }
        if (round == 0) {
            EXPECT_GT(fallback, 0) << "no word took the global mix";
        }
        EXPECT_NEAR(m.observationSurprise(m.observations() - 1), std::exp(total / words), 1e-5 * std::exp(total / words));
        m.refineAll(3);
    }
}

TEST(ModelPerplexity, FiniteAndBoundedByVocabularyForUniformModel) {
    rost::Config c = smallConfig();
    rost::Model m(c);
    rost::Rng r(5);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (int f = 0; f < 5; ++f) {
        randomFrame(r, c, 30, w, p);
        ASSERT_TRUE(m.addObservation(w, p).ok());
    }
    m.refineAll(3);
    for (int64_t t = m.oldestStep(); t < m.steps(); ++t) {
        const double ppx = m.stepPerplexity(t);
        EXPECT_TRUE(std::isfinite(ppx));
        EXPECT_GT(ppx, 1.0);
        // Words drawn uniformly from V: no model does much better than V.
        EXPECT_GT(ppx, 0.5 * c.V);
    }
}

// beta's smallest value (1e-30, settings_schema.hpp) still gives finite
// perplexities and surprise: the sampler's tables are single precision, and
// a beta below float's smallest normal (1e-38 and less) made them NaN; the
// check refuses those.
TEST(ModelPerplexity, TheSmallestBetaTakenGivesFiniteMeasurements) {
    rost::Config c = smallConfig();
    c.beta = 1e-30;
    ASSERT_TRUE(c.validate().ok()) << c.validate().message();
    rost::Model m(c);
    rost::Rng r(5);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (int f = 0; f < 5; ++f) {
        randomFrame(r, c, 30, w, p);
        ASSERT_TRUE(m.addObservation(w, p).ok());
        EXPECT_TRUE(std::isfinite(m.observationSurprise(static_cast<uint64_t>(f)))) << f;
        m.refineAll(2);
    }
    for (int64_t t = m.oldestStep(); t < m.steps(); ++t) {
        EXPECT_TRUE(std::isfinite(m.stepPerplexity(t))) << t;
        EXPECT_TRUE(std::isfinite(m.stepPluginPerplexity(t))) << t;
    }
    c.beta = 1e-31;
    EXPECT_EQ(c.validate().message(), "invalid configuration: beta = 1e-31, allowed [1e-30, 1000000]");
}

// An observation's positions read back as given, to the frame's last pixel
// on each side (65535: both coordinates use all 16 bits of their half).
TEST(ModelIngest, PositionsReadBackAsGivenToTheFramesLastPixel) {
    rost::Config c;
    c.K = 2;
    c.V = 4;
    c.frame_width = c.frame_height = 65536;
    c.cell_space = 4096;  // 16 x 16 cells
    c.ring_steps = 2;
    rost::Model m(c);
    const std::vector<uint32_t> w = {0, 1, 2, 3};
    const std::vector<rost::Position> p = {{65535, 65535}, {256, 40000}, {300, 5}, {0, 257}};
    ASSERT_TRUE(m.addObservation(w, p).ok());
    std::vector<rost::Position> back(p.size());
    m.observationPositions(0, back);
    for (std::size_t i = 0; i < p.size(); ++i) {
        EXPECT_EQ(back[i].x, p[i].x) << i;
        EXPECT_EQ(back[i].y, p[i].y) << i;
    }
}

// Initial labels given instead of drawn (rost-cli's --in.topics): the
// samples are exactly those labels, the counts agree with them, and a label
// of K or a labels span of another length is refused before anything changes.
TEST(ModelIngest, GivenInitialLabelsAreTheSamplesAndCountOnce) {
    rost::Config c = smallConfig();  // K = 6
    c.cell_capacity = 40;
    rost::Model m(c);
    rost::Rng r(3);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    randomFrame(r, c, 30, w, p);
    std::vector<uint16_t> z(w.size());
    for (std::size_t i = 0; i < z.size(); ++i) z[i] = static_cast<uint16_t>((i * 7) % 6);
    ASSERT_TRUE(m.addObservation(w, p, z).ok());
    std::vector<uint16_t> samples(w.size());
    m.observationSamples(0, samples);
    EXPECT_EQ(samples, z);
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
    int64_t total = 0;
    for (int k = 0; k < c.K; ++k) total += m.topicCount(k);
    EXPECT_EQ(total, static_cast<int64_t>(w.size()));

    z[4] = 6;
    rost::AddResult bad = m.addObservation(w, p, z);
    EXPECT_EQ(bad.error, rost::AddError::LabelOutOfRange);
    EXPECT_EQ(bad.index, 4u);
    z.pop_back();
    bad = m.addObservation(w, p, z);
    EXPECT_EQ(bad.error, rost::AddError::SizeMismatch);
    EXPECT_EQ(m.observations(), 1u) << "a refused observation changes nothing";
}

// p(v | every other label) for word slot i (word wi, label z) left out,
// rebuilt from the public counts of a one-cell, one-step model (G(c) is the
// cell): n'_k^v = n_k^v - [k = z, v = wi], n'_k = n_k - [k = z], n'_G^k =
// n_G^k - [k = z]; a topic is open while n'_k > 0 (growth; all K otherwise),
// A' open ones, and a new topic takes kGrowthFreshMass / V while A' < K (growth):
//   p(v) = (sum_k open (n'_k^v + beta) / (n'_k + V beta) (n'_G^k + alpha) + fresh / V)
//          / (n'_G + A' alpha + fresh).
double leftOutConditional(const rost::Model& m, uint32_t v, uint32_t wi, int z) {
    const rost::Config& c = m.config();
    const std::span<const int32_t> g = m.cellHistogram(0, 0);
    double num = 0.0, gsum = 0.0;
    int open = 0;
    for (int k = 0; k < c.K; ++k) {
        const int32_t nk = m.topicCount(k) - (k == z ? 1 : 0);
        const double nG = g[static_cast<std::size_t>(k)] - (k == z ? 1 : 0);
        gsum += nG;
        if (c.grow && nk <= 0) continue;
        ++open;
        const double nkv = m.topicWordCount(k, static_cast<int>(v)) - (k == z && v == wi ? 1 : 0);
        num += (nkv + c.beta) / (nk + c.V * c.beta) * (nG + c.alpha);
    }
    const double fresh = c.grow && open < c.K ? rost::kGrowthFreshMass : 0.0;
    return (num + fresh / c.V) / (gsum + open * c.alpha + fresh);
}

// Every stored word's wordLogProb is the left-out conditional rebuilt from the
// public counts, and that conditional is a distribution over the vocabulary:
// with all K topics, and with growth (A < K open, a word that is its topic's
// last closing it and freeing gamma for a new one).
TEST(ModelPerplexity, WordLogProbIsTheNormalisedLeftOutConditional) {
    for (const bool grow : {false, true}) {
        SCOPED_TRACE(grow ? "growth" : "all K topics");
        rost::Config c;
        c.K = 8;
        c.V = 24;
        c.frame_width = c.frame_height = 32;
        c.cell_space = 32;  // one cell
        c.ring_steps = 1;
        c.cell_capacity = 64;
        c.max_words_per_frame = 64;
        c.grow = grow;
        c.gamma = 0.3;
        c.seed = 5;
        rost::Model m(c);
        rost::Rng r(8);
        std::vector<uint32_t> w(48);
        std::vector<rost::Position> p(48, rost::Position{3, 4});
        for (auto& x : w) x = r.below(static_cast<uint32_t>(c.V));
        ASSERT_TRUE(m.addObservation(w, p).ok());
        m.refineAll(3);
        const int A = m.activeTopics();
        if (grow) {
            ASSERT_LT(A, c.K) << "growth leaves topics to open";
            // Open topics 0..A-1: the output numbering of the samples is the counts'.
            for (int k = 0; k < c.K; ++k) ASSERT_EQ(m.topicCount(k) > 0, k < A) << "topic " << k;
        }
        std::vector<uint16_t> z(w.size());
        m.observationSamples(0, z);
        for (uint32_t i = 0; i < w.size(); ++i) {
            SCOPED_TRACE("word slot " + std::to_string(i));
            double sum = 0.0;
            for (uint32_t v = 0; v < static_cast<uint32_t>(c.V); ++v) sum += leftOutConditional(m, v, w[i], z[i]);
            EXPECT_NEAR(sum, 1.0, 1e-12);
            EXPECT_NEAR(m.wordLogProb(0, 0, i), std::log(leftOutConditional(m, w[i], w[i], z[i])), 1e-12);
        }
    }
}

// The maximum-likelihood labels break ties toward the lowest topic
// (rost/model.hpp). K = 3, V = 1, one cell holding word 0 three times with
// labels 0, 1, 2: left out, a word's own topic scores alpha and each other
// topic (1 + beta) / (1 + beta) (1 + alpha), the same: labels 1, 0, 0.
TEST(ModelLabels, TiesGoToTheLowestTopic) {
    rost::Config c;
    c.K = 3;
    c.V = 1;
    c.frame_width = c.frame_height = 1;
    c.ring_steps = 2;
    rost::Model m(c);
    const std::vector<uint32_t> w = {0, 0, 0};
    const std::vector<rost::Position> p(3, rost::Position{0, 0});
    const std::vector<uint16_t> given = {0, 1, 2};
    ASSERT_TRUE(m.addObservation(w, p, given).ok());
    std::vector<uint16_t> labels(3);
    m.observationLabels(0, labels);
    EXPECT_EQ(labels, (std::vector<uint16_t>{1, 0, 0}));
}

// A word its full cell dropped is in no count, so nothing is left out for
// it: its sample and its label are the argmax over the counts as they stand.
// K = 2, V = 1, a cell of capacity 2 holding word 0 labelled 0 and 1: both
// topics score (1 + beta) / (1 + beta) (1 + alpha), and the tie gives 0 (had
// the word been taken for topic 0's own, topic 1 would win).
TEST(ModelLabels, ADroppedWordIsLabelledFromTheCountsAsTheyStand) {
    rost::Config c;
    c.K = 2;
    c.V = 1;
    c.frame_width = c.frame_height = 1;
    c.ring_steps = 2;
    c.cell_time = 2;
    c.cell_capacity = 2;
    rost::Model m(c);
    const std::vector<rost::Position> p(2, rost::Position{0, 0});
    ASSERT_TRUE(m.addObservation(std::vector<uint32_t>{0, 0}, p, std::vector<uint16_t>{0, 1}).ok());
    const rost::AddResult second = m.addObservation(std::vector<uint32_t>{0}, std::span(p).first(1));
    ASSERT_TRUE(second.ok());
    ASSERT_EQ(second.dropped_cell, 1u);
    std::vector<uint16_t> sample(1, 9), label(1, 9);
    m.observationSamples(1, sample);
    m.observationLabels(1, label);
    EXPECT_EQ(sample[0], 0);
    EXPECT_EQ(label[0], 0);
}

// Nothing is measured outside the grid or past a cell's words, even where
// the next step's slot of the ring holds words (one cell a step: cell 1 of
// step 0 would be step 1's cell 0 if read past the grid).
TEST(ModelPerplexity, NothingIsMeasuredOutsideTheGridOrPastACellsWords) {
    rost::Config c;
    c.K = 2;
    c.V = 4;
    c.frame_width = c.frame_height = 1;
    c.ring_steps = 2;
    rost::Model m(c);
    const std::vector<uint32_t> w = {0, 1, 2};
    const std::vector<rost::Position> p(3, rost::Position{0, 0});
    ASSERT_TRUE(m.addObservation(w, p).ok());
    ASSERT_TRUE(m.addObservation(w, p).ok());
    ASSERT_EQ(m.cellsPerStep(), 1);
    ASSERT_EQ(m.cellWordCount(1, 0), 3u);
    for (const int cell : {-1, 1}) {
        EXPECT_EQ(m.cellLogLoss(0, cell).words, 0u) << cell;
        EXPECT_EQ(m.cellPluginLogLoss(0, cell).words, 0u) << cell;
        EXPECT_TRUE(m.cellHistogram(0, cell).empty()) << cell;
        EXPECT_EQ(m.cellWordCount(0, cell), 0u) << cell;
        EXPECT_TRUE(std::isnan(m.wordLogProb(0, cell, 0))) << cell;
    }
    EXPECT_TRUE(std::isfinite(m.wordLogProb(0, 0, 2)));
    EXPECT_TRUE(std::isnan(m.wordLogProb(0, 0, 3))) << "past the cell's 3 words";
}

// Growth, a word that is its topic's last: left out, it closes that topic
// (one open topic fewer in the normaliser, none of its mass in the sum) and
// frees the fresh mass for a new one. K = 4, labels 0, 0, 0, 1, 1, 2: word 5
// is topic 2's only word; every word's wordLogProb is still the conditional
// rebuilt from the public counts.
TEST(ModelPerplexity, AWordThatIsItsTopicsLastClosesItWhenLeftOut) {
    rost::Config c;
    c.K = 4;
    c.V = 6;
    c.alpha = 0.4;
    c.beta = 0.3;
    c.frame_width = c.frame_height = 1;
    c.ring_steps = 1;
    c.grow = true;
    c.gamma = 0.5;
    rost::Model m(c);
    const std::vector<uint32_t> w = {0, 1, 2, 3, 4, 5};
    const std::vector<rost::Position> p(6, rost::Position{0, 0});
    const std::vector<uint16_t> given = {0, 0, 0, 1, 1, 2};
    ASSERT_TRUE(m.addObservation(w, p, given).ok());
    ASSERT_EQ(m.activeTopics(), 3);
    ASSERT_EQ(m.topicCount(2), 1);
    std::vector<uint16_t> z(w.size());
    m.observationSamples(0, z);
    ASSERT_EQ(z, given);
    for (uint32_t i = 0; i < w.size(); ++i)
        EXPECT_NEAR(m.wordLogProb(0, 0, i), std::log(leftOutConditional(m, w[i], w[i], z[i])), 1e-12) << "word slot " << i;
}

// ---- plug-in perplexity (the 2013 ROST code's) ----------------------------------

// One topic, one cell, words [0, 0, 1] of V = 4, beta = 0.5: theta is 1, so
// the plug-in p(w) = (n_w + beta) / (N + V beta) with every word counted
// (0: 2.5 / 5, 1: 1.5 / 5), where the left-out one takes the word out first
// (0: 1.5 / 4, 1: 0.5 / 4).
TEST(ModelPluginPerplexity, KeepsTheWordInItsCountsWhereOursLeavesItOut) {
    rost::Config c;
    c.K = 1;
    c.V = 4;
    c.beta = 0.5;
    c.frame_width = c.frame_height = 1;
    c.ring_steps = 2;
    rost::Model m(c);
    const std::vector<uint32_t> w = {0, 0, 1};
    const std::vector<rost::Position> p(3, rost::Position{0, 0});
    ASSERT_TRUE(m.addObservation(w, p).ok());
    const double plugin = std::exp(-(2 * std::log(0.5) + std::log(0.3)) / 3);
    const double leftOut = std::exp(-(2 * std::log(0.375) + std::log(0.125)) / 3);
    EXPECT_NEAR(m.stepPluginPerplexity(0), plugin, 1e-12);
    EXPECT_NEAR(m.stepPerplexity(0), leftOut, 1e-12);
    const rost::LogLoss cell = m.cellPluginLogLoss(0, 0);
    EXPECT_EQ(cell.words, 3u);
    EXPECT_NEAR(cell.perplexity(), plugin, 1e-12);
    // Nothing outside the window or the grid.
    EXPECT_TRUE(std::isnan(m.stepPluginPerplexity(1)));
    EXPECT_EQ(m.cellPluginLogLoss(0, 1).words, 0u);
}

// The definition, recomputed from the public counts: each word's cell from
// its position, theta from that cell's own histogram, phi from n_k^v.
TEST(ModelPluginPerplexity, IsTheCodesFormulaOverTheCellsOwnTopicMix) {
    rost::Config c = smallConfig();
    c.cell_time = 2;
    rost::Model m(c);
    rost::Rng r(17);
    std::vector<std::vector<uint32_t>> words;
    std::vector<std::vector<rost::Position>> positions;
    for (int f = 0; f < 6; ++f) {
        words.emplace_back();
        positions.emplace_back();
        randomFrame(r, c, 12, words.back(), positions.back());  // no cell fills up
        ASSERT_EQ(m.addObservation(words.back(), positions.back()).kept, 12u);
        m.refineAll(2);
    }
    const double vbeta = c.V * c.beta;
    for (int64_t t = 0; t < m.steps(); ++t) {
        double nll = 0.0;
        uint64_t n = 0;
        for (uint64_t f = static_cast<uint64_t>(t) * 2; f < static_cast<uint64_t>(t + 1) * 2; ++f)
            for (std::size_t i = 0; i < words[f].size(); ++i) {
                const int cell = positions[f][i].y / c.cell_space * c.gridWidth() + positions[f][i].x / c.cell_space;
                const auto h = m.cellHistogram(t, cell);
                const double nc = m.cellWordCount(t, cell);
                double pw = 0.0;
                for (int k = 0; k < c.K; ++k)
                    pw += (m.topicWordCount(k, static_cast<int>(words[f][i])) + c.beta) / (m.topicCount(k) + vbeta) *
                          (h[static_cast<std::size_t>(k)] + c.alpha) / (nc + c.K * c.alpha);
                nll -= std::log(pw);
                ++n;
            }
        const rost::LogLoss got = m.stepPluginLogLoss(t);
        EXPECT_EQ(got.words, n) << t;
        EXPECT_NEAR(got.nll, nll, 1e-9 * nll) << t;
    }
}

TEST(ModelMemory, ReportedUpFrontAndCoversTheRing) {
    rost::Config c;
    rost::Model m(c);
    const std::size_t ringWords = static_cast<std::size_t>(c.ring_steps) * c.cellsPerStep() * c.cell_capacity;
    EXPECT_GE(m.memoryBytes(), ringWords * (sizeof(uint32_t) + sizeof(uint16_t)));
    EXPECT_GE(m.memoryBytes(), static_cast<std::size_t>(c.V) * 16 * sizeof(int32_t));
}

} // namespace

namespace {

TEST(ModelState, CopiedStateResumesBitForBit) {
    rost::Config c = smallConfig();
    c.ring_steps = 4;  // wraps during the run
    rost::Model a(c);
    rost::Rng r(21);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (int f = 0; f < 6; ++f) {
        randomFrame(r, c, 30, w, p);
        ASSERT_TRUE(a.addObservation(w, p).ok());
        a.refineAll(1);
    }
    // Copy every state buffer into a fresh model built from the same config.
    std::vector<std::vector<char>> saved;
    rost::StateLayout layoutA;
    a.describeState(layoutA);
    for (const rost::StateSection& s : layoutA.sections())
        saved.emplace_back(static_cast<char*>(s.data), static_cast<char*>(s.data) + s.bytes);
    rost::Config other = c;
    other.seed = 999;  // the RNG state comes from the copy, not the seed
    rost::Model b(other);
    rost::StateLayout layoutB;
    b.describeState(layoutB);
    ASSERT_EQ(layoutB.size(), saved.size());
    for (std::size_t i = 0; i < layoutB.size(); ++i) {
        ASSERT_EQ(saved[i].size(), layoutB[i].bytes) << layoutB[i].name;
        std::memcpy(layoutB[i].data, saved[i].data(), layoutB[i].bytes);
    }
    b.stateRestored();  // as the API asks after the sections were written back
    std::string why;
    ASSERT_TRUE(b.checkInvariants(&why)) << why;
    for (int f = 0; f < 5; ++f) {
        randomFrame(r, c, 30, w, p);
        ASSERT_TRUE(a.addObservation(w, p).ok());
        ASSERT_TRUE(b.addObservation(w, p).ok());
        a.refineAll(2);
        b.refineAll(2);
    }
    std::vector<uint16_t> la(64), lb(64);
    for (uint64_t f = a.observations() - 4; f < a.observations(); ++f) {
        a.observationSamples(f, la);
        b.observationSamples(f, lb);
        EXPECT_EQ(la, lb) << "frame " << f;
    }
    EXPECT_EQ(a.tokensRefined(), b.tokensRefined());
    EXPECT_EQ(a.observationSurprise(a.observations() - 1), b.observationSurprise(b.observations() - 1));
}

} // namespace

#if defined(__linux__)
namespace {
std::size_t pageBytes() { return static_cast<std::size_t>(::sysconf(_SC_PAGESIZE)); }
// How many of the pages of [p, p + bytes) are in memory (p page-aligned).
std::size_t residentPages(const void* p, std::size_t bytes) {
    std::vector<unsigned char> in((bytes + pageBytes() - 1) / pageBytes());
    if (::mincore(const_cast<void*>(p), bytes, in.data()) != 0) return SIZE_MAX;
    return static_cast<std::size_t>(std::count_if(in.begin(), in.end(), [](unsigned char c) { return (c & 1) != 0; }));
}
// The process's anonymous memory that is its own (written pages, not the
// shared zero page a read maps), in bytes; 0 where the kernel does not say.
std::size_t anonymousBytes() {
    std::FILE* f = std::fopen("/proc/self/smaps_rollup", "r");
    if (f == nullptr) return 0;
    char line[256];
    unsigned long kb = 0;
    while (std::fgets(line, sizeof line, f) != nullptr)
        if (std::sscanf(line, "Anonymous: %lu kB", &kb) == 1) break;
    std::fclose(f);
    return static_cast<std::size_t>(kb) * 1024;
}
} // namespace
#endif

// Set-up zeroing on several threads (the ring's tables): every byte, for
// sizes that are and are not whole 2 MiB pages, whatever the thread count.
TEST(AlignedBuffer, ZeroerClearsEveryByteOnAnyNumberOfThreads) {
    for (const std::size_t bytes : {std::size_t{1} << 10, (std::size_t{9} << 20) + 4100, std::size_t{24} << 20}) {
        std::vector<unsigned char> buf(bytes, 0xA5);
        for (int threads : {1, 2, 3, 7}) {
            std::fill(buf.begin(), buf.end(), static_cast<unsigned char>(0xA5));
            rost::PageZeroer z;
            z.add(buf.data(), bytes);
            z.run(threads);
            EXPECT_EQ(std::count(buf.begin(), buf.end(), 0), static_cast<std::ptrdiff_t>(bytes))
                << bytes << " bytes, " << threads << " threads";
        }
    }
    for (int threads : {1, 2}) {  // an empty buffer's null data: nothing to touch
        rost::PageZeroer z;
        z.add(nullptr, 0);
        z.run(threads);
    }
    rost::AlignedBuffer<uint32_t> empty;
    empty.reset(0, 1);
    EXPECT_EQ(empty.data(), nullptr);
    rost::AlignedBuffer<uint32_t> b;
    b.reset((std::size_t{10} << 20) / 4 + 3, 2);
    EXPECT_EQ(std::count(b.data(), b.data() + b.size(), 0u), static_cast<std::ptrdiff_t>(b.size()));
}

// Several buffers zeroed together (a model's ring tables): every byte of
// every range, none outside them, for ranges of under one piece, of whole
// and partial 2 MiB pieces, on any number of threads; then the zeroer is
// empty and can be used again.
TEST(AlignedBuffer, PageZeroerClearsEveryRangeAndNothingElse) {
    const std::size_t sizes[] = {100, (std::size_t{2} << 20) + 7, std::size_t{4} << 20, 4096, (std::size_t{5} << 20) + 1};
    std::size_t total = 0;
    for (std::size_t n : sizes) total += n + 64;  // a guard band after each range
    std::vector<unsigned char> buf(total);
    for (int threads : {1, 2, 3, 8}) {
        std::fill(buf.begin(), buf.end(), static_cast<unsigned char>(0xA5));
        rost::PageZeroer z;
        std::size_t at = 0;
        for (std::size_t n : sizes) {
            z.add(buf.data() + at, n);
            at += n + 64;
        }
        z.add(buf.data(), 0);  // an empty range is no range
        EXPECT_EQ(z.bytes(), total - 64 * std::size(sizes));
        z.run(threads);
        EXPECT_EQ(z.bytes(), 0u);
        at = 0;
        for (std::size_t n : sizes) {
            EXPECT_EQ(std::count(buf.begin() + static_cast<std::ptrdiff_t>(at), buf.begin() + static_cast<std::ptrdiff_t>(at + n), 0),
                      static_cast<std::ptrdiff_t>(n))
                << n << " bytes, " << threads << " threads";
            EXPECT_EQ(std::count(buf.begin() + static_cast<std::ptrdiff_t>(at + n), buf.begin() + static_cast<std::ptrdiff_t>(at + n + 64),
                                 static_cast<unsigned char>(0xA5)),
                      64)
                << "guard after " << n << " bytes, " << threads << " threads";
            at += n + 64;
        }
    }
    // Buffers registered with a zeroer are zero once it has run: a small one
    // from the heap is written (whatever the allocator handed out), a large
    // one is a fresh mapping, zero already, whose pages the run faults in.
    for (int threads : {1, 2}) {
        rost::PageZeroer z;
        rost::AlignedBuffer<uint32_t> a, b;
        a.reset((std::size_t{5} << 20) / 4 + 5, z);
        b.reset(1000, z);
        std::fill_n(b.data(), b.size(), 7u);
        EXPECT_FALSE(b.mapped());
#if defined(__linux__)
        EXPECT_TRUE(a.mapped());
        EXPECT_EQ(residentPages(a.data(), a.bytes()), 0u) << "a fresh mapping has no page before the zeroer runs";
        const std::size_t anonymous = anonymousBytes();
#endif
        z.run(threads);
#if defined(__linux__)
        // Every page in at set-up, and the process's own (checked before
        // anything reads them: a read of a 4 KiB page maps the shared zero
        // page, and the first write would then fault on a realtime path).
        const std::size_t pages = (a.bytes() + pageBytes() - 1) / pageBytes();
        EXPECT_EQ(residentPages(a.data(), a.bytes()), pages) << threads << " threads";
        if (anonymous != 0) {
            EXPECT_GE(anonymousBytes(), anonymous + a.bytes() / 8 * 7) << threads << " threads";
        }
#endif
        EXPECT_EQ(std::count(a.data(), a.data() + a.size(), 0u), static_cast<std::ptrdiff_t>(a.size()));
        EXPECT_EQ(std::count(b.data(), b.data() + b.size(), 0u), static_cast<std::ptrdiff_t>(b.size()));
#if defined(__linux__)
        // A buffer reset is a fresh mapping again: zero whatever the old one held.
        std::fill_n(a.data(), a.size(), 9u);
        a.reset(a.size(), threads);
        EXPECT_EQ(residentPages(a.data(), a.bytes()), pages);
        EXPECT_EQ(std::count(a.data(), a.data() + a.size(), 0u), static_cast<std::ptrdiff_t>(a.size()));
        rost::AlignedBuffer<uint32_t> moved(std::move(a));
        EXPECT_TRUE(moved.mapped());
        EXPECT_FALSE(a.mapped());  // NOLINT(bugprone-use-after-move): a moved-from buffer is empty
#endif
    }
}

// The Eigen adaptor (rost/model_eigen.hpp; model.hpp has no Eigen): each
// topic's distribution over words, smoothed by beta, from the counts.
TEST(ModelEigen, TopicModelMatrixIsTheSmoothedCountsAndEachRowSumsToOne) {
    const rost::Config c = smallConfig();
    rost::Model m(c);
    rost::Rng r(3);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    for (int f = 0; f < 5; ++f) {
        randomFrame(r, c, 30, w, p);
        ASSERT_TRUE(m.addObservation(w, p).ok());
    }
    const Eigen::MatrixXd phi = rost::topicModelMatrix(m);
    ASSERT_EQ(phi.rows(), c.K);
    ASSERT_EQ(phi.cols(), c.V);
    for (int k = 0; k < c.K; ++k) {
        EXPECT_NEAR(phi.row(k).sum(), 1.0, 1e-12) << k;
        for (int v = 0; v < c.V; ++v)
            EXPECT_DOUBLE_EQ(phi(k, v), (m.topicWordCount(k, v) + c.beta) / (m.topicCount(k) + c.V * c.beta));
    }
}

namespace {

// A model of a few observations whose state is then edited through its
// state sections, as a checkpoint file would write them back.
struct RestoredModel {
    rost::Config c = smallConfig();
    rost::Model m{c};
    rost::StateLayout layout;
    RestoredModel() {
        rost::Rng r(5);
        std::vector<uint32_t> w;
        std::vector<rost::Position> p;
        for (int f = 0; f < 11; ++f) {  // 11 steps in a ring of 8: slots wrap
            randomFrame(r, c, 30, w, p);
            EXPECT_TRUE(m.addObservation(w, p).ok());
            m.refineStep(m.steps() - 1);
        }
        m.describeState(layout);
    }
    template <typename T>
    T* section(std::string_view name) {
        const rost::StateSection* s = layout.find(name);
        EXPECT_NE(s, nullptr) << name;
        return static_cast<T*>(s->data);
    }
    // The first word slot of a cell that holds a word in the newest step's slot.
    std::size_t firstWord() {
        const std::size_t slot = static_cast<std::size_t>((m.steps() - 1) % c.ring_steps);
        const auto* n = section<uint32_t>("ring.cell_n");
        for (std::size_t cell = 0; cell < static_cast<std::size_t>(m.cellsPerStep()); ++cell)
            if (n[slot * m.cellsPerStep() + cell] > 0) return (slot * m.cellsPerStep() + cell) * c.cell_capacity;
        ADD_FAILURE() << "no word in the newest step";
        return 0;
    }
};

} // namespace

// The store judges state written back from an untrusted checkpoint itself:
// a value it would index with is refused by section and element before
// anything reads it, and an untouched state passes.
TEST(ModelRestoredState, RefusesEachOutOfRangeValueBySectionAndElement) {
    {
        RestoredModel r;
        rost::StateProblem p;
        EXPECT_TRUE(r.m.checkRestoredState(p)) << p.section << ": " << p.what;
    }
    {
        RestoredModel r;
        const std::size_t at = r.firstWord();
        r.section<uint16_t>("ring.cell_z")[at] = static_cast<uint16_t>(r.c.K);
        rost::StateProblem p;
        EXPECT_FALSE(r.m.checkRestoredState(p));
        EXPECT_EQ(p.section, "ring.cell_z");
        EXPECT_EQ(p.element, at);
        EXPECT_NE(p.what.find("topic label 6 out of range [0, 6)"), std::string::npos) << p.what;
    }
    {
        RestoredModel r;
        const std::size_t at = r.firstWord();
        r.section<uint32_t>("ring.cell_words")[at] = 50;
        rost::StateProblem p;
        EXPECT_FALSE(r.m.checkRestoredState(p));
        EXPECT_EQ(p.section, "ring.cell_words");
        EXPECT_NE(p.what.find("word id 50 out of range [0, 50)"), std::string::npos) << p.what;
    }
    {
        RestoredModel r;
        r.section<int64_t>("counters.steps")[0] += 1;
        rost::StateProblem p;
        EXPECT_FALSE(r.m.checkRestoredState(p));
        EXPECT_EQ(p.section, "counters.steps");
        EXPECT_NE(p.what.find("does not follow from 11 observations"), std::string::npos) << p.what;
    }
    {
        RestoredModel r;
        r.section<int64_t>("ring.slot_step")[0] = 3;  // slot 0 holds step 8 of 11 steps in a ring of 8
        rost::StateProblem p;
        EXPECT_FALSE(r.m.checkRestoredState(p));
        EXPECT_EQ(p.section, "ring.slot_step");
        EXPECT_EQ(p.element, 0u);
        EXPECT_NE(p.what.find("holds step 3, expected 8"), std::string::npos) << p.what;
    }
    {
        RestoredModel r;
        r.section<float>("ring.obs_surprise")[2] = -1.f;
        rost::StateProblem p;
        EXPECT_FALSE(r.m.checkRestoredState(p));
        EXPECT_EQ(p.section, "ring.obs_surprise");
        EXPECT_EQ(p.element, 2u);
    }
}
