// The sampler draws from the exact conditional of paper eq. 5.
//
// Method. All cells but one are frozen (never refined again), and only the
// target cell is refined, many times. Refining a cell resamples its words in
// order, each from eq. 5 given every other label, so the sequence of target
// labels is a Markov chain whose one-sweep transition law is known in closed
// form: with n words, word j is drawn given the new labels of words < j and
// the old labels of words > j. For a cell with ONE word the law does not
// depend on the old label at all (the word leaves its own topic only), so the
// draws are iid from one distribution. For two words the transition depends
// only on the second word's old label (the "row").
//
// The expected law is computed here in double, from an independent recount:
// the labels, words and positions the model reports (observationSamples /
// observationWords / observationPositions), the cell of each word recomputed
// from its position, and the neighbourhood G(c) written out from its
// definition (the cell, its spatial neighbours within Manhattan distance
// g.space at the same step, and the same cell at steps t +- 1..g.time inside
// the window). Pearson's chi-square over the transition counts, row by row
// (Anderson & Goodman 1957: given the row visits, the counts are multinomial
// by the Markov property), gives a p-value.
//
// False-failure rate: every "matches" check passes when p > 1e-4, so it fails
// a correct sampler with probability 1e-4 (asymptotically; bins expected below
// 5 are pooled). There are 15 such checks in this file: < 2e-3 for the file.
// Every "rejected" check requires p < 1e-6 and first asserts that the wrong
// law is far enough from the right one (noncentrality n sum (p - q)^2 / q of
// at least 200 at 4 df, 1000 at ~100 df) that a correct sampler fails to
// reject it with probability < 1e-9. Seeds are fixed, so a run is reproducible.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <ostream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "counter_rng.hpp"
#include "kernel.hpp"
#include "kernel_fixed.hpp"
#include "kernel_frozen.hpp"
#include "rost/model.hpp"

namespace {

using rost::kernel::Path;

constexpr int kCellSpace = 16;
constexpr int kDraws = 200000;
constexpr double kPass = 1e-4;    // a correct sampler fails a "matches" check with this probability
constexpr double kReject = 1e-6;  // a wrong law must be rejected at least this strongly

// ---- chi-square ------------------------------------------------------------

// Regularised upper incomplete gamma Q(a, x): series for x < a + 1, Lentz's
// continued fraction otherwise.
double gammaQ(double a, double x) {
    if (x <= 0.0) return 1.0;
    const double logPrefix = -x + a * std::log(x) - std::lgamma(a);
    if (x < a + 1.0) {
        double term = 1.0 / a, sum = term, ap = a;
        for (int n = 0; n < 100000 && std::fabs(term) > std::fabs(sum) * 1e-16; ++n) {
            ap += 1.0;
            term *= x / ap;
            sum += term;
        }
        return std::max(0.0, 1.0 - sum * std::exp(logPrefix));
    }
    constexpr double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; ++i) {
        const double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (std::fabs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::fabs(c) < tiny) c = tiny;
        d = 1.0 / d;
        const double delta = d * c;
        h *= delta;
        if (std::fabs(delta - 1.0) < 1e-16) break;
    }
    return std::exp(logPrefix) * h;
}

// P(chi-square with df degrees of freedom > x).
double chi2Survival(double x, int df) { return gammaQ(0.5 * df, 0.5 * x); }

struct GoodnessOfFit {
    double stat = 0.0;
    int df = 0;
    [[nodiscard]] double p() const { return df > 0 ? chi2Survival(stat, df) : 1.0; }
};

std::ostream& operator<<(std::ostream& os, const GoodnessOfFit& g) {
    return os << "chi2 = " << g.stat << " on " << g.df << " df, p = " << g.p();
}

// One line per check in the test log, so a reader sees how far from the bar each run is.
void report(const std::string& what, const GoodnessOfFit& g) {
    std::printf("[ stats    ] %s: %s\n", what.c_str(), (std::ostringstream() << g).str().c_str());
}

// Adds one multinomial row: observed counts against probabilities (summing to
// 1). Bins expected below 5 are pooled (into the smallest regular bin if the
// pool itself is still below 5), the usual condition for the chi-square limit.
void addRow(GoodnessOfFit& g, const std::vector<double>& observed, const std::vector<double>& prob) {
    double n = 0.0;
    for (double o : observed) n += o;
    if (n == 0.0) return;
    struct Bin {
        double o, e;
    };
    std::vector<Bin> bins;
    Bin pool{0.0, 0.0};
    for (std::size_t i = 0; i < observed.size(); ++i) {
        const double e = n * prob[i];
        if (e >= 5.0) bins.push_back({observed[i], e});
        else {
            pool.o += observed[i];
            pool.e += e;
        }
    }
    if (pool.e >= 5.0 || bins.empty()) bins.push_back(pool);
    else if (pool.e > 0.0 || pool.o > 0.0) {
        auto smallest = std::min_element(bins.begin(), bins.end(), [](const Bin& a, const Bin& b) { return a.e < b.e; });
        smallest->o += pool.o;
        smallest->e += pool.e;
    }
    for (const Bin& b : bins) g.stat += b.e > 0.0 ? (b.o - b.e) * (b.o - b.e) / b.e : (b.o > 0 ? std::numeric_limits<double>::infinity() : 0.0);
    g.df += static_cast<int>(bins.size()) - 1;
}

// ---- a tiny scene and its independent recount -------------------------------------

struct SceneSpec {
    const char* name;
    int K, V;
    int gridW, gridH;      // cells
    int steps, ring;       // observations added, ring size (steps > ring evicts the oldest)
    int gSpace, gTime;
    int targetStepFromEnd; // target step = steps - 1 - this
    int targetCell;
    int targetWords;       // words in the target cell (1 or 2), all of type targetWord
    uint32_t targetWord;
    int minWords, maxWords;  // words in every other cell
    int warmupSweeps;      // batch sweeps before freezing (0: uniformly random labels)
    uint64_t seed;
};

// gtest names failing parameters with this.
void PrintTo(const SceneSpec& s, std::ostream* os) { *os << s.name; }

// One stored word as the model reports it.
struct Token {
    int64_t step;
    int cx, cy;
    uint32_t word;
    int z;
};

struct Scene {
    SceneSpec spec;
    rost::Config config;
    int64_t targetStep = 0;
    std::vector<std::size_t> target;  // indices into tokens of the target cell's words, in input order
    std::vector<uint32_t> targetInput;  // their indices in the target observation's input
    std::vector<Token> tokens;
};

rost::Config configOf(const SceneSpec& s) {
    rost::Config c;
    c.K = s.K;
    c.V = s.V;
    c.cell_space = kCellSpace;
    c.frame_width = s.gridW * kCellSpace;
    c.frame_height = s.gridH * kCellSpace;
    c.g_space = s.gSpace;
    c.g_time = s.gTime;
    c.ring_steps = s.ring;
    // Evicted steps leave n_k^v too, so the recount over the window is the whole model.
    c.eviction = rost::EvictionPolicy::Subtract;
    c.cell_capacity = std::max(s.maxWords, s.targetWords);
    c.max_words_per_frame = c.cell_capacity * s.gridW * s.gridH;
    c.seed = s.seed;
    return c;
}

