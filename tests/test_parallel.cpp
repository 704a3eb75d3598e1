// Refinement in windows on every core (Model::refine, src/core/worker_pool):
// the same labels, counts and perplexity for any number of threads; the
// count invariants after every round; the colouring; W = 1 is the serial
// sampler; the pool under more threads than cores; the measurements on the
// workers (perplexities, surprise, labels) give the serial bits.

#include <gtest/gtest.h>

#include <sched.h>

#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <memory>
#include <thread>
#include <string>
#include <vector>

#include "rost/engine.hpp"
#include "rost/model.hpp"
#include "synthetic.hpp"
#include "test_deadline.hpp"
#include "test_engine_support.hpp"
#include "measure.hpp"
#include "worker_pool.hpp"

namespace rost {
namespace {

using testing::makeStream;
using testing::smallConfig;
namespace syn = synthetic;

// Everything a run exposes, to compare runs with.
struct Outcome {
    std::vector<uint16_t> labels, samples;
    std::vector<int32_t> nkv;
    std::vector<double> perplexity;
    uint64_t tokens = 0;
    bool operator==(const Outcome&) const = default;
};

Outcome outcomeOf(const Model& m) {
    Outcome o;
    for (uint64_t f = 0; f < m.observations(); ++f) {
        if (!m.observationInWindow(f)) continue;
        std::vector<uint16_t> l(m.observationSize(f)), s(m.observationSize(f));
        m.observationLabels(f, l);
        m.observationSamples(f, s);
        o.labels.insert(o.labels.end(), l.begin(), l.end());
        o.samples.insert(o.samples.end(), s.begin(), s.end());
    }
    for (int v = 0; v < m.V(); ++v)
        for (int k = 0; k < m.K(); ++k) o.nkv.push_back(m.topicWordCount(k, v));
    for (int64_t t = m.oldestStep(); t < m.steps(); ++t) o.perplexity.push_back(m.stepPerplexity(t));
    o.tokens = m.tokensRefined();
    return o;
}

// A video-like grid (12 cells a step) and a word stream (1 cell a step).
Config gridConfig(int threads, int window) {
    Config c = smallConfig();
    c.threads = threads;
    c.refine_window = window;
    return c;
}
Config streamConfig(int threads, int window) {
    Config c = gridConfig(threads, window);
    c.frame_width = 1;
    c.frame_height = 1;
    c.cell_capacity = 256;
    return c;
}

Outcome engineRun(const Config& model, Budget budget, int frames) {
    EngineConfig ec;
    ec.model = model;
    ec.budget = budget;
    Engine e(ec);
    const auto stream = makeStream(model, frames, 200, 5);
    for (const auto& f : stream) EXPECT_TRUE(e.processNow(f.view()).add.ok());
    e.finalPass(3);
    std::string why;
    EXPECT_TRUE(e.model().checkInvariants(&why)) << why;
    return outcomeOf(e.model());
}

TEST(ParallelRefine, OneToFourThreadsGiveIdenticalLabelsCountsAndPerplexity) {
    for (const auto make : {&gridConfig, &streamConfig})
        for (const Budget b : {Budget::steps(6), Budget::tokens(2000)}) {
            const Outcome one = engineRun(make(1, 64), b, 40);
            ASSERT_GT(one.tokens, 0u);
            for (int threads = 2; threads <= 4; ++threads)
                EXPECT_TRUE(engineRun(make(threads, 64), b, 40) == one)
                    << threads << " threads differ from 1 (budget kind " << static_cast<int>(b.kind) << ")";
        }
}

TEST(ParallelRefine, ATokenBudgetIsPassedByLessThanOneCell) {
    for (const int threads : {1, 3}) {
        EngineConfig ec;
        ec.model = gridConfig(threads, 256);
        ec.budget = Budget::tokens(100);
        Engine e(ec);
        for (const auto& f : makeStream(ec.model, 30, 200, 9)) {
            const ObservationResult r = e.processNow(f.view());
            EXPECT_GE(r.tokens, 100u);
            EXPECT_LT(r.tokens, 100u + static_cast<uint64_t>(ec.model.cell_capacity));
        }
    }
}

// Checks the count tables after every round of every window.
class InvariantCheck final : public RefineControl {
public:
    explicit InvariantCheck(const Model& m) : m_(m), active(m.activeTopics()) {}
    void afterRound(uint64_t) noexcept override {
        ++rounds;
        if (failure.empty() && !m_.checkInvariants(&failure) && failure.empty()) failure = "invariants failed";
        const int a = m_.activeTopics();
        if (a != active) ++activeChanges;
        active = a;
    }
    const Model& m_;
    uint64_t rounds = 0;
    int active;
    uint64_t activeChanges = 0;  // rounds after which the open topics changed
    std::string failure;
};

class Sweep final : public StepPicker {
public:
    explicit Sweep(const Model& m) : m_(m), t_(m.oldestStep()) {}
    int64_t next() noexcept override {
        const int64_t t = t_;
        t_ = t_ + 1 < m_.steps() ? t_ + 1 : m_.oldestStep();
        return t;
    }
    const Model& m_;
    int64_t t_;
};

// A word stream of one cell a step (frame 1 x 1), `steps` steps of `words`
// words each, refined in windows of `window` cell refinements.
std::unique_ptr<Model> oneCellModel(int window, int threads, int steps, int words) {
    Config c = smallConfig();
    c.frame_width = 1;
    c.frame_height = 1;
    c.cell_capacity = words;
    c.max_words_per_frame = words;
    c.refine_window = window;
    c.threads = threads;
    auto m = std::make_unique<Model>(c);
    for (int t = 0; t < steps; ++t) {
        std::vector<uint32_t> w(static_cast<std::size_t>(words));
        for (int i = 0; i < words; ++i) w[static_cast<std::size_t>(i)] = static_cast<uint32_t>((t * 7 + i * 3) % c.V);
        const std::vector<Position> at(w.size());
        EXPECT_TRUE(m->addObservation(w, at).ok());
    }
    return m;
}

// Always the same step.
class SameStep final : public StepPicker {
public:
    explicit SameStep(int64_t t) : t_(t) {}
    int64_t next() noexcept override { return t_; }
    int64_t t_;
};

// Refuses every round (a deadline already passed when the window is full).
class NoRound final : public RefineControl {
public:
    bool beforeRound(uint64_t) noexcept override { return false; }
};

// A window's counts: a cell picked k times is refined k times (k x its words
// in the tokens); a step draw counts as started only when a cell of it was
// refined, and each refinement counts its own from the first draw.
TEST(ParallelRefine, AWindowCountsRepeatedPicksAndOnlyStepsItRefined) {
    for (const int threads : {1, 2}) {
        constexpr int kWords = 30;
        const std::unique_ptr<Model> model = oneCellModel(4, threads, 3, kWords);
        Model& m = *model;
        SameStep same(1);
        RefineLimits four;
        four.steps = 4;
        const uint64_t before = m.tokensRefined();
        const RefineCount rc = m.refine(same, four);
        EXPECT_EQ(rc.steps, 4u) << threads << " threads";
        EXPECT_EQ(rc.tokens, 4u * kWords) << "a cell picked 4 times in one window, " << threads << " threads";
        EXPECT_EQ(m.tokensRefined() - before, rc.tokens);
        EXPECT_EQ(rc.started, 4u);
        // Refinements of one step each, one after another: each started once.
        for (int i = 0; i < 3; ++i) {
            Sweep sweep(m);
            RefineLimits one;
            one.steps = 1;
            const RefineCount r1 = m.refine(sweep, one);
            EXPECT_EQ(r1.steps, 1u);
            EXPECT_EQ(r1.started, 1u) << "refinement " << i << ", " << threads << " threads";
            EXPECT_EQ(r1.tokens, static_cast<uint64_t>(kWords));
        }
        // Steps drawn, but no round allowed: none started.
        NoRound none;
        RefineLimits refused;
        refused.steps = 4;
        refused.control = &none;
        Sweep sweep(m);
        const RefineCount r0 = m.refine(sweep, refused);
        EXPECT_EQ(r0.rounds, 0u);
        EXPECT_EQ(r0.tokens, 0u);
        EXPECT_EQ(r0.started, 0u) << "steps counted as started with no cell of them refined, " << threads << " threads";
        EXPECT_TRUE(m.checkInvariants());
    }
}

TEST(ParallelRefine, CountsAreConsistentAfterEveryRound) {
    for (const int window : {2, 16, 256}) {
        Model m(gridConfig(3, window));
        for (const auto& f : makeStream(m.config(), 20, 200, 3)) ASSERT_TRUE(m.addObservation(f.words, f.positions).ok());
        InvariantCheck check(m);
        Sweep sweep(m);
        RefineLimits limits;
        limits.steps = 60;
        limits.control = &check;
        const RefineCount rc = m.refine(sweep, limits);
        EXPECT_EQ(rc.steps, 60u);
        EXPECT_EQ(rc.rounds, check.rounds);
        EXPECT_GT(check.rounds, 1u);
        EXPECT_TRUE(check.failure.empty()) << "window " << window << ": " << check.failure;
    }
}

// With topics that grow, a round opens and closes topics on the workers'
// copies: the open-topic bookkeeping (which topics hold words, A, the highest
// open label, the next free one; checkInvariants) holds after every round of
// a window, not only once refinement is over.
TEST(ParallelRefine, OpenTopicsAreKeptAfterEveryRoundWhenTopicsGrow) {
    for (const int window : {16, 256}) {
        Config c = gridConfig(3, window);
        c.grow = true;
        c.gamma = 2.0;
        c.alpha = 0.001;  // words of topics 0 and 1 seldom join a one-word topic first
        Model m(c);
        // Topics 2.. hold one word each, in frames the window keeps, so
        // that they close during the rounds when their word leaves (a word
        // alone opens a topic only when none is open).
        rost::Rng lr(5);
        const auto frames = makeStream(m.config(), 20, 200, 3);
        for (std::size_t f = 0; f < frames.size(); ++f) {
            std::vector<uint16_t> labels(frames[f].words.size());
            for (auto& z : labels) z = static_cast<uint16_t>(lr.below(2));
            const int single = static_cast<int>(f) - 4 + 2;  // frames 4.. (the oldest kept): topics 2..K-1
            if (single >= 2 && single < c.K) labels[0] = static_cast<uint16_t>(single);
            ASSERT_TRUE(m.addObservation(frames[f].words, frames[f].positions, labels).ok());
        }
        const int openBefore = m.activeTopics();
        InvariantCheck check(m);
        Sweep sweep(m);
        RefineLimits limits;
        limits.steps = 60;
        limits.control = &check;
        m.refine(sweep, limits);
        EXPECT_GT(check.rounds, 1u);
        // Topics closed during the rounds (seen after a round, or once the
        // last round's moves are in the model's table).
        EXPECT_TRUE(check.activeChanges > 0 || m.activeTopics() != openBefore)
            << "window " << window << ": topics closed during the rounds";
        EXPECT_TRUE(check.failure.empty()) << "window " << window << ": " << check.failure;
    }
}

// Steps drawn at random from the model's generator, as a strategy draws them.
class RandomSteps final : public StepPicker {
public:
    explicit RandomSteps(Model& m) : m_(m) {}
    int64_t next() noexcept override {
        return m_.oldestStep() + m_.rng().below(static_cast<uint32_t>(m_.steps() - m_.oldestStep()));
    }
    Model& m_;
};

// With workers and a step budget each window is planned (picks drawn, key
// drawn, cells grouped) by a task of the window before; the draws are in
// the serial order, so the result and the generator's state afterwards are
// one thread's. A token budget plans after the round, as one thread does.
TEST(ParallelRefine, WindowsArePlannedAheadOnWorkersWithTheSameDraws) {
    struct Run {
        Outcome outcome;
        RefineCount rc;
        uint32_t after = 0;  // the generator's next draw after the refinement
    };
    const auto run = [](int threads, const RefineLimits& limits, bool random) {
        Model m(gridConfig(threads, 16));
        for (const auto& f : makeStream(m.config(), 20, 200, 6)) EXPECT_TRUE(m.addObservation(f.words, f.positions).ok());
        Sweep sweep(m);
        RandomSteps steps(m);
        Run r;
        r.rc = random ? m.refine(steps, limits) : m.refine(sweep, limits);
        std::string why;
        EXPECT_TRUE(m.checkInvariants(&why)) << why;
        r.outcome = outcomeOf(m);
        r.after = m.rng().next();
        return r;
    };
    RefineLimits steps;
    steps.steps = 45;
    for (const bool random : {false, true}) {
        const Run one = run(1, steps, random);
        ASSERT_GT(one.rc.rounds, 4u);
        for (const int threads : {2, 3}) {
            const Run r = run(threads, steps, random);
            EXPECT_TRUE(r.outcome == one.outcome) << threads << " threads, random " << random;
            EXPECT_EQ(r.after, one.after) << threads << " threads, random " << random;
            EXPECT_EQ(r.rc.steps, one.rc.steps);
            EXPECT_EQ(r.rc.started, one.rc.started);
            EXPECT_EQ(r.rc.tokens, one.rc.tokens);
            EXPECT_EQ(r.rc.rounds, one.rc.rounds);
            // Two colours: about one window every two rounds, each planned
            // ahead but the first (and any after a round of a single cell).
            EXPECT_GT(r.rc.planned, one.rc.rounds / 4) << threads << " threads, random " << random;
            EXPECT_LT(r.rc.planned, one.rc.rounds);
        }
    }
    RefineLimits tokens;
    tokens.tokens = 20000;
    const Run t1 = run(1, tokens, true), t2 = run(2, tokens, true);
    EXPECT_TRUE(t2.outcome == t1.outcome);
    EXPECT_EQ(t2.after, t1.after);
    EXPECT_EQ(t2.rc.planned, 0u);
    EXPECT_GT(t2.rc.rounds, 0u);
}

// A sweep that takes its time over each step (on the worker that plans
// the next window): the other workers park meanwhile, wake late for the
// next round and miss it, and take part in the rounds after.
class SlowSweep final : public StepPicker {
public:
    explicit SlowSweep(const Model& m) : sweep_(m) {}
    int64_t next() noexcept override {
        std::this_thread::sleep_for(std::chrono::microseconds(300));
        return sweep_.next();
    }
    Sweep sweep_;
};

// Without a control, a round's moves reach each worker's copy of n_k^v at
// the start of the next round (the worker that takes part adds them
// itself; the caller adds them to the copies of workers that took no task)
// and the model's own table when the refinement ends. Four threads on
// rounds of one to a few cells, planned slowly: workers miss rounds and
// take part again, and rounds of one cell (window 3: two cells of a colour,
// then one) refine against the live counts in between.
TEST(ParallelRefine, DeferredMergesReachEveryCopyAndTheModelsTable) {
    for (const int window : {3, 4, 16}) {
        const auto run = [window](int threads) {
            Model m(gridConfig(threads, window));
            const auto stream = makeStream(m.config(), 24, 200, 8);
            SlowSweep sweep(m);
            RefineLimits limits;
            limits.steps = 7;
            std::string why;
            RefineCount total;
            for (std::size_t i = 0; i < stream.size(); ++i) {
                EXPECT_TRUE(m.addObservation(stream[i].words, stream[i].positions).ok());
                if (i % 4 != 3) continue;
                const RefineCount rc = m.refine(sweep, limits);
                total.rounds += rc.rounds;
                total.deferred += rc.deferred;
                total.caught_up += rc.caught_up;
                EXPECT_TRUE(m.checkInvariants(&why)) << "window " << window << ", " << threads << " threads: " << why;
            }
            return std::make_pair(outcomeOf(m), total);
        };
        const auto [one, serial] = run(1);
        EXPECT_EQ(serial.deferred, 0u);  // one thread merges each round at once
        for (const int threads : {2, 4}) {
            const auto [outcome, rc] = run(threads);
            EXPECT_TRUE(outcome == one) << "window " << window << ", " << threads << " threads";
            EXPECT_GT(rc.deferred, serial.rounds / 4) << "window " << window << ", " << threads << " threads";
            // A window of four picks of a sweep is two rounds of two cells
            // (one with the planning task): on four workers a round always
            // leaves one out, and the caller catches its copy up.
            if (threads == 4 && window == 4) {
                EXPECT_GT(rc.caught_up, 0u);
            }
        }
    }
}

TEST(ParallelRefine, WindowOfOneIsTheSerialSampler) {
    Model a(gridConfig(2, 1)), b(gridConfig(1, 1));
    const auto stream = makeStream(a.config(), 20, 200, 4);
    for (const auto& f : stream) {
        ASSERT_TRUE(a.addObservation(f.words, f.positions).ok());
        ASSERT_TRUE(b.addObservation(f.words, f.positions).ok());
    }
    a.refineAll(3);
    for (int s = 0; s < 3; ++s)
        for (int64_t t = b.oldestStep(); t < b.steps(); ++t) b.refineStep(t);
    EXPECT_TRUE(outcomeOf(a) == outcomeOf(b));
}

// A window's tasks are ordered by colour and, where a worker refines two at
// once (K = 16 on the vector path), within a colour by their cell's words;
// the order changes no result. Cells of every length, also of more words
// than the order has keys for (63), are refined once a sweep, each in its own
// colour's round: every word counted once, every step's samples drawn anew,
// and the samples the scalar path (no pairs, first-pick order) draws.
TEST(ParallelRefine, ASweepRefinesEveryCellOnceWhateverItsLength) {
    const auto samples = [](const Model& m) {
        std::vector<std::vector<uint16_t>> s(m.observations());
        for (uint64_t f = 0; f < m.observations(); ++f) {
            if (!m.observationInWindow(f)) continue;
            s[f].resize(m.observationSize(f));
            m.observationSamples(f, s[f]);
        }
        return s;
    };
    for (const int K : {8, 16})
        for (const int threads : {1, 2})
            for (const int window : {16, 256}) {
                Config c = streamConfig(threads, window);
                c.K = K;
                Model m(c), reference(c);
                reference.setKernelPath(kernel::Path::Scalar);
                Rng r(11);
                for (int t = 0; t < 30; ++t) {
                    const auto n = static_cast<std::size_t>(20 + (t * 37) % 150);  // 20 to 169 words
                    std::vector<uint32_t> w(n);
                    for (auto& v : w) v = r.below(static_cast<uint32_t>(m.V()));
                    ASSERT_TRUE(m.addObservation(w, std::vector<Position>(n, Position{0, 0})).ok());
                    ASSERT_TRUE(reference.addObservation(w, std::vector<Position>(n, Position{0, 0})).ok());
                }
                const auto before = samples(m);
                uint64_t words = 0;
                for (const auto& s : before) words += s.size();
                const std::string where =
                    "K " + std::to_string(K) + ", " + std::to_string(threads) + " threads, window " + std::to_string(window);
                EXPECT_EQ(m.refineAll(1), words) << where;
                EXPECT_EQ(reference.refineAll(1), words) << where;
                const auto after = samples(m);
                for (uint64_t f = 0; f < after.size(); ++f)
                    if (!after[f].empty()) {
                        EXPECT_NE(after[f], before[f]) << "step " << f << " (" << after[f].size()
                                                       << " words) not refined, " << where;
                    }
                EXPECT_TRUE(after == samples(reference)) << "the scalar path draws other samples, " << where;
                std::string why;
                EXPECT_TRUE(m.checkInvariants(&why)) << why;
            }
}

TEST(ParallelRefine, NoTwoCellsOfAColourAreNeighbours) {
    for (int gs = 0; gs <= 3; ++gs)
        for (int gt = 0; gt <= 3; ++gt) {
            Config c = smallConfig();
            c.frame_width = 640;
            c.frame_height = 480;
            c.cell_space = 40;  // 16 x 12
            c.g_space = gs;
            c.g_time = gt;
            const Model m(c);
            const int gw = c.gridWidth(), cells = c.cellsPerStep();
            int conflicts = 0;
            for (int64_t t = 0; t < 8; ++t)
                for (int a = 0; a < cells; ++a) {
                    for (int b = 0; b < cells; ++b) {  // same step, spatial neighbours
                        const int d = std::abs(a % gw - b % gw) + std::abs(a / gw - b / gw);
                        if (a != b && d <= gs && m.colourOf(t, a) == m.colourOf(t, b)) ++conflicts;
                    }
                    for (int dt = 1; dt <= gt; ++dt)  // same cell, temporal neighbours
                        if (m.colourOf(t, a) == m.colourOf(t + dt, a)) ++conflicts;
                }
            EXPECT_EQ(conflicts, 0) << "g.space " << gs << ", g.time " << gt << ": " << m.colours() << " colours";
            if (gs == 1 && gt == 1) {
                EXPECT_EQ(m.colours(), 2) << "radius 1: (t + x + y) mod 2";
            }
        }
}

// A limit that refuses the next round stops refinement there, between two
// rounds: the rounds counted are the rounds run, and the tokens counted the
// tokens they refined (on one thread and on workers alike).
TEST(ParallelRefine, AControlStopsBetweenRoundsAndTheRoundsCountedAreTheRoundsRun) {
    struct StopAfter final : RefineControl {
        explicit StopAfter(uint64_t n) : allow(n) {}
        bool beforeRound(uint64_t) noexcept override { return started < allow ? (++started, true) : false; }
        void afterRound(uint64_t tokens) noexcept override {
            ++finished;
            refined += tokens;
        }
        uint64_t allow, started = 0, finished = 0, refined = 0;
    };
    for (const int threads : {1, 3})
        for (const uint64_t allow : {1u, 5u}) {
            Model m(gridConfig(threads, 16));
            for (const auto& f : makeStream(m.config(), 20, 200, 3)) ASSERT_TRUE(m.addObservation(f.words, f.positions).ok());
            const uint64_t before = m.tokensRefined();
            StopAfter stop(allow);
            Sweep sweep(m);
            RefineLimits limits;
            limits.steps = 1000;  // far more than 5 rounds' worth: the control stops it
            limits.control = &stop;
            const RefineCount rc = m.refine(sweep, limits);
            EXPECT_EQ(stop.finished, allow) << threads << " threads";
            EXPECT_EQ(rc.rounds, allow) << threads << " threads";
            EXPECT_EQ(rc.tokens, stop.refined);
            EXPECT_EQ(m.tokensRefined() - before, stop.refined);
            EXPECT_LT(rc.steps, 1000u);
            std::string why;
            EXPECT_TRUE(m.checkInvariants(&why)) << why;
        }
}

TEST(ParallelRefine, ATimeBudgetStopsBetweenRoundsAndCountsThem) {
    EngineConfig ec;
    ec.model = gridConfig(2, 64);
    ec.budget = Budget::time(50.0);
    Engine e(ec);
    for (const auto& f : makeStream(ec.model, 8, 200, 6)) {
        const ObservationResult r = e.processNow(f.view());
        EXPECT_GE(r.rounds, 1u) << "50 ms hold at least a round of one observation's cells";
        EXPECT_GT(r.tokens, 0u);
    }
}

// ---- measurements on the workers (src/core/measure.cpp) -------------------------

// Everything measured along a run, as exact bits (NaN compares too).
struct Measured {
    std::vector<uint64_t> ppx;    // left-out and plug-in nll of the previous step, before each observation
    std::vector<uint32_t> surprise;  // observation and cell surprise (floats)
    std::vector<uint64_t> atEnd;  // every step's nll and perplexities at the end
    std::vector<uint16_t> labels;
    std::vector<uint64_t> words;
    uint64_t measureJobs = 0;  // pool jobs run by the measurements alone
    bool operator==(const Measured& o) const {
        return ppx == o.ppx && surprise == o.surprise && atEnd == o.atEnd && labels == o.labels && words == o.words;
    }
};

void measureLoss(Measured& out, std::vector<uint64_t>& to, const LogLoss& l) {
    to.push_back(std::bit_cast<uint64_t>(l.nll));
    to.push_back(std::bit_cast<uint64_t>(l.perplexity()));
    out.words.push_back(l.words);
}

// Measures a step as the engine does, counting the pool jobs the measurements run.
void measureStep(Model& m, int64_t t, Measured& out, std::vector<uint64_t>& to) {
    const uint64_t jobs = m.poolJobs();
    measureLoss(out, to, m.stepLogLoss(t));
    measureLoss(out, to, m.stepPluginLogLoss(t));
    out.measureJobs += m.poolJobs() - jobs;
}

void measureLabels(Model& m, Measured& out) {
    for (uint64_t f = 0; f < m.observations(); ++f) {
        std::vector<uint16_t> z(m.observationSize(f));
        const uint64_t jobs = m.poolJobs();
        m.observationLabels(f, z);
        out.measureJobs += m.poolJobs() - jobs;
        out.labels.insert(out.labels.end(), z.begin(), z.end());
    }
}

// A synthetic stream of 12 x 12 cells, 20-30 words each (about 3600 words a
// step): every measurement is large enough for the workers.
Measured measuredRun(const syn::Data& d, Config c, int threads) {
    c.threads = threads;
    Model m(c);
    Measured out;
    for (int t = 0; t < d.spec.steps; ++t) {
        if (t > 0) measureStep(m, t - 1, out, out.ppx);
        const uint64_t jobs = m.poolJobs();
        EXPECT_TRUE(m.addObservation(d.words[t], d.positions[t]).ok());
        out.measureJobs += m.poolJobs() - jobs;
        out.surprise.push_back(std::bit_cast<uint32_t>(static_cast<float>(m.observationSurprise(t))));
        for (const float s : m.cellSurprise(t)) out.surprise.push_back(std::bit_cast<uint32_t>(s));
        Sweep sweep(m);
        RefineLimits limits;
        limits.steps = 3;
        m.refine(sweep, limits);
    }
    for (int64_t t = m.oldestStep(); t < m.steps(); ++t) measureStep(m, t, out, out.atEnd);
    measureLabels(m, out);
    return out;
}

syn::Data measureData() {
    syn::Spec s;
    s.K = 6;
    s.steps = 12;
    s.seed = 21;
    return syn::generate(s);
}

TEST(ParallelMeasure, OneTwoThreeThreadsGiveIdenticalPerplexitySurpriseAndLabels) {
    const syn::Data d = measureData();
    Config growing = d.config();
    growing.K = 12;
    growing.grow = true;
    growing.gamma = 0.5;
    for (const Config& c : {d.config(), growing}) {
        const Measured one = measuredRun(d, c, 1);
        EXPECT_EQ(one.measureJobs, 0u) << "one thread: no pool";
        for (const int threads : {2, 3}) {
            const Measured more = measuredRun(d, c, threads);
            EXPECT_TRUE(more == one) << threads << " threads differ from 1 (grow " << c.grow << ")";
            // Every step's two perplexities (before each observation and at the end), the surprise, the labels.
            const uint64_t expected = 2 * (static_cast<uint64_t>(d.spec.steps) - 1) + 2 * d.spec.steps +
                                      static_cast<uint64_t>(d.spec.steps) + static_cast<uint64_t>(d.spec.steps);
            EXPECT_EQ(more.measureJobs, expected) << "every measurement ran on the workers";
        }
    }
}

// Const measurements from two threads at once: one has the workers, the
// other computes serially; both get the serial bits.
TEST(ParallelMeasure, TwoThreadsMeasuringAtOnceGetTheSerialBits) {
    const syn::Data d = measureData();
    Config c = d.config();
    Model serial(c);
    c.threads = 2;
    Model m(c);
    for (int t = 0; t < d.spec.steps; ++t) {
        ASSERT_TRUE(serial.addObservation(d.words[t], d.positions[t]).ok());
        ASSERT_TRUE(m.addObservation(d.words[t], d.positions[t]).ok());
    }
    std::vector<double> want;
    for (int64_t t = 0; t < serial.steps(); ++t) want.push_back(serial.stepPerplexity(t));
    std::atomic<int> wrong{0};
    auto measureAll = [&] {
        for (int rep = 0; rep < 50; ++rep)
            for (int64_t t = 0; t < m.steps(); ++t) {
                const double got = m.stepPerplexity(t), expect = want[static_cast<std::size_t>(t)];
                if (std::bit_cast<uint64_t>(got) != std::bit_cast<uint64_t>(expect)) ++wrong;
            }
    };
    std::thread a(measureAll), b(measureAll);
    a.join();
    b.join();
    EXPECT_EQ(wrong.load(), 0);
    EXPECT_GT(m.poolJobs(), 0u);
    // Labels and samples too, from two threads of different steps at once: their serial path's
    // cache of neighbourhood sums is claimed by one call, the other sums on its own stack.
    // (ThreadSanitizer reported the shared cache as a race before.)
    std::vector<std::vector<uint16_t>> wantLabels, wantSamples;
    for (uint64_t f = 0; f < m.observations(); ++f) {
        std::vector<uint16_t> l(m.observationSize(f)), z(m.observationSize(f));
        serial.observationLabels(f, l);
        m.observationSamples(f, z);
        wantLabels.push_back(std::move(l));
        wantSamples.push_back(std::move(z));
    }
    auto labelAll = [&](uint64_t first) {
        std::vector<uint16_t> l, z;
        for (int rep = 0; rep < 30; ++rep)
            for (uint64_t i = 0; i < m.observations(); ++i) {
                const uint64_t f = (first + i) % m.observations();
                l.assign(m.observationSize(f), 0);
                z.assign(m.observationSize(f), 0);
                m.observationLabels(f, l);
                m.observationSamples(f, z);
                if (l != wantLabels[f] || z != wantSamples[f]) ++wrong;
            }
    };
    std::thread c1(labelAll, 0), c2(labelAll, m.observations() / 2);
    c1.join();
    c2.join();
    EXPECT_EQ(wrong.load(), 0);
}

// The workers' grouping scratch lies in one buffer, a stride each: every word
// a worker uses lies inside its own stride, which starts on a cache line
// (the overlap a stride one word short makes is a race the test below sees
// only at times, and only when (cells + max.words) is a multiple of 8).
TEST(ParallelMeasure, EachWorkersGroupingScratchFitsItsStride) {
    for (std::size_t cells = 1; cells <= 96; ++cells)
        for (std::size_t maxWords = 1; maxWords <= 96; ++maxWords) {
            const std::size_t stride = detail::measureGroupStride(cells, maxWords);
            ASSERT_GE(stride, (cells + 1) + cells + maxWords + maxWords) << cells << " cells, max.words " << maxWords;
            ASSERT_EQ(stride % 16, 0u) << cells << " cells, max.words " << maxWords;
            ASSERT_LT(stride, (cells + 1) + cells + maxWords + maxWords + 16) << "more than a line's rounding";
        }
}

// The final pass's measurements of many observations at once (a task an
// observation on the workers): each observation's step perplexity and
// labels are the bits stepPerplexity and observationLabels give one at a
// time, on one thread or several, with several observations a step (the
// step's perplexity computed once and copied), with growth, on a word
// stream (steps of one cell, which the per-cell measurements leave
// serial), and with a stride shorter than an observation (its first labels
// only, the rest of the buffer untouched). One pool job a call.
TEST(ParallelMeasure, FinalMeasurementsOfManyObservationsGiveTheSerialBits) {
    const syn::Data d = measureData();
    Config twoPerStep = d.config();
    twoPerStep.cell_time = 2;
    Config growing = d.config();
    growing.K = 12;
    growing.grow = true;
    growing.gamma = 0.5;
    Config oneCell = d.config();  // a word stream: a step is one cell
    oneCell.frame_width = 1;
    oneCell.frame_height = 1;
    oneCell.cell_capacity = 4096;
    Config full = d.config();  // observations of exactly max.words inputs: the measure's buffers to their last word
    full.max_words_per_frame = static_cast<int>(
        std::min_element(d.words.begin(), d.words.end(), [](const auto& a, const auto& b) { return a.size() < b.size(); })
            ->size());
    // And (cells + max.words) a multiple of 8: a worker's grouping scratch
    // (2 cells + 1 + 2 max.words words) then leaves 15 words of its 16-word
    // rounding, and a stride one word short would run into the next worker's.
    Config edge = full;
    edge.max_words_per_frame -= (Model(edge).cellsPerStep() + edge.max_words_per_frame) % 8;
    ASSERT_GT(edge.max_words_per_frame, 0);
    for (const Config& base : {d.config(), twoPerStep, growing, oneCell, full, edge}) {
        std::vector<uint64_t> reference;  // one thread, one measurement at a time
        for (const int threads : {1, 2, 3}) {
            Config c = base;
            c.threads = threads;
            Model m(c);
            for (int t = 0; t < d.spec.steps; ++t) {
                const std::vector<Position> atOrigin(d.words[t].size());
                ASSERT_TRUE(m.addObservation(d.words[t], c.frame_width == 1 ? atOrigin : d.positions[t]).ok());
                Sweep sweep(m);
                RefineLimits limits;
                limits.steps = 2;
                m.refine(sweep, limits);
            }
            const uint64_t first = 1, count = m.observations() - 1;
            for (const std::size_t stride : {std::size_t{4096}, std::size_t{50}}) {
                std::vector<uint64_t> one;  // one measurement at a time, on this model
                for (uint64_t f = first; f < first + count; ++f) {
                    one.push_back(std::bit_cast<uint64_t>(m.stepPerplexity(m.stepOfObservation(f))));
                    std::vector<uint16_t> z(std::min<std::size_t>(stride, m.observationSize(f)));
                    ASSERT_LT(z.size(), 4096u);
                    m.observationLabels(f, z);
                    one.insert(one.end(), z.begin(), z.end());
                }
                std::vector<double> ppx(count, -1.0);
                std::vector<uint16_t> labels(count * stride, 0xBEEF);
                const uint64_t jobs = m.poolJobs();
                m.finalMeasurements(first, ppx, labels, stride);
                EXPECT_EQ(m.poolJobs() - jobs, threads > 1 ? 1u : 0u) << threads << " threads";
                std::vector<uint64_t> batch;
                for (uint64_t i = 0; i < count; ++i) {
                    batch.push_back(std::bit_cast<uint64_t>(ppx[i]));
                    const std::size_t n = std::min<std::size_t>(stride, m.observationSize(first + i));
                    batch.insert(batch.end(), labels.begin() + static_cast<std::ptrdiff_t>(i * stride),
                                 labels.begin() + static_cast<std::ptrdiff_t>(i * stride + n));
                    for (std::size_t j = n; j < stride; ++j) ASSERT_EQ(labels[i * stride + j], 0xBEEF) << "past the labels";
                }
                EXPECT_EQ(batch, one) << threads << " threads, stride " << stride << ", cell.time " << c.cell_time
                                      << ", grow " << c.grow;
                if (stride == 4096) {
                    if (threads == 1) reference = one;
                    EXPECT_EQ(one, reference) << threads << " threads against one";
                }
            }
        }
    }
}

// A batch that starts at a step's first observation (cell.time 2, from
// observation 0): on the workers each step's perplexity is computed by the
// task of its first observation and copied to the next, so the second
// observation of the batch's first step gets it too, not what the span held.
TEST(ParallelMeasure, FinalMeasurementsFromAStepsFirstObservationGiveEveryOneItsStepsPerplexity) {
    const syn::Data d = measureData();
    Config c = d.config();
    c.cell_time = 2;
    c.threads = 2;
    Model m(c);
    for (int t = 0; t < d.spec.steps; ++t) ASSERT_TRUE(m.addObservation(d.words[t], d.positions[t]).ok());
    const auto count = static_cast<std::size_t>(m.observations());
    const std::size_t stride = 4096;
    std::vector<double> ppx(count, -1.0);
    std::vector<uint16_t> labels(count * stride, 0);
    const uint64_t jobs = m.poolJobs();
    m.finalMeasurements(0, ppx, labels, stride);
    ASSERT_EQ(m.poolJobs() - jobs, 1u) << "on the workers";
    for (std::size_t f = 0; f < count; ++f)
        EXPECT_EQ(std::bit_cast<uint64_t>(ppx[f]), std::bit_cast<uint64_t>(m.stepPerplexity(m.stepOfObservation(f))))
            << "observation " << f << ": " << ppx[f];
}

// A batch larger than a pool job can hold (2^16 observations a part): the
// same perplexities and labels as one at a time, across the parts' edges.
TEST(ParallelMeasure, FinalMeasurementsOfMoreObservationsThanAJobHolds) {
    Config c = streamConfig(2, 64);
    c.V = 50;
    c.K = 4;
    c.cell_capacity = 4;
    c.max_words_per_frame = 4;
    c.ring_steps = 70000;
    Model m(c);
    uint64_t x = 99;
    for (int t = 0; t < c.ring_steps; ++t) {
        std::vector<uint32_t> w(3);
        for (auto& v : w) v = static_cast<uint32_t>((x = x * 6364136223846793005ULL + 1) >> 59) % 50;
        ASSERT_TRUE(m.addObservation(w, std::vector<Position>(3)).ok());
    }
    const std::size_t count = static_cast<std::size_t>(c.ring_steps), stride = 4;
    std::vector<double> ppx(count);
    std::vector<uint16_t> labels(count * stride, 0xBEEF);
    const uint64_t jobs = m.poolJobs();
    m.finalMeasurements(0, ppx, labels, stride);
    EXPECT_EQ(m.poolJobs() - jobs, 2u) << "two parts";
    std::vector<uint16_t> z(3);
    for (std::size_t f = 0; f < count; f += f < 65530 || f > 65540 ? 997 : 1) {
        ASSERT_EQ(std::bit_cast<uint64_t>(ppx[f]), std::bit_cast<uint64_t>(m.stepPerplexity(static_cast<int64_t>(f)))) << f;
        m.observationLabels(f, z);
        ASSERT_TRUE(std::equal(z.begin(), z.end(), labels.begin() + static_cast<std::ptrdiff_t>(f * stride))) << f;
        ASSERT_EQ(labels[f * stride + 3], 0xBEEF) << f;
    }
}

// Small work stays on the calling thread: a word stream's step (one cell)
// and a step of fewer than 256 words.
TEST(ParallelMeasure, SmallStepsAndOneCellAreMeasuredSerially) {
    for (const auto make : {&gridConfig, &streamConfig}) {
        Model m(make(3, 64));
        for (const auto& f : makeStream(m.config(), 4, make == &gridConfig ? 200 : 2000, 8))
            ASSERT_TRUE(m.addObservation(f.words, f.positions).ok());
        std::vector<uint16_t> z(m.observationSize(3));
        m.observationLabels(3, z);
        EXPECT_GT(m.stepLogLoss(3).words, 0u);
        EXPECT_GT(m.stepPluginLogLoss(3).words, 0u);
        EXPECT_EQ(m.poolJobs(), 0u);
    }
}

// Every task of a job runs exactly once, whichever thread claims it, also
// with more threads than cores; a parked pool wakes for the next job.
struct CountJob final : detail::WorkerPool::Job {
    std::vector<std::atomic<uint32_t>> runs = std::vector<std::atomic<uint32_t>>(64);
    std::atomic<uint64_t> mask{0};
    void task(int worker, uint32_t index) noexcept override {
        runs[index].fetch_add(1, std::memory_order_relaxed);
        mask.fetch_or(uint64_t{1} << worker, std::memory_order_relaxed);
        volatile double x = 1.0;  // a little work, so other workers get tasks too
        for (int i = 0; i < 2000; ++i) x = x * 1.0000001;
    }
};

// Pinned workers (thread.cpu = C): worker N on CPU (C - N) modulo the
// machine's CPUs, the CPUs below the refiner's, wrapping round.
TEST(WorkerPool, PinnedWorkersTakeTheCpusBelowTheRefinersOwn) {
    using detail::WorkerPool;
    EXPECT_EQ(WorkerPool::workerCpu(5, 1, 8), 4);
    EXPECT_EQ(WorkerPool::workerCpu(5, 3, 8), 2);
    EXPECT_EQ(WorkerPool::workerCpu(1, 2, 8), 7);
    EXPECT_EQ(WorkerPool::workerCpu(0, 9, 8), 7);
    EXPECT_EQ(WorkerPool::workerCpu(3, 0, 4), 3);
    EXPECT_EQ(WorkerPool::workerCpu(3, 1, 0), -1) << "no CPU count: left unpinned";
}

// And the threads are where it says: each worker's affinity is its one CPU.
struct AffinityJob final : detail::WorkerPool::Job {
    std::atomic<int> cpuOf[3] = {-2, -2, -2};  // -2: took no task; -1: not pinned to one CPU
    void task(int worker, uint32_t) noexcept override {
        cpu_set_t set;
        CPU_ZERO(&set);
        int seen = -1;
        if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) == 1)
            for (int c = 0; c < CPU_SETSIZE; ++c)
                if (CPU_ISSET(c, &set)) seen = c;
        cpuOf[worker].store(seen);
        std::this_thread::sleep_for(std::chrono::milliseconds(1));  // room for every worker to take one
    }
};

