// Recovery of planted structure by batch Gibbs (paper Algorithm 1) on data
// drawn from the paper's generative process (tests/synthetic.hpp), and the
// value of the spatiotemporal neighbourhood on noisy data.
//
// Gibbs sampling from uniformly random labels sometimes settles in a local
// optimum (two planted topics merged into one learned topic, another split in
// two; a few percent of runs here). As in the paper's experiments, a fit is
// the best of a few random restarts, chosen by the model's own mean per-step
// perplexity, never by the planted labels.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "rost/model.hpp"
#include "synthetic.hpp"

namespace {

namespace syn = rost::synthetic;

struct Fit {
    double perplexity = std::numeric_limits<double>::infinity();  // mean over steps of Model::stepPerplexity
    std::vector<uint16_t> labels;  // ML labels (observationLabels), all steps in input order
};

std::vector<uint16_t> planted(const syn::Data& d) {
    std::vector<uint16_t> z;
    for (const auto& step : d.topics) z.insert(z.end(), step.begin(), step.end());
    return z;
}

// Batch Gibbs over every cell of every step (refineAll), `sweeps` passes.
Fit batchGibbs(const syn::Data& d, int radius, uint64_t seed, int sweeps) {
    rost::Config c = d.config();
    c.g_space = radius;
    c.g_time = radius;
    c.seed = seed;
    rost::Model m(c);
    for (int t = 0; t < d.spec.steps; ++t) {
        const rost::AddResult res = m.addObservation(d.words[t], d.positions[t]);
        EXPECT_TRUE(res.ok() && res.kept == d.words[t].size()) << "step " << t << " not stored whole";
    }
    m.refineAll(sweeps);
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;
    Fit f;
    f.perplexity = 0.0;
    for (int t = 0; t < d.spec.steps; ++t) {
        f.perplexity += m.stepPerplexity(t);
        std::vector<uint16_t> z(d.words[t].size());
        m.observationLabels(static_cast<uint64_t>(t), z);
        f.labels.insert(f.labels.end(), z.begin(), z.end());
    }
    f.perplexity /= d.spec.steps;
    return f;
}

Fit bestOfRestarts(const syn::Data& d, int radius, uint64_t seed, int restarts, int sweeps) {
    Fit best;
    for (int r = 0; r < restarts; ++r) {
        Fit f = batchGibbs(d, radius, seed * 100 + static_cast<uint64_t>(r), sweeps);
        if (f.perplexity < best.perplexity) best = std::move(f);
    }
    return best;
}

// ---- recovery -----------------------------------------------------------------------

// K = 5 topics (16 words of their own each, 5 % of their mass on 8 shared
// noise words), laid out as five vertical stripes 12 cells wide that drift
// 0.2 cells per step, on a 60 x 12 grid of 16 px cells, 12 steps, 8-12 words
// per cell (~86 k words); 2 % of words take a uniformly random topic.
// Stripes keep the fraction of cells whose radius-1 neighbourhood straddles a
// region boundary small: against a truth with hard boundaries, smoothing over
// G(c) costs perplexity at every such cell (with 12 x 12-cell blobs the
// radius-1 model's floor is ~7 % above the true perplexity; here it is ~3 %).
syn::Spec recoverySpec(uint64_t seed) {
    syn::Spec s;
    s.K = 5;
    s.words_per_topic = 16;
    s.noise_words = 8;
    s.noise_mass = 0.05;
    s.topic_noise = 0.02;
    s.layout = syn::Layout::Stripes;
    s.regions = 5;
    s.speed = 0.2;
    s.grid_width = 60;
    s.grid_height = 12;
    s.cell_space = 16;
    s.steps = 12;
    s.min_words = 8;
    s.max_words = 12;
    s.seed = seed;
    return s;
}

struct RecoveryResult {
    double nmi, ari, perplexity, truePerplexity;
};

// Paper defaults (alpha 0.1, beta 0.5, radius 1 in space and time), best of
// 4 restarts of 50 sweeps.
RecoveryResult recover(uint64_t seed) {
    const syn::Data d = syn::generate(recoverySpec(seed));
    const Fit f = bestOfRestarts(d, 1, seed, 4, 50);
    const std::vector<uint16_t> z = planted(d);
    return {syn::nmi(z, f.labels, d.spec.K, d.spec.K), syn::adjustedRand(z, f.labels, d.spec.K, d.spec.K),
            f.perplexity, syn::trueMeanPerplexity(d)};
}

// Batch Gibbs recovers the planted labels (NMI and adjusted Rand >= 0.9 of the
// ML labels against the planted topics) and its mean per-step perplexity is
// within 5 % of the true model's on the same data.
//
// Perplexity, both sides with the definition of model.hpp: per step t,
// exp(-sum_i log p(w_i) / N_t), averaged over the 12 steps. Learned:
// p(w_i) = sum_k phi_k(w_i) theta_G(k) from the counts with word i left out
// (Model::stepPerplexity). True: the generating phi and the generating theta of
// the word's cell and step (synthetic::trueMeanPerplexity); nothing is
// estimated there, so no word is left out.
//
// False-failure rate (over data seeds; this seed is fixed): measured on data
// seeds 1-200, single runs hit a local optimum in 93 of 800 (12 %); the best
// of 4 restarts failed on none, with NMI in [0.960, 0.970], adjusted Rand
// >= 0.977 and perplexity ratio in [1.032, 1.039]. With independent restarts
// all four get stuck with probability ~0.12^4 = 2e-4.
TEST(BatchGibbsRecovery, RecoversPlantedLabelsAndTrueModelPerplexity) {
    const RecoveryResult r = recover(2024);
    std::printf("[ recovery ] NMI %.4f, ARI %.4f, perplexity %.4f, true %.4f, ratio %.4f\n", r.nmi, r.ari, r.perplexity,
                r.truePerplexity, r.perplexity / r.truePerplexity);
    EXPECT_GE(r.nmi, 0.9);
    EXPECT_GE(r.ari, 0.9);
    EXPECT_LE(r.perplexity, 1.05 * r.truePerplexity);
    EXPECT_GE(r.perplexity, 0.95 * r.truePerplexity);
}

// ---- the neighbourhood matters --------------------------------------------------------

// Four topics as moving blobs (Voronoi regions of 4 centres drifting 0.2
// cells per step on a 24 x 24 torus of cells, ~144 cells each), only 2-4
// words per cell, and heavy word noise: half of each topic's mass on 8 shared
// noise words that say nothing about the topic; 5 % of words take a random
// topic. A cell alone (radius 0: LDA with 3-word documents) has too few words
// to tell its topic; its radius-1 neighbourhood has ~21.
syn::Spec noisySpec(uint64_t seed) {
    syn::Spec s;
    s.K = 4;
    s.words_per_topic = 16;
    s.noise_words = 8;
    s.noise_mass = 0.5;
    s.topic_noise = 0.05;
    s.layout = syn::Layout::Blobs;
    s.regions = 4;
    s.speed = 0.2;
    s.grid_width = 24;
    s.grid_height = 24;
    s.cell_space = 16;
    s.steps = 10;
    s.min_words = 2;
    s.max_words = 4;
    s.seed = seed;
    return s;
}

struct Comparison {
    std::vector<double> acc0, acc1, diff;  // per data seed
    double median = 0.0, mad = 0.0;        // of diff
};

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Fraction of words whose ML label equals the planted topic after the best
// one-to-one matching of learned to planted topics, radius 0 against radius 1,
// on `seeds` data sets; each fit the best of 2 restarts of 50 sweeps.
Comparison compareRadii(uint64_t firstSeed, int seeds) {
    Comparison c;
    for (int i = 0; i < seeds; ++i) {
        const uint64_t seed = firstSeed + static_cast<uint64_t>(i);
        const syn::Data d = syn::generate(noisySpec(seed));
        const std::vector<uint16_t> z = planted(d);
        c.acc0.push_back(syn::bestMatchAccuracy(z, bestOfRestarts(d, 0, seed, 2, 50).labels, d.spec.K));
        c.acc1.push_back(syn::bestMatchAccuracy(z, bestOfRestarts(d, 1, seed, 2, 50).labels, d.spec.K));
        c.diff.push_back(c.acc1.back() - c.acc0.back());
    }
    c.median = median(c.diff);
    std::vector<double> dev;
    for (double x : c.diff) dev.push_back(std::fabs(x - c.median));
    c.mad = median(dev);
    return c;
}

// Radius 1 (g.space = g.time = 1) labels more words correctly than radius 0,
// over 7 data seeds. The margin is the median over seeds of the paired
// difference in accuracy; seed noise is its robust spread, 1.4826 * MAD (the
// median absolute deviation scaled to a standard deviation). Medians, because
// a stuck chain makes the differences heavy-tailed. Asserted: median >= 5
// points, and median >= 3 robust standard errors (1.4826 MAD / sqrt 7).
// Observed here: radius 1 ~96.5 %, radius 0 ~84 %, median gain 0.12, robust
// standard error 0.006 (a margin of ~20 standard errors).
//
// False-failure rate: on data seeds 1-100 (one seed each) the gain was below
// 0.05 on 2 seeds (radius 1 stuck even with restarts) and far above the
// median on 12 (radius 0 stuck). Resampling 7 of those 100 gains 200 000
// times, these two checks failed in 6e-4 of the draws.
TEST(NeighbourhoodMatters, RadiusOneLabelsMoreWordsCorrectlyThanRadiusZeroOnNoisyData) {
    const int seeds = 7;
    const Comparison c = compareRadii(700, seeds);
    for (int i = 0; i < seeds; ++i)
        std::printf("[ radius   ] seed %d: accuracy radius 0 %.4f, radius 1 %.4f\n", 700 + i, c.acc0[i], c.acc1[i]);
    const double se = 1.4826 * c.mad / std::sqrt(static_cast<double>(seeds));
    std::printf("[ radius   ] median gain %.4f, robust standard error %.4f\n", c.median, se);
    EXPECT_GE(c.median, 0.05);
    EXPECT_GE(c.median, 3.0 * se);
}

// ---- the generator and the metrics themselves --------------------------------------------

TEST(SyntheticData, SameSeedSameDataAndPlantedTopicsFollowTheta) {
    const syn::Spec s = noisySpec(5);
    const syn::Data a = syn::generate(s), b = syn::generate(s);
    ASSERT_EQ(a.words, b.words);
    ASSERT_EQ(a.topics, b.topics);
    // Words per cell in range, positions inside their cell's frame.
    for (int t = 0; t < s.steps; ++t) {
        std::vector<int> perCell(static_cast<std::size_t>(s.cells()), 0);
        for (const rost::Position& p : a.positions[t]) ++perCell[static_cast<std::size_t>(a.cellOf(p))];
        for (int n : perCell) {
            ASSERT_GE(n, s.min_words);
            ASSERT_LE(n, s.max_words);
        }
    }
    // Phi rows are distributions.
    for (int k = 0; k < s.K; ++k) EXPECT_NEAR(a.phi.row(k).sum(), 1.0, 1e-12);
    // Share of words whose planted topic is their region's: 1 - tn + tn / K.
    // Binomial with n ~ 17 k: 5 standard deviations (false failure ~6e-7).
    double agree = 0.0, n = 0.0;
    for (int t = 0; t < s.steps; ++t)
        for (std::size_t i = 0; i < a.words[t].size(); ++i) {
            agree += a.topics[t][i] == a.regionOf(t, a.cellOf(a.positions[t][i]));
            n += 1.0;
        }
    const double p = 1.0 - s.topic_noise + s.topic_noise / s.K;
    EXPECT_NEAR(agree / n, p, 5.0 * std::sqrt(p * (1.0 - p) / n));
    // The layout moves: some cell changes region between the first and last step.
    int moved = 0;
    for (int c = 0; c < s.cells(); ++c) moved += a.regionOf(0, c) != a.regionOf(s.steps - 1, c);
    EXPECT_GT(moved, 0);
}

TEST(SyntheticData, AgreementMetricsOnKnownPartitions) {
    const std::vector<uint16_t> a{0, 0, 0, 1, 1, 1, 2, 2, 2, 2};
    const std::vector<uint16_t> relabelled{2, 2, 2, 0, 0, 0, 1, 1, 1, 1};
    EXPECT_NEAR(syn::nmi(a, relabelled, 3, 3), 1.0, 1e-12);
    EXPECT_NEAR(syn::adjustedRand(a, relabelled, 3, 3), 1.0, 1e-12);
    EXPECT_NEAR(syn::bestMatchAccuracy(a, relabelled, 3), 1.0, 1e-12);
    const std::vector<uint16_t> oneOff{2, 2, 2, 0, 0, 1, 1, 1, 1, 1};
    EXPECT_NEAR(syn::bestMatchAccuracy(a, oneOff, 3), 0.9, 1e-12);
    EXPECT_LT(syn::nmi(a, oneOff, 3, 3), 1.0);
    // Independent labelings score ~0 (large random sample).
    rost::Rng r(3);
    std::vector<uint16_t> x(20000), y(20000);
    for (std::size_t i = 0; i < x.size(); ++i) {
        x[i] = static_cast<uint16_t>(r.below(4));
        y[i] = static_cast<uint16_t>(r.below(4));
    }
    EXPECT_LT(syn::nmi(x, y, 4, 4), 0.01);
    EXPECT_NEAR(syn::adjustedRand(x, y, 4, 4), 0.0, 0.01);
}

} // namespace