// Adds the scene's observations to the model. Every cell gets a few words
// whose types depend on the cell and step (so topics form during warm-up);
// the target cell gets exactly `targetWords` copies of `targetWord`.
void fill(rost::Model& m, const SceneSpec& s) {
    rost::Rng r(s.seed ^ 0xC0FFEEull);
    const int64_t targetStep = s.steps - 1 - s.targetStepFromEnd;
    for (int t = 0; t < s.steps; ++t) {
        std::vector<uint32_t> w;
        std::vector<rost::Position> p;
        for (int c = 0; c < s.gridW * s.gridH; ++c) {
            const bool isTarget = t == targetStep && c == s.targetCell;
            const int n = isTarget ? s.targetWords
                                   : s.minWords + static_cast<int>(r.below(static_cast<uint32_t>(s.maxWords - s.minWords + 1)));
            for (int i = 0; i < n; ++i) {
                w.push_back(isTarget ? s.targetWord
                                     : (static_cast<uint32_t>(c + 2 * t) + r.below(3)) % static_cast<uint32_t>(s.V));
                p.push_back({(c % s.gridW) * kCellSpace + static_cast<int>(r.below(kCellSpace)),
                             (c / s.gridW) * kCellSpace + static_cast<int>(r.below(kCellSpace))});
            }
        }
        const rost::AddResult res = m.addObservation(w, p);
        ASSERT_TRUE(res.ok());
        ASSERT_EQ(res.dropped_cell + res.dropped_frame, 0u) << "the scene must fit without subsampling";
    }
}

// Every stored word of the window, from the model's public outputs only.
std::vector<Token> recount(const rost::Model& m, const rost::Config& c) {
    std::vector<Token> out;
    for (uint64_t f = 0; f < m.observations(); ++f) {
        if (!m.observationInWindow(f)) continue;
        const uint32_t n = m.observationSize(f);
        std::vector<uint32_t> w(n);
        std::vector<rost::Position> p(n);
        std::vector<uint16_t> z(n);
        m.observationWords(f, w);
        m.observationPositions(f, p);
        m.observationSamples(f, z);
        for (uint32_t i = 0; i < n; ++i)
            out.push_back({static_cast<int64_t>(f) / c.cell_time, p[i].x / c.cell_space, p[i].y / c.cell_space, w[i], z[i]});
    }
    return out;
}

Scene makeScene(rost::Model& m, const SceneSpec& s) {
    Scene sc;
    sc.spec = s;
    sc.config = m.config();
    fill(m, s);
    m.refineAll(s.warmupSweeps);
    sc.targetStep = s.steps - 1 - s.targetStepFromEnd;
    sc.tokens = recount(m, sc.config);
    const int tcx = s.targetCell % s.gridW, tcy = s.targetCell / s.gridW;
    uint32_t inputIndex = 0;
    for (std::size_t i = 0; i < sc.tokens.size(); ++i) {
        const Token& t = sc.tokens[i];
        if (t.step != sc.targetStep) continue;
        if (t.cx == tcx && t.cy == tcy) {
            sc.target.push_back(i);
            sc.targetInput.push_back(inputIndex);
        }
        ++inputIndex;
    }
    return sc;
}

// ---- closed forms ------------------------------------------------------------------

// Paper eq. 5 for token i given every other token's label, normalised over k:
//   P(z_i = k) ∝ (n_{k,-i}^v + beta) / (n_{k,-i} + V beta) * (n_{G_i,-i}^k + alpha).
std::vector<double> eq5(const std::vector<Token>& tokens, std::size_t i, const rost::Config& c) {
    const Token& me = tokens[i];
    std::vector<double> nkv(c.K, 0.0), nk(c.K, 0.0), nG(c.K, 0.0);
    for (std::size_t j = 0; j < tokens.size(); ++j) {
        if (j == i) continue;
        const Token& o = tokens[j];
        nk[o.z] += 1;
        if (o.word == me.word) nkv[o.z] += 1;
        const bool spatial = o.step == me.step && std::abs(o.cx - me.cx) + std::abs(o.cy - me.cy) <= c.g_space;
        const int64_t dt = std::abs(o.step - me.step);
        const bool temporal = o.cx == me.cx && o.cy == me.cy && dt >= 1 && dt <= c.g_time;
        if (spatial || temporal) nG[o.z] += 1;
    }
    std::vector<double> p(c.K);
    double sum = 0.0;
    for (int k = 0; k < c.K; ++k) {
        p[k] = (nkv[k] + c.beta) / (nk[k] + c.V * c.beta) * (nG[k] + c.alpha);
        sum += p[k];
    }
    for (double& x : p) x /= sum;
    return p;
}

// Collapsed Gibbs for LDA, Griffiths & Steyvers (2004, eq. 5 there), written
// from that paper over a corpus of documents, one per (step, cell):
//   P(z_i = j | z_-i, w) ∝ (n_{-i,j}^(w_i) + beta) / (n_{-i,j}^(.) + W beta)
//                        * (n_{-i,j}^(d_i) + alpha) / (n_{-i,.}^(d_i) + T alpha).
std::vector<double> griffithsSteyvers(const std::vector<Token>& tokens, std::size_t i, const rost::Config& c) {
    using Doc = std::tuple<int64_t, int, int>;
    std::map<Doc, std::vector<std::size_t>> docs;
    for (std::size_t j = 0; j < tokens.size(); ++j) docs[{tokens[j].step, tokens[j].cx, tokens[j].cy}].push_back(j);
    const int T = c.K, W = c.V;
    const Doc di{tokens[i].step, tokens[i].cx, tokens[i].cy};
    std::vector<double> p(T);
    for (int j = 0; j < T; ++j) {
        double wordInTopic = 0, inTopic = 0, docInTopic = 0, docLen = 0;
        for (const auto& [d, members] : docs)
            for (std::size_t m : members) {
                if (m == i) continue;
                const bool isJ = tokens[m].z == j;
                inTopic += isJ;
                wordInTopic += isJ && tokens[m].word == tokens[i].word;
                if (d == di) {
                    docLen += 1;
                    docInTopic += isJ;
                }
            }
        p[j] = (wordInTopic + c.beta) / (inTopic + W * c.beta) * (docInTopic + c.alpha) / (docLen + T * c.alpha);
    }
    double sum = 0.0;
    for (double x : p) sum += x;
    for (double& x : p) x /= sum;
    return p;
}

using Conditional = std::function<std::vector<double>(const std::vector<Token>&, std::size_t, const rost::Config&)>;

// ---- the chain -----------------------------------------------------------------------

// Transition counts of the target cell under repeated refinement:
// counts[row][outcome], row = old labels of target words 2..n (base K),
// outcome = new labels of words 1..n (base K, word 1 most significant).
struct Chain {
    int K = 0, n = 0;
    std::vector<std::vector<double>> counts;
};