TEST(WorkerPool, PinnedWorkersRunOnTheirCpus) {
    const int n = static_cast<int>(std::thread::hardware_concurrency());
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
    if (n < 2 || CPU_COUNT(&allowed) < n) GTEST_SKIP() << "needs every CPU of the machine";
    detail::WorkerPool pool(3);
    ThreadSettings s;
    s.cpu = n - 1;
    pool.applySettings(s);
    AffinityJob job;
    for (int i = 0; i < 200 && (job.cpuOf[1].load() == -2 || job.cpuOf[2].load() == -2); ++i) pool.run(job, 16);
    for (int w = 1; w < 3; ++w)
        EXPECT_EQ(job.cpuOf[w].load(), detail::WorkerPool::workerCpu(n - 1, w, n)) << "worker " << w;
}

TEST(WorkerPool, EveryTaskRunsExactlyOnceAlsoWithMoreThreadsThanCores) {
    detail::WorkerPool pool(8);
    CountJob job;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < 1000; ++i) pool.run(job, 64);
    for (const auto& r : job.runs) EXPECT_EQ(r.load(), 1000u);
    EXPECT_EQ(pool.jobs(), 1000u);
    EXPECT_GT(std::popcount(job.mask.load()), 1) << "the workers took part";
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(60)) << "the barrier should not livelock";
    // Idle long enough to park, then wake for another job; a job of one task and of none.
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    pool.run(job, 64);
    pool.run(job, 1);
    pool.run(job, 0);
    EXPECT_EQ(job.runs[0].load(), 1002u);
    EXPECT_EQ(job.runs[63].load(), 1001u);
}