Chain runChain(rost::Model& m, const Scene& sc, Path path, int draws) {
    m.setKernelPath(path);
    Chain ch;
    ch.K = sc.config.K;
    ch.n = static_cast<int>(sc.target.size());
    int rows = 1, outcomes = 1;
    for (int j = 1; j < ch.n; ++j) rows *= ch.K;
    for (int j = 0; j < ch.n; ++j) outcomes *= ch.K;
    ch.counts.assign(static_cast<std::size_t>(rows), std::vector<double>(static_cast<std::size_t>(outcomes), 0.0));
    const auto frame = static_cast<uint64_t>(sc.targetStep * sc.config.cell_time);
    std::vector<uint16_t> z(m.observationSize(frame));
    m.observationSamples(frame, z);
    for (int d = 0; d < draws; ++d) {
        int row = 0;
        for (int j = 1; j < ch.n; ++j) row = row * ch.K + z[sc.targetInput[j]];
        m.refineCell(sc.targetStep, sc.spec.targetCell);
        m.observationSamples(frame, z);
        int out = 0;
        for (int j = 0; j < ch.n; ++j) out = out * ch.K + z[sc.targetInput[j]];
        ch.counts[row][out] += 1;
    }
    return ch;
}

// Closed-form transition law of one sweep over the target cell under `cond`:
// word j drawn given the new labels of words < j and the old ones of words > j.
std::vector<std::vector<double>> transitionLaw(const Scene& sc, const Conditional& cond) {
    const int K = sc.config.K, n = static_cast<int>(sc.target.size());
    int rows = 1, outcomes = 1;
    for (int j = 1; j < n; ++j) rows *= K;
    for (int j = 0; j < n; ++j) outcomes *= K;
    std::vector<std::vector<double>> law(static_cast<std::size_t>(rows), std::vector<double>(static_cast<std::size_t>(outcomes)));
    std::vector<Token> tokens = sc.tokens;
    for (int row = 0; row < rows; ++row)
        for (int out = 0; out < outcomes; ++out) {
            std::vector<int> oldZ(n, 0), newZ(n);
            for (int j = n - 1, r = row; j >= 1; --j, r /= K) oldZ[j] = r % K;
            for (int j = n - 1, o = out; j >= 0; --j, o /= K) newZ[j] = o % K;
            double p = 1.0;
            for (int j = 0; j < n; ++j) {
                for (int m = 0; m < n; ++m) tokens[sc.target[m]].z = m < j ? newZ[m] : oldZ[m];
                p *= cond(tokens, sc.target[j], sc.config)[newZ[j]];
            }
            law[row][out] = p;
        }
    return law;
}

GoodnessOfFit fit(const Chain& ch, const std::vector<std::vector<double>>& law) {
    GoodnessOfFit g;
    for (std::size_t r = 0; r < law.size(); ++r) addRow(g, ch.counts[r], law[r]);
    return g;
}

// The law the draws must NOT follow has to be far from the right one, or the
// rejection would prove nothing: noncentrality n * sum (p - q)^2 / q.
double noncentrality(const std::vector<std::vector<double>>& right, const std::vector<std::vector<double>>& wrong,
                     const Chain& ch) {
    double lambda = 0.0;
    for (std::size_t r = 0; r < right.size(); ++r) {
        double n = 0.0;
        for (double o : ch.counts[r]) n += o;
        for (std::size_t k = 0; k < right[r].size(); ++k) {
            const double d = right[r][k] - wrong[r][k];
            lambda += n * d * d / wrong[r][k];
        }
    }
    return lambda;
}

// ---- sanity of the statistics themselves ----------------------------------------------

TEST(SamplerStatistics, ChiSquareTailMatchesTables) {
    EXPECT_NEAR(chi2Survival(3.841459, 1), 0.05, 1e-6);
    EXPECT_NEAR(chi2Survival(18.46683, 4), 1e-3, 1e-7);
    EXPECT_NEAR(chi2Survival(124.3421, 100), 0.05, 1e-6);
    EXPECT_NEAR(chi2Survival(2.0, 2), std::exp(-1.0), 1e-12);
    EXPECT_NEAR(chi2Survival(0.5, 4), 0.9735009788, 1e-9);
}

// ---- a round of a parallel window: the frozen kernel's conditional -------------------

// During a round n_k^v and n_k are frozen with every word at its label when
// the round began (a), while its own cell's counts hold its current label
// (c). Its draws must follow eq. 5 with the word left out of n_k^v and n_k at
// a and out of n_G^k at c; the frozen tables must not change. Both paths.
void frozenCase(const int K) {
    const int Kp = rost::kernel::paddedK(K), V = 3;
    const float alpha = 0.1f, beta = 0.5f;
    rost::Rng r(77);
    std::vector<int32_t> nkv(V * Kp, 0), nk(Kp, 0);
    for (int v = 0; v < V; ++v)
        for (int k = 0; k < K; ++k) nkv[v * Kp + k] = static_cast<int32_t>(r.below(12));
    const uint32_t word = 1;
    const int a = 2, c = K - 2;
    nkv[word * Kp + a] += 1;  // the word itself, at its round-start label
    for (int k = 0; k < K; ++k) nk[k] = nkv[k] + nkv[Kp + k] + nkv[2 * Kp + k] + static_cast<int32_t>(r.below(30));
    std::vector<float> inv(Kp), dec(Kp), inc(Kp);
    rost::kernel::Tables t;
    t.nkv = nkv.data();
    t.nk = nk.data();
    t.inv = inv.data();
    t.dec = dec.data();
    t.inc = inc.data();
    t.K = K;
    t.Kp = Kp;
    t.active = K;
    t.alpha = alpha;
    t.beta = beta;
    t.vbeta = static_cast<float>(V) * beta;
    rost::kernel::refreshReciprocals(t);
    std::vector<int32_t> g0(Kp, 0), nc0(Kp, 0);
    for (int k = 0; k < K; ++k) g0[k] = static_cast<int32_t>(r.below(9));
    g0[c] += 1;
    nc0[c] = 1;
    std::vector<double> law(K);
    double total = 0;
    for (int k = 0; k < K; ++k) {
        const double l = k == a ? 1.0 : 0.0, m = k == c ? 1.0 : 0.0;
        law[k] = (nkv[word * Kp + k] - l + beta) / (nk[k] - l + V * static_cast<double>(beta)) * (g0[k] - m + alpha);
        total += law[k];
    }
    for (double& p : law) p /= total;
    const std::vector<int32_t> nkvBefore = nkv, nkBefore = nk;
    for (const Path path : {Path::Simd, Path::Scalar}) {
        std::vector<double> counts(K, 0.0);
        std::vector<int32_t> g(Kp), nc(Kp);
        for (int d = 0; d < kDraws; ++d) {
            std::copy(g0.begin(), g0.end(), g.begin());
            std::copy(nc0.begin(), nc0.end(), nc.begin());
            uint16_t z = static_cast<uint16_t>(c);
            const uint16_t z0 = a;
            rost::detail::CounterRng rng(12345, static_cast<uint64_t>(d));
            uint64_t move = 0;
            const uint32_t moved =
                path == Path::Simd
                    ? rost::kernel::refineCellFrozen<0, Path::Simd>(t, g.data(), &word, &z, &z0, 1, rng, &move)
                    : rost::kernel::refineCellFrozen<0, Path::Scalar>(t, g.data(), &word, &z, &z0, 1, rng, &move);
            ASSERT_EQ(moved, z != z0 ? 1u : 0u) << "a move listed when the word left its round-start label";
            if (moved) {
                ASSERT_EQ(move, word | uint64_t{z0} << 32 | uint64_t{z} << 48);
            }
            counts[z] += 1;
            ASSERT_EQ(g[z], g0[z] + (z == c ? 0 : 1)) << "the neighbourhood sums follow the new label";
            if (z != c) {
                ASSERT_EQ(g[c], g0[c] - 1) << "and leave the old one";
            }
            ASSERT_EQ(nc, nc0) << "the cell's own counts are the task's to set, from the sums";
        }
        GoodnessOfFit gof;
        for (int k = 0; k < K; ++k) {
            const double e = law[k] * kDraws;
            gof.stat += (counts[k] - e) * (counts[k] - e) / e;
        }
        gof.df = K - 1;
        EXPECT_GT(gof.p(), kPass) << "K " << K << (path == Path::Simd ? " simd: " : " scalar: ") << gof;
        EXPECT_TRUE(nkv == nkvBefore && nk == nkBefore) << "a round must not write the frozen tables";
    }
}

// K = 7: the scan order (2 blocks, one padding lane). K = 37: the lane
// order (10 blocks, three padding lanes).
TEST(FrozenConditional, DrawsFollowEq5WithTheRoundStartLabelLeftOutOnBothKernelPaths) {
    frozenCase(7);
    frozenCase(37);
}

// ---- topic growth: the conditional with a new topic -------------------------------------

// With topics.grow, a word draws an open topic k (n_k > 0 without it) with
// eq. 5's weight and a new topic with weight gamma / V; the new topic takes
// the lowest closed label, the slot (docs/design.md, "Topics that grow").
// One word in a cell, both kernel paths, live and frozen (a parallel round's):
// open topics 0..A-1 (A at a block boundary, inside a block, at the cap K = 7:
// no new topic), a closed topic among them (the slot is below the open ones),
// and a word that is its topic's only word (its topic closes while it draws:
// weight 0, and live, its label becomes the slot). The tables are restored
// between draws.
template <int KK>
struct GrowthSceneT {
    static constexpr int K = KK, Kp = rost::kernel::paddedK(KK), V = 5;
    const float alpha = 0.1f, beta = 0.5f, gamma = 0.8f;
    std::vector<int32_t> nkv, nk;
    std::vector<int32_t> g0, nc0;
    alignas(64) float inv[Kp], dec[Kp], inc[Kp];
    rost::kernel::Tables t;
    uint32_t word = 2;
    int z = 0;
    bool singleton = false;

    GrowthSceneT(int A, int hole, bool single) : nkv(V * Kp, 0), nk(Kp, 0), g0(Kp, 0), nc0(Kp, 0), singleton(single) {
        rost::Rng r(static_cast<uint64_t>(90 + A * 7 + hole + (single ? 50 : 0)));
        z = A - 1;
        for (int v = 0; v < V; ++v)
            for (int k = 0; k < A; ++k)
                if (k != hole && !(single && k == z)) nkv[v * Kp + k] = static_cast<int32_t>(1 + r.below(10));
        nkv[word * Kp + z] += 1;  // the word itself
        for (int k = 0; k < A; ++k) {
            for (int v = 0; v < V; ++v) nk[k] += nkv[v * Kp + k];
            if (nk[k] > 0) g0[k] = static_cast<int32_t>(r.below(6));
        }
        g0[z] += 1;
        nc0[z] = 1;
        t.nkv = nkv.data();
        t.nk = nk.data();
        t.inv = inv;
        t.dec = dec;
        t.inc = inc;
        t.K = K;
        t.Kp = Kp;
        t.grow = true;
        t.fresh = gamma / static_cast<float>(V);
        t.alpha = alpha;
        t.beta = beta;
        t.vbeta = static_cast<float>(V) * beta;
        rost::kernel::refreshReciprocals(t);
        rost::kernel::updateTopics(t);
    }
    // The label a new topic takes: the slot, which live includes the word's
    // own topic when it closes; frozen, the round's slot.
    int newLabel(bool frozen) const { return !frozen && singleton ? std::min(t.slot, z) : t.slot; }
    // The law of the word's new label.
    std::vector<double> law(bool frozen) const {
        std::vector<double> p(K, 0.0);
        double total = 0;
        for (int k = 0; k < K; ++k) {
            const double l = k == z ? 1.0 : 0.0;
            if (nk[k] - l <= 0) continue;  // closed without the word
            p[k] = (nkv[word * Kp + k] - l + beta) / (nk[k] - l + V * static_cast<double>(beta)) * (g0[k] - l + alpha);
            total += p[k];
        }
        const int n = newLabel(frozen);
        if (n < K) {
            p[n] += static_cast<double>(gamma) / V;
            total += static_cast<double>(gamma) / V;
        }
        for (double& x : p) x /= total;
        return p;
    }
};

// One draw of the word on kernel `variant` (0 live simd, 1 live scalar, 2 frozen simd, 3 frozen scalar).
template <int KK>
uint16_t growthDraw(GrowthSceneT<KK>& sc, int variant, int d, int32_t* nc) {
    using rost::kernel::kGrow;
    alignas(64) int32_t g[GrowthSceneT<KK>::Kp];
    std::copy(sc.g0.begin(), sc.g0.end(), g);
    std::copy(sc.nc0.begin(), sc.nc0.end(), nc);
    uint16_t z = static_cast<uint16_t>(sc.z);
    const uint16_t z0 = z;
    rost::detail::CounterRng rng(777, static_cast<uint64_t>(d));
    if (variant == 0) rost::kernel::refineCell<kGrow, Path::Simd>(sc.t, g, nc, &sc.word, &z, 1, rng);
    if (variant == 1) rost::kernel::refineCell<kGrow, Path::Scalar>(sc.t, g, nc, &sc.word, &z, 1, rng);
    uint64_t move = 0;
    if (variant == 2) rost::kernel::refineCellFrozen<kGrow, Path::Simd>(sc.t, g, &sc.word, &z, &z0, 1, rng, &move);
    if (variant == 3) rost::kernel::refineCellFrozen<kGrow, Path::Scalar>(sc.t, g, &sc.word, &z, &z0, 1, rng, &move);
    if (variant >= 2)  // the frozen kernels leave the cell's counts to the task, which sets them from the sums
        for (int k = 0; k < GrowthSceneT<KK>::Kp; ++k) nc[k] = sc.nc0[k] + g[k] - sc.g0[k];
    return z;
}

struct GrowthCase {
    int A, hole;
    bool single;
};