// A job of 2^20 tasks or more (a range's fields hold 20 bits): every task
// still runs exactly once, and the job ends. Before, a 1024 x 1024 grid of
// 1-pixel cells (2^20 cells, which the settings allow) hung its first
// measurement for good on two threads.
struct ManyJob final : detail::WorkerPool::Job {
    explicit ManyJob(std::size_t n) : runs(n) {}
    std::vector<std::atomic<uint8_t>> runs;
    std::atomic<int> begins[3] = {};
    std::atomic<int> unbegun{0};  // tasks run by a worker before its begin()
    void begin(int worker) noexcept override { begins[worker].fetch_add(1, std::memory_order_relaxed); }
    void task(int worker, uint32_t index) noexcept override {
        if (begins[worker].load(std::memory_order_relaxed) == 0) unbegun.fetch_add(1, std::memory_order_relaxed);
        runs[index].fetch_add(1, std::memory_order_relaxed);
    }
};

// A job of 2^20 tasks or more runs in parts: each task once, each worker's
// begin() once and before its tasks, with or without cuts (a 1024 x 1024
// grid of 1-pixel cells hung its first measurement when a range's 20 bits
// wrapped).
TEST(WorkerPool, AJobOfAMillionTasksOrMoreRunsEachOnceAndEnds) {
    for (const bool withCuts : {false, true}) {
        for (const uint32_t count : {(1u << 20) - 1, 1u << 20, (1u << 20) + 3, 3u << 20}) {
            SCOPED_TRACE(std::to_string(count) + (withCuts ? " with cuts" : ""));
            // Two jobs on one pool (the second's begin() is its own), with
            // uneven own ranges: a fifth, a half, the rest.
            auto a = std::make_shared<ManyJob>(count), b = std::make_shared<ManyJob>(count);
            const std::array<uint32_t, 4> cuts{0, count / 5, count / 5 + count / 2, count};
            const bool ended = rost::testing::endsWithin(std::chrono::seconds(60), [a, b, count, withCuts, cuts] {
                detail::WorkerPool pool(3);
                pool.run(*a, count, withCuts ? cuts.data() : nullptr);
                pool.run(*b, count, withCuts ? cuts.data() : nullptr);
                EXPECT_EQ(pool.jobs(), 2u);
            });
            if (!ended) rost::testing::endTheRun("a job of " + std::to_string(count) + " tasks did not end in 60 s");
            for (const auto& job : {a, b}) {
                std::size_t wrong = 0;
                for (const auto& r : job->runs) wrong += r.load() != 1 ? 1 : 0;
                EXPECT_EQ(wrong, 0u) << "tasks not run exactly once";
                EXPECT_EQ(job->unbegun.load(), 0) << "tasks run before their worker's begin()";
                for (int w = 0; w < 3; ++w) EXPECT_LE(job->begins[w].load(), 1) << "worker " << w;
                EXPECT_EQ(job->begins[0].load(), 1) << "the caller runs tasks of its own range";
            }
        }
    }
    // The grid of 2^20 cells itself, measured on two threads.
    Config c;
    c.V = 50;
    c.K = 4;
    c.frame_width = c.frame_height = 1024;
    c.cell_space = 1;
    c.cell_capacity = 1;
    c.ring_steps = 2;
    c.threads = 2;
    auto m = std::make_shared<Model>(c);
    const bool ended = rost::testing::endsWithin(std::chrono::seconds(120), [m] {
        std::vector<uint32_t> w(300);
        std::vector<Position> p(300);
        for (int i = 0; i < 300; ++i) {
            w[static_cast<std::size_t>(i)] = static_cast<uint32_t>(i % 50);
            p[static_cast<std::size_t>(i)] = {i * 3, i * 2};
        }
        EXPECT_TRUE(m->addObservation(w, p).ok());
        EXPECT_TRUE(std::isfinite(m->observationSurprise(0)));
    });
    if (!ended) rost::testing::endTheRun("an observation on a grid of 2^20 cells, two threads, did not end in 120 s");
}