template <int KK>
void growthCases(std::initializer_list<GrowthCase> cases) {
    using GrowthScene = GrowthSceneT<KK>;
    for (const GrowthCase c : cases) {
        GrowthScene sc(c.A, c.hole, c.single);
        const GrowthScene ref(c.A, c.hole, c.single);
        for (int variant = 0; variant < 4; ++variant) {
            const bool frozen = variant >= 2;
            const std::vector<double> law = sc.law(frozen);
            const int fresh = sc.newLabel(frozen);
            std::vector<double> counts(GrowthScene::K, 0.0);
            for (int d = 0; d < kDraws; ++d) {
                alignas(64) int32_t nc[GrowthScene::Kp];
                const uint16_t z = growthDraw(sc, variant, d, nc);
                ASSERT_LT(z, GrowthScene::K);
                counts[z] += 1;
                ASSERT_EQ(nc[z], 1);
                if (frozen) {
                    ASSERT_TRUE(sc.nkv == ref.nkv && sc.nk == ref.nk) << "a round must not write the frozen tables";
                    continue;
                }
                std::string why;
                rost::kernel::Tables check = sc.t;
                rost::kernel::updateTopics(check);
                ASSERT_TRUE(check.active == sc.t.active && check.hi == sc.t.hi && check.slot == sc.t.slot)
                    << "case A=" << c.A << ": open topics kept up to date";
                ASSERT_EQ(sc.inv[z], rost::kernel::reciprocal(sc.nk[z], sc.t.vbeta));
                ASSERT_EQ(sc.dec[z], rost::kernel::reciprocal(sc.nk[z] - 1, sc.t.vbeta));
                ASSERT_EQ(sc.inc[z], rost::kernel::reciprocal(sc.nk[z] + 1, sc.t.vbeta));
                if (c.single && z != sc.z) {
                    ASSERT_EQ(sc.inv[sc.z], 0.f) << "the word's old topic closed";
                }
                std::copy(ref.nkv.begin(), ref.nkv.end(), sc.nkv.begin());
                std::copy(ref.nk.begin(), ref.nk.end(), sc.nk.begin());
                std::copy(ref.inv, ref.inv + GrowthScene::Kp, sc.inv);
                std::copy(ref.dec, ref.dec + GrowthScene::Kp, sc.dec);
                std::copy(ref.inc, ref.inc + GrowthScene::Kp, sc.inc);
                rost::kernel::updateTopics(sc.t);
            }
            GoodnessOfFit gof;
            int cells = 0;
            for (int k = 0; k < GrowthScene::K; ++k) {
                if (law[k] == 0.0) {
                    EXPECT_EQ(counts[k], 0.0) << "A=" << c.A << ": topic " << k << " is closed";
                    continue;
                }
                const double e = law[k] * kDraws;
                gof.stat += (counts[k] - e) * (counts[k] - e) / e;
                ++cells;
            }
            gof.df = cells - 1;
            EXPECT_GT(gof.p(), kPass) << "A=" << c.A << " hole " << c.hole << " single " << c.single << " variant "
                                      << variant << ": " << gof;
            if (fresh < GrowthScene::K) {
                EXPECT_GT(counts[fresh], 0.0) << "the new topic is drawn";
            }
        }
    }
}

// K = 7: the scan order.
TEST(GrowthConditional, NewTopicDrawsWithWeightGammaOverVOnEveryKernelPath) {
    growthCases<7>({{4, -1, false}, {5, -1, false}, {6, -1, false}, {7, -1, false}, {6, 1, false}, {5, -1, true},
                    {6, 2, true}});
}

// K = 37: more than 8 live blocks, the lane order: open topics up to a block
// boundary and inside a block, the cap, a hole, a word that closes its topic.
TEST(GrowthConditional, NewTopicDrawsWithWeightGammaOverVInTheLaneOrder) {
    growthCases<37>({{34, -1, false}, {36, -1, false}, {37, -1, false}, {35, 3, false}, {36, -1, true}});
}

// The growth conditional through a model built with gamma and V (the tests
// above set the kernel's tables by hand): a one-word cell beside a cell of
// 40 words, G(c) = c (g.space 0, one step), so with the word left out its
// law over the open topics B = {0..|B|-1} and a new topic |B| is
//   p_k ∝ (n'_k^v + beta) / (n'_k + V beta) * alpha,   p_new ∝ kGrowthFreshMass / V,
// the same for every draw (only the word moves): gamma no longer weighs a
// word's new topic (topics open by split moves). Two gammas, both kernel paths.
TEST(GrowthConditional, AModelsNewTopicWeighsTheFreshMassOverVForAnyGamma) {
    for (const double gamma : {0.05, 1.5}) {
        rost::Config c;
        c.K = 12;
        c.V = 10;
        c.grow = true;
        c.gamma = gamma;
        c.frame_width = 32;
        c.frame_height = 16;
        c.cell_space = 16;  // two cells
        c.g_space = 0;
        c.ring_steps = 1;
        c.cell_capacity = 64;
        c.max_words_per_frame = 64;
        c.seed = 3;
        rost::Model m(c);
        rost::Rng r(4);
        std::vector<uint32_t> w;
        std::vector<rost::Position> p;
        for (int i = 0; i < 40; ++i) {
            w.push_back(r.below(static_cast<uint32_t>(c.V)));
            p.push_back({static_cast<int32_t>(r.below(16)), static_cast<int32_t>(r.below(16))});
        }
        const uint32_t v = 3;
        w.push_back(v);
        p.push_back({20, 5});  // alone in cell 1
        ASSERT_TRUE(m.addObservation(w, p).ok());
        m.refineAll(5);
        std::vector<uint16_t> z(w.size());
        m.observationSamples(0, z);
        const int zi = z.back();
        int B = 0;  // open topics with the word left out: 0..B-1 (asserted)
        for (int k = 0; k < c.K; ++k) {
            const bool open = m.topicCount(k) - (k == zi ? 1 : 0) > 0;
            if (!open) continue;
            ASSERT_EQ(k, B++) << "gamma " << gamma << ": open topics below a closed one";
        }
        ASSERT_LT(B, c.K) << "gamma " << gamma << ": room for a new topic";
        std::vector<double> law(static_cast<std::size_t>(B) + 1, 0.0);
        double total = 0.0;
        for (int k = 0; k < B; ++k) {
            const int drop = k == zi ? 1 : 0;
            law[static_cast<std::size_t>(k)] = (m.topicWordCount(k, static_cast<int>(v)) - drop + c.beta) /
                                               (m.topicCount(k) - drop + c.V * c.beta) * c.alpha;
            total += law[static_cast<std::size_t>(k)];
        }
        law[static_cast<std::size_t>(B)] = rost::kGrowthFreshMass / c.V;
        total += rost::kGrowthFreshMass / c.V;
        for (double& x : law) x /= total;
        for (const Path path : {Path::Simd, Path::Scalar}) {
            m.setKernelPath(path);
            std::vector<double> counts(law.size(), 0.0);
            for (int d = 0; d < kDraws / 4; ++d) {
                m.refineCell(0, 1);
                m.observationSamples(0, z);
                ASSERT_LE(z.back(), B) << "a label past the new topic";
                counts[z.back()] += 1;
            }
            GoodnessOfFit g;
            addRow(g, counts, law);
            report("growth through a model, gamma " + std::to_string(gamma), g);
            EXPECT_GT(g.p(), kPass) << "gamma " << gamma << ": " << g << "; new topic drawn " << counts[B] << " times, "
                                    << law[B] * (kDraws / 4) << " expected";
        }
    }
}

// ---- paper eq. 5: the exact conditional -----------------------------------------------

class ExactConditional : public ::testing::TestWithParam<SceneSpec> {};

// One-word cell: iid draws from eq. 5; both kernel paths, one model (the
// frozen state is the same for both: a one-word cell changes only itself).
TEST_P(ExactConditional, OneWordCellDrawsFollowEq5OnBothKernelPaths) {
    const SceneSpec s = GetParam();
    rost::Model m(configOf(s));
    const Scene sc = makeScene(m, s);
    ASSERT_EQ(sc.target.size(), static_cast<std::size_t>(s.targetWords));
    ASSERT_EQ(m.cellWordCount(sc.targetStep, s.targetCell), static_cast<uint32_t>(s.targetWords));
    const auto law = transitionLaw(sc, eq5);
    for (Path path : {Path::Simd, Path::Scalar}) {
        const Chain ch = runChain(m, sc, path, kDraws);
        const GoodnessOfFit g = fit(ch, law);
        report(std::string(s.name) + (path == Path::Simd ? " simd vs eq.5" : " scalar vs eq.5"), g);
        EXPECT_GT(g.p(), kPass) << s.name << (path == Path::Simd ? " simd: " : " scalar: ") << g;
        // Only the target cell moved: the frozen labels and every count table still agree.
        std::string why;
        EXPECT_TRUE(m.checkInvariants(&why)) << why;
    }
    // The rest of the model really stayed frozen (the recount is still valid).
    std::vector<Token> after = recount(m, sc.config);
    ASSERT_EQ(after.size(), sc.tokens.size());
    for (std::size_t i = 0; i < after.size(); ++i)
        if (std::find(sc.target.begin(), sc.target.end(), i) == sc.target.end()) {
            ASSERT_EQ(after[i].z, sc.tokens[i].z) << "word " << i << " outside the target cell moved";
        }
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, ExactConditional,
    ::testing::Values(
        // K = 5 (padded to 8, generic kernel), radius 1, target in the middle of space and time.
        SceneSpec{"K5_radius1", 5, 8, 3, 3, 5, 8, 1, 1, 2, 4, 1, 3, 1, 3, 5, 11},
        // Radius 2 with a ring of 4 after 7 steps: the target step is the oldest
        // in the window (steps t-1, t-2 were evicted and must not count), and the
        // target is a corner cell (spatial neighbours clipped by the grid).
        SceneSpec{"K5_radius2_windowEdge_corner", 5, 8, 4, 3, 7, 4, 2, 2, 3, 0, 1, 5, 1, 3, 5, 12},
        // K = 16: the compile-time specialised kernel (one cache line of counts).
        SceneSpec{"K16_radius1", 16, 12, 3, 3, 5, 8, 1, 1, 2, 4, 1, 7, 1, 4, 5, 13},
        // Temporal radius only (g.space = 0, g.time = 2).
        SceneSpec{"K5_timeOnly", 5, 8, 3, 3, 5, 8, 0, 2, 2, 4, 1, 2, 1, 3, 5, 14},
        // More than 8 blocks: the lane order, compiled (K = 64) and at run
        // time with padding lanes (K = 37).
        SceneSpec{"K64_radius1_laneOrder", 64, 16, 3, 3, 5, 8, 1, 1, 2, 4, 1, 7, 2, 8, 5, 15},
        SceneSpec{"K37_radius1_laneOrder", 37, 16, 3, 3, 5, 8, 1, 1, 2, 4, 1, 7, 2, 8, 5, 16}),
    [](const ::testing::TestParamInfo<SceneSpec>& param) { return std::string(param.param.name); });

// Two words of the same type in one cell: the second word's conditional must
// see the first word's NEW label in n_k^v, n_k and n_G^k (the kernel carries
// the neighbourhood sums across the words of a cell). The transition law of
// a sweep is the product of the two sequential eq. 5 conditionals.
void twoWordSweep(const SceneSpec& s) {
    rost::Model m(configOf(s));
    const Scene sc = makeScene(m, s);
    ASSERT_EQ(sc.target.size(), 2u);
    const auto law = transitionLaw(sc, eq5);
    for (Path path : {Path::Simd, Path::Scalar}) {
        const Chain ch = runChain(m, sc, path, kDraws);
        const GoodnessOfFit g = fit(ch, law);
        report(std::string(s.name) + (path == Path::Simd ? " simd" : " scalar"), g);
        EXPECT_GT(g.p(), kPass) << (path == Path::Simd ? "simd: " : "scalar: ") << g;
    }
}

// K = 5: the scan order. K = 33 (9 blocks, 3 padding lanes): the lane order.
TEST(ExactConditionalInCell, TwoWordSweepFollowsSequentialEq5OnBothKernelPaths) {
    twoWordSweep(SceneSpec{"K5_twoWords", 5, 8, 3, 3, 5, 8, 1, 1, 2, 4, 2, 3, 2, 6, 5, 21});
    twoWordSweep(SceneSpec{"K33_twoWords_laneOrder", 33, 8, 3, 3, 5, 8, 1, 1, 2, 4, 2, 3, 2, 6, 5, 22});
}

// A sweep of a cell of many words keeps every count its bookkeeping carries
// from word to word: after it, n_k^v and n_k hold the rest of the model plus
// the cell's words at their new labels, the cell's own counts n_c^k hold its
// labels, the neighbourhood sums n_G^k the neighbours' counts plus the cell's,
// and the cached reciprocals follow n_k. A count one word leaves wrong skews
// the conditionals of the words after it by one, which a chi-square test of a
// few words can miss; this check cannot. Words that keep their topic and words
// that move both happen (asserted), on both paths, for the register kernel
// (K = 16), the lane kernel at a known K (64) and at run time (37), and the
// growth kernel (topics open and close); live and in a parallel window's
// frozen round (which only reads n_k^v and n_k and lists its moves); and the
// kernel of a fixed topic model (which never writes n_k^v and n_k).
enum class Sweep { Live, Frozen, Fixed };