// A job that takes pairs (src/core/kernel_pair.hpp): an owner claims the
// tasks of its own range two at a time, thieves one; every task still runs
// exactly once, a pair is always two neighbouring tasks of one owner's range,
// and both ways of running a task happen. With one worker the tasks go in
// turn, in pairs but for an odd last one.
struct PairCountJob final : detail::WorkerPool::Job {
    std::vector<std::atomic<uint32_t>> runs = std::vector<std::atomic<uint32_t>>(61);
    std::vector<uint32_t> cuts;
    std::atomic<uint32_t> pairRuns{0}, singleRuns{0}, pairsAcrossRanges{0};
    PairCountJob() { pairs = true; }
    void work() const noexcept {
        volatile double x = 1.0;
        for (int i = 0; i < 2000; ++i) x = x * 1.0000001;
    }
    void task(int /*worker*/, uint32_t index) noexcept override {
        runs[index].fetch_add(1, std::memory_order_relaxed);
        singleRuns.fetch_add(1, std::memory_order_relaxed);
        work();
    }
    void taskPair(int /*worker*/, uint32_t index) noexcept override {
        runs[index].fetch_add(1, std::memory_order_relaxed);
        runs[index + 1].fetch_add(1, std::memory_order_relaxed);
        pairRuns.fetch_add(1, std::memory_order_relaxed);
        for (std::size_t w = 1; w + 1 < cuts.size(); ++w)
            if (index + 1 == cuts[w]) pairsAcrossRanges.fetch_add(1, std::memory_order_relaxed);
        work();
        work();
    }
};