template <int KP>
void cellSweepCounts(const int K, const bool grow, const Sweep mode) {
    const bool frozen = mode == Sweep::Frozen, fixed = mode == Sweep::Fixed;
    const int Kp = rost::kernel::paddedK(K), V = 6, n = 40;
    const int open = grow ? K - 9 : K;  // growth: the top 9 labels start closed
    for (const Path path : {Path::Simd, Path::Scalar}) {
        rost::Rng r(static_cast<uint64_t>(500 + K + (grow ? 1 : 0) + 2 * static_cast<int>(mode)));
        std::vector<int32_t> restV(V * Kp, 0), restK(Kp, 0), around(Kp, 0);
        for (int v = 0; v < V; ++v)
            for (int k = 0; k < open; ++k) restV[v * Kp + k] = static_cast<int32_t>(r.below(4));
        for (int k = 0; k < open; ++k) {
            for (int v = 0; v < V; ++v) restK[k] += restV[v * Kp + k];
            around[k] = restK[k] > 0 ? static_cast<int32_t>(r.below(3)) : 0;
        }
        std::vector<uint32_t> words(n);
        std::vector<uint16_t> z(n);
        for (int i = 0; i < n; ++i) {
            words[i] = static_cast<uint32_t>(r.below(V));
            z[i] = static_cast<uint16_t>(r.below(static_cast<uint64_t>(open)));
        }
        // The tables the kernel sees, from the rest of the model and the cell's labels.
        std::vector<int32_t> nkv = restV, nk = restK, nc(Kp, 0), g(Kp, 0);
        for (int i = 0; i < n; ++i) {
            ++nkv[words[i] * static_cast<uint32_t>(Kp) + z[i]];
            ++nk[z[i]];
            ++nc[z[i]];
        }
        for (int k = 0; k < Kp; ++k) g[k] = around[k] + nc[k];
        std::vector<float> inv(Kp), dec(Kp), inc(Kp);
        rost::kernel::Tables t;
        t.nkv = nkv.data();
        t.nk = nk.data();
        t.inv = inv.data();
        t.dec = dec.data();
        t.inc = inc.data();
        t.K = K;
        t.Kp = Kp;
        t.active = K;
        t.grow = grow;
        t.fresh = grow ? 2.0f / static_cast<float>(V) : 0.f;
        t.alpha = 0.3f;
        t.beta = 0.2f;
        t.vbeta = static_cast<float>(V) * t.beta;
        rost::kernel::refreshReciprocals(t);
        if (grow) rost::kernel::updateTopics(t);
        // The frozen register kernels at a known K read each topic's left-out reciprocals.
        std::vector<float> left;
        if (frozen && (KP == 16 || KP == 32)) {
            left.resize(static_cast<std::size_t>(Kp) * static_cast<std::size_t>(Kp));
            t.left = left.data();
            rost::kernel::fillLeft(t);
        }
        int kept = 0, moved = 0, opened = 0;
        for (int sweep = 0; sweep < 30; ++sweep) {
            const std::vector<uint16_t> before = z;
            std::vector<bool> wasOpen(K);
            for (int k = 0; k < K; ++k) wasOpen[k] = nk[k] > 0;
            rost::detail::CounterRng rng(777, static_cast<uint64_t>(sweep));
            const std::vector<int32_t> roundV = nkv, roundK = nk;
            std::vector<uint64_t> moves(n);
            uint32_t listed = 0;
            if (frozen) {
                listed = path == Path::Simd ? rost::kernel::refineCellFrozen<KP, Path::Simd>(
                                                  t, g.data(), words.data(), z.data(), before.data(), n, rng, moves.data())
                                            : rost::kernel::refineCellFrozen<KP, Path::Scalar>(
                                                  t, g.data(), words.data(), z.data(), before.data(), n, rng, moves.data());
            } else if (fixed) {
                rost::kernel::refineCellFixed(t, g.data(), nc.data(), words.data(), z.data(), n, rng);
            } else if (path == Path::Simd) {
                rost::kernel::refineCell<KP, Path::Simd>(t, g.data(), nc.data(), words.data(), z.data(), n, rng);
            } else {
                rost::kernel::refineCell<KP, Path::Scalar>(t, g.data(), nc.data(), words.data(), z.data(), n, rng);
            }
            std::vector<int32_t> wantV = restV, wantK = restK, wantC(Kp, 0);
            for (int i = 0; i < n; ++i) {
                ASSERT_LT(z[i], K);
                (z[i] == before[i] ? kept : moved) += 1;
                ++wantV[words[i] * static_cast<uint32_t>(Kp) + z[i]];
                ++wantK[z[i]];
                ++wantC[z[i]];
            }
            const std::string where = "K = " + std::to_string(K) + (grow ? " (growth)" : "") +
                                      (frozen ? ", a frozen round" : "") + (fixed ? ", a fixed model" : "") + (path == Path::Simd ? ", simd" : ", scalar") +
                                      ", sweep " + std::to_string(sweep);
            if (frozen) {
                // A round only reads n_k^v and n_k, and lists each word that moved, in order.
                ASSERT_EQ(nkv, roundV) << where << ": a round wrote n_k^v";
                ASSERT_EQ(nk, roundK) << where << ": a round wrote n_k";
                uint32_t m = 0;
                for (int i = 0; i < n; ++i) {
                    if (z[i] == before[i]) continue;
                    ASSERT_LT(m, listed) << where << ": word " << i << "'s move is not listed";
                    const uint64_t want = words[i] | uint64_t{before[i]} << 32 | uint64_t{z[i]} << 48;
                    ASSERT_EQ(moves[m], want) << where << ": move " << m << " (word " << i << ")";
                    ++m;
                }
                ASSERT_EQ(listed, m) << where << ": moves listed";
                // The round's end: the tables take the cell's new labels, and the cell's counts follow nG.
                nkv = wantV;
                nk = wantK;
                nc = wantC;
                rost::kernel::refreshReciprocals(t);
                if (grow) rost::kernel::updateTopics(t);
                if (t.left) rost::kernel::fillLeft(t);
            }
            if (fixed) {
                // A fixed model's counts are the given ones, whatever the cell's labels.
                ASSERT_EQ(nkv, roundV) << where << ": a fixed model's n_k^v written";
                ASSERT_EQ(nk, roundK) << where << ": a fixed model's n_k written";
                wantV = roundV;
                wantK = roundK;
            }
            ASSERT_EQ(nkv, wantV) << where << ": n_k^v";
            ASSERT_EQ(nk, wantK) << where << ": n_k";
            ASSERT_EQ(nc, wantC) << where << ": the cell's own counts";
            for (int k = 0; k < Kp; ++k) {
                ASSERT_EQ(g[k], around[k] + wantC[k]) << where << ": the neighbourhood sum of topic " << k;
                if (k >= K || (grow && nk[k] == 0)) {
                    ASSERT_EQ(inv[k], 0.f) << where << ": topic " << k << " is closed";
                    continue;
                }
                ASSERT_EQ(inv[k], rost::kernel::reciprocal(nk[k], t.vbeta)) << where << ", topic " << k;
                ASSERT_EQ(dec[k], rost::kernel::reciprocal(nk[k] - 1, t.vbeta)) << where << ", topic " << k;
                ASSERT_EQ(inc[k], rost::kernel::reciprocal(nk[k] + 1, t.vbeta)) << where << ", topic " << k;
                if (grow && !wasOpen[k]) ++opened;
            }
            if (grow) {
                rost::kernel::Tables check = t;
                rost::kernel::updateTopics(check);
                ASSERT_TRUE(check.active == t.active && check.hi == t.hi && check.slot == t.slot)
                    << where << ": the open topics kept up to date";
            }
        }
        EXPECT_GT(kept, 20) << "K = " << K << ": words that keep their topic (" << moved << " moved)";
        EXPECT_GT(moved, 20) << "K = " << K << ": words that move";
        if (grow) {
            EXPECT_GT(opened, 0) << "K = " << K << ": a closed topic opened";
        }
    }
}

TEST(KernelCounts, ACellSweepOfManyWordsKeepsEveryCountItsLabelsGive) {
    for (const Sweep mode : {Sweep::Live, Sweep::Frozen}) {
        cellSweepCounts<16>(16, false, mode);
        cellSweepCounts<64>(64, false, mode);
        cellSweepCounts<0>(37, false, mode);
        cellSweepCounts<rost::kernel::kGrow>(40, true, mode);
    }
    cellSweepCounts<0>(16, false, Sweep::Fixed);  // one scalar loop for every K
    cellSweepCounts<0>(37, false, Sweep::Fixed);
}