// Runs f; past the deadline (a job the pool never ends: a claim past a
// range's end leaves its count short) the test binary fails at once instead
// of waiting for ctest's limit. f owns what it uses (test_deadline.hpp).
template <typename F>
void withinDeadline(F f, std::chrono::seconds limit) {
    if (!rost::testing::endsWithin(limit, std::move(f)))
        rost::testing::endTheRun("the pool's jobs did not end within " + std::to_string(limit.count()) + " s");
}

TEST(WorkerPool, PairsAreClaimedWithinARangeAndEveryTaskStillRunsOnce) {
    detail::WorkerPool pool(4);
    PairCountJob job;
    job.cuts = {0, 13, 30, 31, 61};  // ranges of odd, even and single sizes
    withinDeadline([&] {
        for (int i = 0; i < 500; ++i) pool.run(job, 61, job.cuts.data());
    }, std::chrono::seconds(120));
    for (const auto& r : job.runs) EXPECT_EQ(r.load(), 500u);
    EXPECT_EQ(job.pairsAcrossRanges.load(), 0u) << "a pair never spans two owners' ranges";
    EXPECT_GT(job.pairRuns.load(), 0u);
    EXPECT_GT(job.singleRuns.load(), 0u) << "the odd ends and thieves run single tasks";
    EXPECT_EQ(2 * job.pairRuns.load() + job.singleRuns.load(), 500u * 61u);

    PairCountJob alone;
    detail::WorkerPool one(1);
    one.run(alone, 7);
    for (uint32_t i = 0; i < 7; ++i) EXPECT_EQ(alone.runs[i].load(), 1u);
    EXPECT_EQ(alone.pairRuns.load(), 3u);
    EXPECT_EQ(alone.singleRuns.load(), 1u);
}

} // namespace
} // namespace rost