// The test can fail: the public 2013 code removed the word by subtracting one
// from EVERY topic's counts (DESIGN.md). With the word currently at z, its
// weights are (n^v_k + [k=z] - 1 + beta) / (n_k + [k=z] - 1 + V beta) *
// (n_G^k + [k=z] - 1 + alpha) in the -i counts, so the draws would follow the
// stationary law of that chain. The draws of the correct kernel must reject it.
TEST(ExactConditionalInCell, SubtractOneFromEveryTopicConditionalIsRejected) {
    // Labels left uniformly random (no warm-up) and many words, so every count
    // the 2013 rule decrements is >= 1 and its weights stay positive.
    const SceneSpec s{"K5_2013", 5, 8, 3, 3, 5, 8, 1, 1, 2, 4, 1, 3, 8, 12, 0, 31};
    rost::Model m(configOf(s));
    const Scene sc = makeScene(m, s);
    ASSERT_EQ(sc.target.size(), 1u);
    const rost::Config& c = sc.config;
    const std::size_t i = sc.target[0];
    const Token& me = sc.tokens[i];

    // -i counts from the recount.
    std::vector<double> nkv(c.K, 0), nk(c.K, 0), nG(c.K, 0);
    for (std::size_t j = 0; j < sc.tokens.size(); ++j) {
        if (j == i) continue;
        const Token& o = sc.tokens[j];
        nk[o.z] += 1;
        nkv[o.z] += o.word == me.word;
        const bool spatial = o.step == me.step && std::abs(o.cx - me.cx) + std::abs(o.cy - me.cy) <= c.g_space;
        const bool temporal = o.cx == me.cx && o.cy == me.cy && std::abs(o.step - me.step) >= 1 && std::abs(o.step - me.step) <= c.g_time;
        nG[o.z] += spatial || temporal;
    }
    // Transition matrix of the 2013 rule and its stationary law.
    std::vector<std::vector<double>> P(c.K, std::vector<double>(c.K));
    for (int z = 0; z < c.K; ++z) {
        double sum = 0.0;
        for (int k = 0; k < c.K; ++k) {
            const double own = k == z ? 1.0 : 0.0;
            const double a = nkv[k] + own - 1.0 + c.beta, b = nk[k] + own - 1.0 + c.V * c.beta, g = nG[k] + own - 1.0 + c.alpha;
            ASSERT_GT(a, 0.0) << "set-up: the 2013 weights must be positive (topic " << k << ")";
            ASSERT_GT(g, 0.0) << "set-up: the 2013 weights must be positive (topic " << k << ")";
            P[z][k] = a / b * g;
            sum += P[z][k];
        }
        for (double& x : P[z]) x /= sum;
    }
    std::vector<double> pi(c.K, 1.0 / c.K);
    for (int it = 0; it < 10000; ++it) {
        std::vector<double> next(c.K, 0.0);
        for (int z = 0; z < c.K; ++z)
            for (int k = 0; k < c.K; ++k) next[k] += pi[z] * P[z][k];
        pi = next;
    }

    const auto right = transitionLaw(sc, eq5);
    const std::vector<std::vector<double>> wrong{pi};
    for (Path path : {Path::Simd, Path::Scalar}) {
        const Chain ch = runChain(m, sc, path, kDraws);
        const double lambda = noncentrality(right, wrong, ch);
        ASSERT_GE(lambda, 200.0) << "set-up: the 2013 law is too close to eq. 5 to be told apart";
        const GoodnessOfFit good = fit(ch, right);
        const GoodnessOfFit bad = fit(ch, wrong);
        report(std::string(path == Path::Simd ? "simd" : "scalar") + " vs eq.5", good);
        report(std::string(path == Path::Simd ? "simd" : "scalar") + " vs 2013 rule (noncentrality " +
                   std::to_string(lambda) + ")",
               bad);
        EXPECT_GT(good.p(), kPass) << good;
        EXPECT_LT(bad.p(), kReject) << bad << " (noncentrality " << lambda << ")";
    }
}

// ---- radius 0 is LDA (Griffiths & Steyvers) ----------------------------------------------

// With g.space = g.time = 0 the neighbourhood is the cell alone, so eq. 5 is
// collapsed Gibbs for LDA with one document per cell. A two-word cell makes
// the document term matter (each word sees the other's label).
TEST(RadiusZeroIsLda, ClosedFormsAgreeForEveryWord) {
    const SceneSpec s{"K5_lda", 5, 8, 3, 3, 5, 8, 0, 0, 2, 4, 2, 3, 2, 6, 5, 41};
    rost::Model m(configOf(s));
    const Scene sc = makeScene(m, s);
    for (std::size_t i = 0; i < sc.tokens.size(); ++i) {
        const auto a = eq5(sc.tokens, i, sc.config), b = griffithsSteyvers(sc.tokens, i, sc.config);
        for (int k = 0; k < sc.config.K; ++k) ASSERT_NEAR(a[k], b[k], 1e-12) << "token " << i << " topic " << k;
    }
}

TEST(RadiusZeroIsLda, SamplerFollowsGriffithsSteyversOnBothKernelPaths) {
    const SceneSpec s{"K5_lda", 5, 8, 3, 3, 5, 8, 0, 0, 2, 4, 2, 3, 2, 6, 5, 41};
    rost::Model m(configOf(s));
    const Scene sc = makeScene(m, s);
    ASSERT_EQ(sc.target.size(), 2u);
    const auto law = transitionLaw(sc, griffithsSteyvers);
    for (Path path : {Path::Simd, Path::Scalar}) {
        const Chain ch = runChain(m, sc, path, kDraws);
        const GoodnessOfFit g = fit(ch, law);
        report(std::string(s.name) + (path == Path::Simd ? " simd" : " scalar"), g);
        EXPECT_GT(g.p(), kPass) << (path == Path::Simd ? "simd: " : "scalar: ") << g;
    }
}

// The same scene with radius 1: the draws still follow eq. 5 but no longer
// LDA, which the test must see (the neighbours' labels enter the conditional).
TEST(RadiusZeroIsLda, RadiusOneDrawsRejectGriffithsSteyvers) {
    const SceneSpec s{"K5_lda_r1", 5, 8, 3, 3, 5, 8, 1, 1, 2, 4, 2, 3, 2, 6, 5, 41};
    rost::Model m(configOf(s));
    const Scene sc = makeScene(m, s);
    ASSERT_EQ(sc.target.size(), 2u);
    const auto right = transitionLaw(sc, eq5);
    const auto lda = transitionLaw(sc, griffithsSteyvers);
    const Chain ch = runChain(m, sc, Path::Simd, kDraws);
    const double lambda = noncentrality(right, lda, ch);
    ASSERT_GE(lambda, 1000.0) << "set-up: LDA and eq. 5 too close on this scene";
    const GoodnessOfFit good = fit(ch, right);
    const GoodnessOfFit bad = fit(ch, lda);
    report("radius 1 vs eq.5", good);
    report("radius 1 vs LDA (noncentrality " + std::to_string(lambda) + ")", bad);
    EXPECT_GT(good.p(), kPass) << good;
    EXPECT_LT(bad.p(), kReject) << bad << " (noncentrality " << lambda << ")";
}

} // namespace
