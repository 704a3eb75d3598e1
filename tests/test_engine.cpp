// The engine in synchronous mode and its parts: configuration, budgets,
// determinism, hooks, snapshots, drop policies, thread settings, replay.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "rost/engine.hpp"
#include "observation_queue.hpp"
#include "spsc_ring.hpp"
#include "predictor.hpp"
#include "realtime_log.hpp"
#include "rost/realtime.hpp"
#include "rost/replay.hpp"
#include "test_engine_support.hpp"

namespace rost {
namespace {

using rost::testing::Frame;
using rost::testing::makeStream;
using rost::testing::smallConfig;

EngineConfig engineConfig(Budget b, StrategyKind k = StrategyKind::UniformNow) {
    EngineConfig e;
    e.model = smallConfig();
    e.budget = b;
    e.strategy.kind = k;
    e.queue_slots = 4;
    return e;
}

WordStream toStream(const std::vector<Frame>& frames) {
    WordStream s;
    s.has_positions = true;
    for (const Frame& f : frames) s.observations.push_back({f.timestamp, f.words, f.positions});
    return s;
}

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

ReplayResult replayOf(const EngineConfig& cfg, const std::vector<Frame>& frames, bool threaded, int sweeps = 0) {
    Engine engine(cfg);
    ReplayResult r;
    ReplayOptions o;
    o.threaded = threaded;
    o.final_sweeps = sweeps;
    const Status s = replay(engine, toStream(frames), o, r);
    EXPECT_TRUE(s.ok()) << s.message();
    std::string why;
    EXPECT_TRUE(engine.model().checkInvariants(&why)) << why;
    return r;
}

// Compares two replays bit for bit; returns how many observations differ.
int differences(const ReplayResult& a, const ReplayResult& b) {
    int diff = 0;
    EXPECT_EQ(a.observations.size(), b.observations.size());
    for (std::size_t i = 0; i < a.observations.size() && i < b.observations.size(); ++i) {
        const auto& x = a.observations[i];
        const auto& y = b.observations[i];
        if (x.labels != y.labels || !sameBits(x.final_perplexity, y.final_perplexity) ||
            !sameBits(x.instantaneous_perplexity, y.instantaneous_perplexity) || !sameBits(x.surprise, y.surprise))
            ++diff;
    }
    return diff;
}

// ---- configuration -------------------------------------------------------------

TEST(EngineConfig, ValidateNamesTheOffendingField) {
    auto messageOf = [](auto edit) {
        EngineConfig c;
        edit(c);
        return c.validate().message();
    };
    // The schema's keys and ranges, by its one check (rost/settings.hpp).
    EXPECT_EQ(messageOf([](EngineConfig& c) { c.queue_slots = 0; }), "invalid configuration: queue.slots = 0, allowed [1, 65536]");
    EXPECT_EQ(messageOf([](EngineConfig& c) { c.budget = Budget::time(0.0); }),
              "invalid configuration: budget.ms = 0, allowed (0, 3600000]");
    EXPECT_EQ(messageOf([](EngineConfig& c) { c.strategy.eta = 2.0; }), "invalid configuration: eta = 2, allowed [0, 1]");
    EXPECT_EQ(messageOf([](EngineConfig& c) { c.drop = static_cast<DropPolicy>(7); }),
              "invalid configuration: drop = 7, allowed newest|oldest");
    EXPECT_NE(messageOf([](EngineConfig& c) {
                  c.thread.fifo = true;
                  c.thread.priority = 0;
              }).find("thread.priority"),
              std::string::npos);
    EXPECT_NE(messageOf([](EngineConfig& c) { c.thread.cpu = 5000; }).find("thread.cpu"), std::string::npos);
    EXPECT_FALSE(messageOf([](EngineConfig& c) { c.model.K = 0; }).empty());
    EXPECT_TRUE(EngineConfig{}.validate().ok());
}

TEST(EngineConfig, CreateReturnsNullWithTheMessageAndTheConstructorThrows) {
    EngineConfig c;
    c.queue_slots = -3;
    Status s;
    EXPECT_EQ(Engine::create(c, s), nullptr);
    EXPECT_NE(s.message().find("queue.slots = -3"), std::string::npos) << s.message();
    EXPECT_THROW(Engine{c}, std::invalid_argument);
}

// Valid settings whose tables do not fit in memory: a message naming the
// settings the tables grow with, not "std::bad_alloc". In a child process
// limited to 1 GiB of address space (not under the sanitizers, whose shadow
// memory needs more).
#if !defined(__SANITIZE_THREAD__) && !defined(__SANITIZE_ADDRESS__)
// Engine::create's message for `c` in a child process limited to 1 GiB of
// address space; "unenforced" where the limit is not (an emulator).
std::string createMessageIn1GiB(const EngineConfig& c) {
    int fds[2];
    if (::pipe(fds) != 0) return "no pipe";
    const pid_t pid = ::fork();
    if (pid < 0) return "no fork";
    if (pid == 0) {
        ::close(fds[0]);
        const rlimit lim{1ul << 30, 1ul << 30};
        ::setrlimit(RLIMIT_AS, &lim);
        // Where the limit is not enforced (an emulator such as qemu-user maps
        // for the guest), a 2 GiB mapping succeeds: the test cannot run there.
        void* probe = ::mmap(nullptr, 2ul << 30, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        std::string msg = "unenforced";
        if (probe == MAP_FAILED) {
            Status st;
            msg = Engine::create(c, st) != nullptr ? std::string("made") : st.message();
        }
        (void)!::write(fds[1], msg.data(), msg.size());
        ::_exit(0);
    }
    ::close(fds[1]);
    std::string msg;
    char buf[512];
    for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) msg.append(buf, static_cast<std::size_t>(n));
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the child ended otherwise: " << status;
    return msg;
}
#endif

TEST(EngineConfig, TablesThatDoNotFitInMemoryAreRefusedNamingTheirSettings) {
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "an address-space limit and a sanitizer's shadow memory do not mix";
#else
    EngineConfig c;
    c.model.K = 1024;
    c.model.V = 1000000;  // n_kv alone is 4 GB
    ASSERT_TRUE(c.validate().ok());
    std::string msg = createMessageIn1GiB(c);
    if (msg == "unenforced") GTEST_SKIP() << "an address-space limit is not enforced here (an emulator)";
    EXPECT_EQ(msg, "engine: not enough memory for the model's tables: " + c.model.tablesText() + ", queue.slots = 8" +
                       "; lower one of them");
    EXPECT_NE(msg.find("K = 1024, V = 1000000, ring.steps = "), std::string::npos) << msg;
    // A queue of many slots, each max.words words (12 bytes a word), is
    // what does not fit: named too.
    EngineConfig q;
    q.queue_slots = 65536;
    q.model.max_words_per_frame = 4194304;
    ASSERT_TRUE(q.validate().ok());
    msg = createMessageIn1GiB(q);
    EXPECT_NE(msg.find("max.words = 4194304, queue.slots = 65536; lower one of them"), std::string::npos) << msg;
#endif
}

TEST(EngineConfig, DropPolicyNamesParseAndUnknownOnesAreRejected) {
    DropPolicy p = DropPolicy::DropOldest;
    ASSERT_TRUE(parseDropPolicy("newest", p).ok());
    EXPECT_EQ(p, DropPolicy::DropNewest);
    ASSERT_TRUE(parseDropPolicy(toString(DropPolicy::DropOldest), p).ok());
    EXPECT_EQ(p, DropPolicy::DropOldest);
    EXPECT_NE(parseDropPolicy("latest", p).message().find("'latest'"), std::string::npos);
}

// ---- memory -------------------------------------------------------------------

TEST(EngineMemory, IsReportedBeforeStartAndDoesNotGrow) {
    EngineConfig c = engineConfig(Budget::steps(2));
    c.queue_slots = 8;
    Engine e(c);
    const EngineMemory m = e.memory();
    EXPECT_EQ(m.model, e.model().memoryBytes());
    const std::size_t maxw = static_cast<std::size_t>(c.model.max_words_per_frame);
    EXPECT_GE(m.queue, 8 * maxw * (sizeof(uint32_t) + sizeof(Position)));
    EXPECT_GE(m.snapshot, 3 * maxw * (sizeof(uint16_t) + sizeof(uint32_t) + sizeof(Position)));  // 2 buffers + staging
    EXPECT_EQ(e.memoryBytes(), m.model + m.queue + m.snapshot + m.other);
    for (const Frame& f : makeStream(c.model, 100, 300, 1)) e.processNow(f.view());
    EXPECT_EQ(e.memoryBytes(), m.total());
}

// ---- budgets ------------------------------------------------------------------

// The time budget's cost predictor: a first round preempted (a sample a
// thousand times the true cost) must not set a cost no round ever fits again,
// for then no round runs and no later sample corrects it.
TEST(EngineBudget, APreemptedFirstRoundCannotStopRefinementForGood) {
    using detail::robustAverage;
    const double prior = 40.0, truth = 40.0;
    uint64_t samples = 0;
    double avg = robustAverage(prior, 1000.0 * truth, 0.05, samples);
    EXPECT_EQ(avg, 8.0 * prior) << "the first sample is kept within 8 times the prior";
    int rounds = 0;
    while (avg > 2.0 * truth && rounds < 1000) avg = robustAverage(avg, truth, 0.05, samples), ++rounds;
    EXPECT_EQ(rounds, 55) << "true samples bring it within 2 times of the truth";
    // A first sample far below the prior (a slower board's prior is far too low the other way round).
    samples = 0;
    avg = robustAverage(prior, prior / 1000.0, 0.05, samples);
    EXPECT_EQ(avg, prior / 8.0);
    // A true cost 64 times the prior (an emulated board): the first sample gives 8 times the prior,
    // and the 3-times clamp catches up within 2 times of the truth in 16 rounds.
    samples = 0;
    avg = robustAverage(prior, 64.0 * prior, 0.05, samples);
    EXPECT_EQ(avg, 8.0 * prior);
    for (rounds = 0; avg < 32.0 * prior && rounds < 1000; ++rounds) avg = robustAverage(avg, 64.0 * prior, 0.05, samples);
    EXPECT_EQ(rounds, 16);
    // After the first, one outlier moves the average by a bounded step.
    const double before = avg;
    EXPECT_NEAR(robustAverage(before, 1e9, 0.05, samples), before * 1.1, 1e-9 * before);
    EXPECT_NEAR(robustAverage(before, 0.0, 0.05, samples), before * 0.975, 1e-9 * before);
}

TEST(EngineBudget, StepBudgetRefinesExactlyRTimeStepsPerObservation) {
    Engine e(engineConfig(Budget::steps(3)));
    const auto frames = makeStream(e.config().model, 40, 200, 2);
    for (const Frame& f : frames) {
        const ObservationResult r = e.processNow(f.view());
        ASSERT_TRUE(r.add.ok());
        EXPECT_EQ(r.refinements, 3u);
    }
    const EngineCounters c = e.counters();
    EXPECT_EQ(c.refinements, 3u * frames.size());
    EXPECT_EQ(c.tokens, e.model().tokensRefined());
    EXPECT_EQ(c.ingested, frames.size());
}

TEST(EngineBudget, TokenBudgetRefinesAtLeastCountTokensAndAtMostOneCellMore) {
    EngineConfig c = engineConfig(Budget::tokens(100));
    Engine e(c);
    for (const Frame& f : makeStream(c.model, 30, 200, 3)) {
        const ObservationResult r = e.processNow(f.view());
        EXPECT_GE(r.tokens, 100u);
        EXPECT_LT(r.tokens, 100u + static_cast<uint64_t>(c.model.cell_capacity));
    }
}

TEST(EngineBudget, TokenBudgetEndsOnAWindowWithoutWords) {
    Engine e(engineConfig(Budget::tokens(1000)));
    const ObservationResult r = e.processNow({0, {}, {}});  // an empty frame
    EXPECT_TRUE(r.add.ok());
    EXPECT_EQ(r.tokens, 0u);
    EXPECT_LE(r.refinements, 1000u);
}

TEST(EngineBudget, RefineExtraAndFinalPassSpendMoreWithoutNewObservations) {
    Engine e(engineConfig(Budget::steps(1)));
    for (const Frame& f : makeStream(e.config().model, 20, 100, 4)) e.processNow(f.view());
    const uint64_t before = e.model().tokensRefined();
    EXPECT_EQ(e.refineExtra(Budget::steps(5)), 5u);
    const uint64_t afterExtra = e.model().tokensRefined();
    EXPECT_GT(afterExtra, before);
    EXPECT_EQ(e.finalPass(2), 2 * 16 * 100u);  // two sweeps over the 16 steps in the ring
    EXPECT_GT(e.model().tokensRefined(), afterExtra);
    std::string why;
    EXPECT_TRUE(e.model().checkInvariants(&why)) << why;
}

// ---- determinism ----------------------------------------------------------------

TEST(EngineDeterminism, SameSeedStreamAndCountBudgetGiveIdenticalLabelsOnTwoRunsForEveryStrategy) {
    for (StrategyKind k : {StrategyKind::Now, StrategyKind::Uniform, StrategyKind::AgeProportional,
                           StrategyKind::Exponential, StrategyKind::UniformNow, StrategyKind::AgeProportionalNow,
                           StrategyKind::UniformExponential, StrategyKind::AgeProportionalExponential}) {
        const EngineConfig c = engineConfig(Budget::steps(2), k);
        const auto frames = makeStream(c.model, 40, 150, 5);
        const ReplayResult a = replayOf(c, frames, false);
        const ReplayResult b = replayOf(c, frames, false);
        EXPECT_EQ(differences(a, b), 0) << toString(k);
    }
}

TEST(EngineDeterminism, ADifferentSeedGivesDifferentLabels) {
    EngineConfig c = engineConfig(Budget::steps(2));
    const auto frames = makeStream(c.model, 40, 150, 5);
    const ReplayResult a = replayOf(c, frames, false);
    c.model.seed += 1;
    const ReplayResult b = replayOf(c, frames, false);
    EXPECT_GT(differences(a, b), 20);
}

TEST(EngineDeterminism, ThreadedReplayMatchesSynchronousBitForBitUnderStepAndTokenBudgets) {
    for (const Budget budget : {Budget::steps(3), Budget::tokens(500)}) {
        EngineConfig c = engineConfig(budget, StrategyKind::AgeProportionalExponential);
        c.model.cell_time = 2;
        c.queue_slots = 2;  // the producer waits on the refiner often
        const auto frames = makeStream(c.model, 80, 150, 6);
        const ReplayResult sync = replayOf(c, frames, false, 1);
        const ReplayResult threaded = replayOf(c, frames, true, 1);
        EXPECT_EQ(differences(sync, threaded), 0);
        EXPECT_EQ(threaded.counters.dropped(), 0u);
        EXPECT_EQ(threaded.counters.ingested, frames.size());
        EXPECT_EQ(sync.counters.tokens, threaded.counters.tokens);
    }
}

// What a rejected observation's error says, each its own words.
TEST(EngineInput, EachAddErrorHasItsOwnText) {
    EXPECT_STREQ(toString(AddError::None), "ok");
    EXPECT_STREQ(toString(AddError::SizeMismatch), "words and positions (or the given labels) differ in length");
    EXPECT_STREQ(toString(AddError::WordOutOfRange), "word id out of range");
    EXPECT_STREQ(toString(AddError::PositionOutOfRange), "position outside the frame");
    EXPECT_STREQ(toString(AddError::LabelOutOfRange), "initial label out of range");
}

// processNow is synchronous mode's: on a running engine it processes and
// queues nothing, and says so by step -1 without an error of the model's.
TEST(EngineSync, ProcessNowOnARunningEngineTakesNothing) {
    Engine e(engineConfig(Budget::steps(1)));
    const auto frames = makeStream(e.config().model, 2, 40, 3);
    ASSERT_TRUE(e.start().ok());
    const ObservationResult r = e.processNow(frames[0].view());
    EXPECT_EQ(r.step, -1);
    EXPECT_TRUE(r.add.ok());
    EXPECT_EQ(e.queued(), 0u);
    e.stop();
    EXPECT_EQ(e.counters().ingested, 0u);
    EXPECT_EQ(e.processNow(frames[1].view()).step, 0);  // stopped: synchronous mode again
}

// ---- hooks and perplexity --------------------------------------------------------

TEST(EngineHooks, EvictionHookSeesEveryObservationOnceWhileStillInTheWindow) {
    EngineConfig c = engineConfig(Budget::steps(1));
    c.model.cell_time = 2;
    c.model.ring_steps = 5;
    Engine e(c);
    std::vector<int> seen;
    e.setEvictionHook([&](const WindowObservation& w, const Model& m) {
        EXPECT_TRUE(m.observationInWindow(w.observation)) << w.observation;
        EXPECT_EQ(w.step, m.stepOfObservation(w.observation));
        EXPECT_EQ(w.sequence, w.observation);  // nothing dropped or rejected here
        EXPECT_EQ(w.timestamp, 1000 + 40 * static_cast<int64_t>(w.observation));
        EXPECT_EQ(seen.size(), w.observation) << "in order";
        seen.push_back(static_cast<int>(w.observation));
    });
    const auto frames = makeStream(c.model, 71, 60, 7);
    for (std::size_t i = 0; i < 51; ++i) e.processNow(frames[i].view());
    EXPECT_EQ(seen.size(), 51u - 9u);  // the last 4 full steps and the newest half step remain
    e.flushWindowToEvictionHook();
    ASSERT_EQ(seen.size(), 51u);
    // Observations added after a flush: those flushed do not come again as
    // they leave the ring (the hook's "in order" check sees a second visit),
    // nor at a second flush.
    for (std::size_t i = 51; i < frames.size(); ++i) e.processNow(frames[i].view());
    e.flushWindowToEvictionHook();
    e.flushWindowToEvictionHook();
    ASSERT_EQ(seen.size(), frames.size());
}

TEST(EnginePerplexity, InstantaneousPerplexityIsThePreviousStepsJustBeforeTheNextStepIsAdded) {
    EngineConfig c = engineConfig(Budget::steps(2));
    c.model.cell_time = 2;
    Engine e(c);
    int opened = 0;
    for (const Frame& f : makeStream(c.model, 30, 120, 8)) {
        const Model& m = e.model();
        const bool opensStep = m.observations() % 2 == 0 && m.steps() > 0;
        const double expected = opensStep ? m.stepPerplexity(m.steps() - 1) : std::nan("");
        const double expectedPlugin = opensStep ? m.stepPluginPerplexity(m.steps() - 1) : std::nan("");
        const int64_t prev = opensStep ? m.steps() - 1 : -1;
        const ObservationResult r = e.processNow(f.view());
        EXPECT_EQ(r.previous_step, prev);
        if (opensStep) {
            ++opened;
            EXPECT_TRUE(sameBits(r.previous_perplexity, expected));
            EXPECT_TRUE(std::isfinite(r.previous_perplexity) && r.previous_perplexity > 1.0);
            // The plug-in perplexity of the same step at the same instant: the word
            // counts itself, so it predicts better than the left-out one.
            EXPECT_TRUE(sameBits(r.previous_plugin, expectedPlugin));
            EXPECT_TRUE(std::isfinite(r.previous_plugin) && r.previous_plugin > 1.0);
            EXPECT_LT(r.previous_plugin, r.previous_perplexity);
        } else {
            EXPECT_TRUE(std::isnan(r.previous_perplexity));
            EXPECT_TRUE(std::isnan(r.previous_plugin));
        }
        EXPECT_TRUE(sameBits(r.perplexity, e.model().stepPerplexity(r.step)));
    }
    EXPECT_EQ(opened, 14);
}

TEST(EngineEviction, SubtractPolicyKeepsOnlyTheWindowsWordsInTheTopicModelAndCountsStayConsistent) {
    for (EvictionPolicy policy : {EvictionPolicy::Keep, EvictionPolicy::Subtract}) {
        EngineConfig c = engineConfig(Budget::steps(2));
        c.model.eviction = policy;
        Engine e(c);
        uint64_t total = 0;
        for (const Frame& f : makeStream(c.model, 60, 80, 12)) total += e.processNow(f.view()).add.kept;
        const Model& m = e.model();
        uint64_t inWindow = 0;
        for (int64_t t = m.oldestStep(); t < m.steps(); ++t) inWindow += m.wordsInStep(t);
        EXPECT_EQ(m.wordsInModel(), policy == EvictionPolicy::Subtract ? inWindow : total) << toString(policy);
        std::string why;
        EXPECT_TRUE(m.checkInvariants(&why)) << toString(policy) << ": " << why;
    }
}

// ---- snapshots ------------------------------------------------------------------

TEST(EngineSnapshot, HoldsTheNewestObservationsLabelsHistogramsSurpriseAndCounters) {
    const EngineConfig c = engineConfig(Budget::steps(2));
    Engine e(c);
    Snapshot s = e.makeSnapshot();
    EXPECT_FALSE(e.readSnapshot(s)) << "nothing published yet";
    const auto frames = makeStream(c.model, 25, 180, 9);
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const ObservationResult r = e.processNow(frames[i].view());
        ASSERT_TRUE(e.readSnapshot(s));
        const Model& m = e.model();
        EXPECT_EQ(s.version, i + 1);
        EXPECT_EQ(s.observation, i);
        EXPECT_EQ(s.timestamp, frames[i].timestamp);
        EXPECT_EQ(s.step, r.step);
        ASSERT_EQ(s.words(), m.observationSize(i));
        std::vector<uint16_t> labels(s.words());
        m.observationLabels(i, labels);
        EXPECT_TRUE(std::equal(labels.begin(), labels.end(), s.labels().begin()));
        EXPECT_TRUE(std::equal(frames[i].words.begin(), frames[i].words.end(), s.wordIds().begin()));
        for (int cell = 0; cell < m.cellsPerStep(); ++cell) {
            const auto h = m.cellHistogram(r.step, cell);
            EXPECT_TRUE(std::equal(h.begin(), h.end(), s.histogram(cell).begin())) << cell;
        }
        const auto cs = m.cellSurprise(r.step);
        EXPECT_TRUE(std::equal(cs.begin(), cs.end(), s.cellSurprise().begin()));
        EXPECT_TRUE(sameBits(s.perplexity, r.perplexity));
        EXPECT_TRUE(sameBits(s.surprise, m.observationSurprise(i)));
        EXPECT_TRUE(sameBits(s.previous_perplexity, r.previous_perplexity));
        EXPECT_TRUE(sameBits(s.previous_plugin, r.previous_plugin));
        EXPECT_EQ(s.counters.ingested, i + 1);
        EXPECT_EQ(s.counters.pushed, i + 1);
        EXPECT_EQ(s.counters.refinements, 2 * (i + 1));
        EXPECT_EQ(s.active_topics, c.model.K);
    }
}

// With growth, the snapshot's labels and histograms number the open topics
// 0..A-1 and it reports A: also when a closed slot lies below an open one (a
// prior in slots 0 and 2), where the numbering is not the slots'. A published
// result says each label's slot (what a label names once topics renumber).
TEST(EngineSnapshot, WithGrowingTopicsNumbersOpenTopicsFromZeroAndReportsTheirCount) {
    for (const bool gap : {false, true}) {
        SCOPED_TRACE(gap ? "a prior in slots 0 and 2" : "no prior");
        EngineConfig c = engineConfig(Budget::steps(3));
        c.model.grow = true;
        c.model.gamma = 0.5;
        Engine e(c);
        if (gap) {
            std::vector<int32_t> prior(static_cast<std::size_t>(c.model.K) * static_cast<std::size_t>(c.model.V), 0);
            for (int v = 0; v < c.model.V; ++v) {
                prior[static_cast<std::size_t>(v)] = v % 2 == 0 ? 3 : 0;
                prior[static_cast<std::size_t>(2 * c.model.V + v)] = v % 2 == 1 ? 3 : 0;
            }
            ASSERT_TRUE(e.model().addTopicCounts(prior).ok());
        }
        Snapshot s = e.makeSnapshot();
        ASSERT_TRUE(e.publishResults(4).ok());
        PublishedResult pr = e.makeResult();
        const auto frames = makeStream(c.model, 25, 180, 9);
        int most = 0, renumbered = 0;
        for (std::size_t i = 0; i < frames.size(); ++i) {
            const ObservationResult r = e.processNow(frames[i].view());
            ASSERT_TRUE(e.readSnapshot(s));
            const Model& m = e.model();
            ASSERT_EQ(s.active_topics, m.activeTopics());
            ASSERT_EQ(r.active_topics, m.activeTopics());
            most = std::max(most, s.active_topics);
            std::vector<uint16_t> map(static_cast<std::size_t>(m.K()));
            m.outputNumbering(map);
            for (int k = 0; k < m.K(); ++k) renumbered += map[k] != 0xFFFF && map[k] != k;
            for (uint16_t z : s.labels()) ASSERT_LT(z, s.active_topics);
            for (int cell = 0; cell < m.cellsPerStep(); ++cell) {
                const auto h = m.cellHistogram(r.step, cell);
                const auto out = s.histogram(cell);
                for (int k = 0; k < m.K(); ++k) {
                    if (map[k] != 0xFFFF) {
                        ASSERT_EQ(out[map[k]], h[k]);
                    } else {
                        ASSERT_EQ(h[k], 0) << "a closed topic holds no word";
                    }
                }
                for (int k = s.active_topics; k < m.K(); ++k) ASSERT_EQ(out[k], 0);
            }
            ASSERT_TRUE(e.readResult(pr));
            std::vector<uint16_t> slots(static_cast<std::size_t>(m.K()));
            m.slotsInLabelOrder(slots);
            ASSERT_EQ(pr.topic_slots, slots);
            for (int cell = 0; cell < m.cellsPerStep(); ++cell)
                for (int l = 0; l < s.active_topics; ++l)
                    ASSERT_EQ(pr.histograms[static_cast<std::size_t>(cell * m.K() + l)],
                              m.cellHistogram(r.step, cell)[pr.topic_slots[static_cast<std::size_t>(l)]]);
        }
        EXPECT_GT(most, 1) << "topics grew";
        if (gap) {
            EXPECT_GT(renumbered, 0) << "the numbering differed from the slots'";
        }
        std::string why;
        EXPECT_TRUE(e.model().checkInvariants(&why)) << why;
    }
}

TEST(EngineSnapshot, ReadIsRefusedForASnapshotSizedForAnotherConfiguration) {
    const EngineConfig c = engineConfig(Budget::steps(1));
    Engine e(c);
    e.processNow(makeStream(c.model, 1, 10, 1)[0].view());
    Snapshot unsized;
    EXPECT_FALSE(e.readSnapshot(unsized));
    Config other = c.model;
    other.K = 4;
    Snapshot wrong(other);
    EXPECT_FALSE(e.readSnapshot(wrong));
    Snapshot right = e.makeSnapshot();
    EXPECT_TRUE(e.readSnapshot(right));
}

// ---- bad input ----------------------------------------------------------------------

TEST(EngineInput, RejectsAnOutOfRangeWordOrPositionNamingTheIndexAndCountsIt) {
    const EngineConfig c = engineConfig(Budget::steps(1));
    Engine e(c);
    Frame f = makeStream(c.model, 1, 20, 1)[0];
    f.words[5] = static_cast<uint32_t>(c.model.V);
    ObservationResult r = e.processNow(f.view());
    EXPECT_EQ(r.add.error, AddError::WordOutOfRange);
    EXPECT_EQ(r.add.index, 5u);
    EXPECT_EQ(r.step, -1);
    f.words[5] = 0;
    f.positions[7] = {c.model.frame_width, 0};
    r = e.processNow(f.view());
    EXPECT_EQ(r.add.error, AddError::PositionOutOfRange);
    EXPECT_EQ(r.add.index, 7u);
    f.positions.pop_back();
    r = e.processNow(f.view());
    EXPECT_EQ(r.add.error, AddError::SizeMismatch);
    EXPECT_EQ(r.add.index, 19u);
    EXPECT_EQ(e.counters().rejected, 3u);
    EXPECT_EQ(e.counters().ingested, 0u);
    EXPECT_EQ(e.model().observations(), 0u);
    Snapshot s = e.makeSnapshot();
    EXPECT_FALSE(e.readSnapshot(s)) << "rejected observations are not published";
}

// More words than max_words_per_frame: a uniform subsample, in input order.
// Word id = input index, so the kept indices show which were kept: over 20
// frames of 2048 words (512 kept each) the four quarters of the input must
// be kept equally often (chi-square, 3 df, false-failure rate 1e-6).
TEST(EngineInput, SubsamplesAnOversizeObservationUniformlyInInputOrderAndCountsTheWords) {
    EngineConfig c = engineConfig(Budget::steps(0));
    c.model.V = 2048;
    c.model.cell_capacity = 512;
    c.model.frame_width = c.model.frame_height = 64;  // one cell
    Engine e(c);
    std::vector<uint32_t> words(2048);
    std::vector<Position> pos(2048, Position{1, 1});
    for (uint32_t i = 0; i < 2048; ++i) words[i] = i;
    double quarter[4] = {0, 0, 0, 0};
    for (int f = 0; f < 20; ++f) {
        const ObservationResult r = e.processNow({f, words, pos});
        ASSERT_TRUE(r.add.ok());
        ASSERT_EQ(e.model().observationSize(static_cast<uint64_t>(f)), 512u);
        // The observation's own result counts the words subsampled away, as the counters do.
        ASSERT_EQ(r.add.kept, 512u);
        ASSERT_EQ(r.add.dropped_frame, 2048u - 512u);
        ASSERT_EQ(r.add.dropped_cell, 0u);
        std::vector<uint32_t> kept(512);
        e.model().observationWords(static_cast<uint64_t>(f), kept);
        for (std::size_t i = 1; i < kept.size(); ++i) ASSERT_LT(kept[i - 1], kept[i]) << "input order";
        for (uint32_t w : kept) quarter[w / 512] += 1;
    }
    EXPECT_EQ(e.counters().words_truncated, 20u * (2048 - 512));
    double chi = 0;
    for (double q : quarter) chi += (q - 2560.0) * (q - 2560.0) / 2560.0;
    EXPECT_LT(chi, 30.7);  // chi-square 3 df, upper 1e-6 quantile
}

// ---- queue and drop policies ---------------------------------------------------------

TEST(EngineDrop, DropNewestRefusesPushesToAFullQueueAndCountsThem) {
    EngineConfig c = engineConfig(Budget::steps(1));
    c.drop = DropPolicy::DropNewest;
    Engine e(c);
    const auto frames = makeStream(c.model, 10, 30, 1);
    int accepted = 0;
    for (const Frame& f : frames) accepted += e.tryPush(f.view()) ? 1 : 0;
    EXPECT_EQ(accepted, 4);
    EXPECT_EQ(e.counters().dropped_newest, 6u);
    EXPECT_EQ(e.queued(), 4u);
    std::vector<int64_t> ts;
    e.setObservationHook([&](const ObservationResult& r, const Model&) { ts.push_back(r.timestamp); });
    EXPECT_EQ(e.processPending(), 4u);
    EXPECT_EQ(ts, (std::vector<int64_t>{1000, 1040, 1080, 1120})) << "the oldest four were kept";
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.ingested + k.dropped(), k.pushed);
}

TEST(EngineDrop, DropOldestKeepsTheFreshestObservationsAndCountsTheDiscarded) {
    EngineConfig c = engineConfig(Budget::steps(1));
    c.drop = DropPolicy::DropOldest;
    Engine e(c);
    const auto frames = makeStream(c.model, 10, 30, 1);
    for (const Frame& f : frames) EXPECT_TRUE(e.tryPush(f.view()));
    EXPECT_EQ(e.counters().dropped_oldest, 6u);
    std::vector<uint64_t> seq;
    e.setObservationHook([&](const ObservationResult& r, const Model&) { seq.push_back(r.sequence); });
    EXPECT_EQ(e.processPending(), 4u);
    EXPECT_EQ(seq, (std::vector<uint64_t>{6, 7, 8, 9})) << "the newest four were kept";
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.ingested + k.dropped(), k.pushed);
}

// The library's SPSC ring, slot by slot: a full ring refuses, a pop frees
// exactly the slot read, slots come back in order and are reused in place.
TEST(SpscRing, APopFreesTheSlotReadAndSlotsAreReusedInOrder) {
    SpscRing<int> ring(2, [](int& v) { v = -1; });
    int* a = ring.beginPush();
    ASSERT_NE(a, nullptr);
    *a = 10;
    ring.commitPush();
    int* b = ring.beginPush();
    ASSERT_NE(b, nullptr);
    EXPECT_NE(a, b);
    *b = 11;
    ring.commitPush();
    EXPECT_EQ(ring.beginPush(), nullptr) << "a full ring took a third slot";
    ASSERT_NE(ring.front(), nullptr);
    EXPECT_EQ(*ring.front(), 10);
    ring.pop();
    int* c = ring.beginPush();
    ASSERT_NE(c, nullptr) << "the slot read and popped did not come back to the producer";
    EXPECT_EQ(c, a);
    *c = 12;
    ring.commitPush();
    EXPECT_EQ(ring.beginPush(), nullptr);
    for (const int want : {11, 12}) {
        ASSERT_NE(ring.front(), nullptr);
        EXPECT_EQ(*ring.front(), want);
        ring.pop();
    }
    EXPECT_EQ(ring.front(), nullptr);
    for (int i = 0; i < 10; ++i) {  // round and round, one at a time
        int* s = ring.beginPush();
        ASSERT_NE(s, nullptr);
        *s = 100 + i;
        ring.commitPush();
        ASSERT_NE(ring.front(), nullptr);
        EXPECT_EQ(*ring.front(), 100 + i);
        ring.pop();
    }
}

TEST(ObservationQueue, DropOldestDropsTheNewestInsteadWhileTheConsumerIsReadingTheOldest) {
    ObservationQueue q(2, 8, 1);
    const uint32_t w[1] = {3};
    const Position p[1] = {{0, 0}};
    EXPECT_EQ(q.tryPush(1, w, p, true), ObservationQueue::Push::Queued);
    EXPECT_EQ(q.tryPush(2, w, p, true), ObservationQueue::Push::Queued);
    ObservationQueue::Item it;
    ASSERT_TRUE(q.claim(it));  // the consumer reads observation 0 ...
    EXPECT_EQ(it.timestamp, 1);
    // ... so its slot cannot be reused: the newest is dropped.
    EXPECT_EQ(q.tryPush(3, w, p, true), ObservationQueue::Push::Dropped);
    q.release();
    EXPECT_EQ(q.tryPush(4, w, p, true), ObservationQueue::Push::Queued);  // the released slot
    EXPECT_EQ(q.tryPush(5, w, p, true), ObservationQueue::Push::QueuedDroppedOldest);  // discards 2
    ASSERT_TRUE(q.claim(it));
    EXPECT_EQ(it.timestamp, 4);
    EXPECT_EQ(it.words[0], 3u);
    q.release();
    ASSERT_TRUE(q.claim(it));
    EXPECT_EQ(it.timestamp, 5);
    q.release();
    EXPECT_FALSE(q.claim(it));
    EXPECT_EQ(q.droppedNewest(), 1u);
    EXPECT_EQ(q.droppedOldest(), 1u);
    EXPECT_EQ(q.pushed(), 5u);
}

// The queue alone under a producer and a consumer on two threads: every
// observation claimed is whole (its size, time stamp, words and positions
// are the ones pushed with its sequence number, never a slot's earlier
// contents or a half-written one), in push order, and each push is either
// claimed or counted as dropped. Both policies; the slots are few and the
// pushes many, so every slot is reused thousands of times while read.
TEST(ObservationQueue, ConcurrentReadersSeeEachObservationWholeAndInOrder) {
    constexpr uint32_t kSlots = 3, kMaxWords = 48;
    constexpr uint64_t kPushes = 40000;
    auto sizeOf = [](uint64_t seq) { return static_cast<uint32_t>(1 + seq * 7 % kMaxWords); };
    auto wordOf = [](uint64_t seq, uint32_t i) { return static_cast<uint32_t>(seq * 131 + i); };
    for (const bool dropOldest : {false, true}) {
        ObservationQueue q(kSlots, kMaxWords, 1);
        std::atomic<bool> done{false};
        uint64_t claimed = 0, torn = 0, outOfOrder = 0;
        int64_t last = -1;
        std::thread consumer([&] {
            ObservationQueue::Item it;
            for (;;) {
                if (!q.claim(it)) {
                    if (done.load(std::memory_order_acquire) && !q.pending()) break;
                    continue;
                }
                bool whole = it.size == sizeOf(it.sequence) && it.timestamp == static_cast<int64_t>(it.sequence) * 10;
                for (uint32_t i = 0; whole && i < it.size; ++i)
                    whole = it.words[i] == wordOf(it.sequence, i) && it.positions[i].x == static_cast<int>(i) &&
                            it.positions[i].y == static_cast<int>(it.sequence % 1000);
                torn += whole ? 0 : 1;
                outOfOrder += static_cast<int64_t>(it.sequence) > last ? 0 : 1;
                last = static_cast<int64_t>(it.sequence);
                ++claimed;
                q.release();
            }
        });
        std::vector<uint32_t> words(kMaxWords);
        std::vector<Position> positions(kMaxWords);
        for (uint64_t seq = 0; seq < kPushes; ++seq) {
            const uint32_t n = sizeOf(seq);
            for (uint32_t i = 0; i < n; ++i) {
                words[i] = wordOf(seq, i);
                positions[i] = {static_cast<int>(i), static_cast<int>(seq % 1000)};
            }
            // Drop newest: each push waits for a free slot, so all are read
            // and each slot is reused right after its release. Drop oldest:
            // every other push does not wait, its discard racing the claims.
            while ((!dropOldest || seq % 2 == 0) && !q.hasSpace()) {
            }
            q.tryPush(static_cast<int64_t>(seq) * 10, {words.data(), n}, {positions.data(), n}, dropOldest);
        }
        done.store(true, std::memory_order_release);
        consumer.join();
        SCOPED_TRACE(dropOldest ? "drop oldest" : "drop newest");
        EXPECT_EQ(torn, 0u) << "observations claimed with contents other than those pushed, of " << claimed;
        EXPECT_EQ(outOfOrder, 0u);
        EXPECT_EQ(claimed + q.droppedNewest() + q.droppedOldest(), kPushes);
        EXPECT_EQ(q.pushed(), kPushes);
        if (dropOldest) {
            EXPECT_GT(claimed, 0u);
            EXPECT_GT(q.droppedOldest(), 0u);
        } else {
            EXPECT_EQ(claimed, kPushes);
        }
    }
}

static_assert(noexcept(std::declval<ObservationQueue&>().tryPush(0, {}, {}, true)));
static_assert(noexcept(std::declval<ObservationQueue&>().claim(std::declval<ObservationQueue::Item&>())));
static_assert(noexcept(std::declval<Engine&>().tryPush(std::declval<const ObservationView&>())));
static_assert(noexcept(std::declval<const Engine&>().readSnapshot(std::declval<Snapshot&>())));
static_assert(noexcept(std::declval<Engine&>().processNow(std::declval<const ObservationView&>())));
static_assert(!std::is_copy_constructible_v<Engine> && !std::is_move_constructible_v<Engine>);
static_assert(!std::is_copy_constructible_v<ObservationQueue>);

// ---- thread settings ----------------------------------------------------------------

TEST(ThreadSettings, PinningToAMissingCpuFallsBackWithAMessageNamingTheCpu) {
    ThreadSettingsReport report;
    std::thread t([&] {
        ThreadSettings s;
        s.cpu = 1000;
        report = applyToCurrentThread(s);
    });
    t.join();
    EXPECT_FALSE(report.pinned);
    EXPECT_NE(report.message.find("CPU 1000"), std::string::npos) << report.message;
}

// Each fallback is a line of the report, and stderr says each once a
// process. Priority 0 is no
// SCHED_FIFO priority, so FIFO falls back with privileges too.
TEST(ThreadSettings, FallbacksAreReportedLineByLineAndLoggedOnceAProcess) {
    ThreadSettings s;
    s.cpu = 100000;
    s.fifo = true;
    s.priority = 0;
    detail::forgetLoggedFallbacks();  // an earlier test of this process may have said them
    std::fflush(stderr);
    char path[] = "/tmp/rost_fallbacks_XXXXXX";
    const int fd = ::mkstemp(path);
    ASSERT_GE(fd, 0);
    const int saved = ::dup(2);
    ::dup2(fd, 2);
    const auto loggedSoFar = [&] {
        std::fflush(stderr);
        std::string text;
        char buf[1024];
        ::lseek(fd, 0, SEEK_SET);
        for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) text.append(buf, static_cast<std::size_t>(n));
        return text;
    };
    ThreadSettingsReport first, second;
    std::string afterFirst, afterSecond;
    std::thread t([&] {
        first = applyToCurrentThread(s);
        afterFirst = loggedSoFar();
        second = applyToCurrentThread(s);
        afterSecond = loggedSoFar();
    });
    t.join();
    ::dup2(saved, 2);
    ::close(saved);
    ::close(fd);
    ::unlink(path);
    EXPECT_FALSE(first.pinned || first.fifo);
    EXPECT_NE(first.message.find("it runs on any CPU\nSCHED_FIFO priority 0 not permitted"), std::string::npos)
        << first.message;
    EXPECT_EQ(second.message, first.message);
    const auto count = [](const std::string& logged, const std::string& what) {
        std::size_t n = 0;
        for (std::size_t at = logged.find(what); at != std::string::npos; at = logged.find(what, at + 1)) ++n;
        return n;
    };
    // Said at the first fallback, not again at the second.
    EXPECT_EQ(count(afterFirst, "rost: could not pin the refiner thread to CPU 100000"), 1u) << afterFirst;
    EXPECT_EQ(count(afterFirst, "rost: SCHED_FIFO priority 0 not permitted"), 1u) << afterFirst;
    EXPECT_EQ(afterSecond, afterFirst);
}

TEST(ThreadSettings, OnboardRequestsFifoPinningAndLockedMemory) {
    const ThreadSettings s = ThreadSettings::onboard();
    EXPECT_TRUE(s.fifo);
    EXPECT_TRUE(s.lock_memory);
    EXPECT_GE(s.priority, 1);
    EXPECT_LE(s.priority, 99);
    EXPECT_EQ(ThreadSettings{}.fifo, false) << "the library default asks for nothing";
    // The CPU is the last this machine has (one that exists), or none on one CPU.
    const unsigned n = std::thread::hardware_concurrency();
    EXPECT_EQ(s.cpu, n > 1 ? static_cast<int>(n) - 1 : -1);
    if (n > 1) {  // pinning there works (FIFO and locked memory left out: they need privileges)
        ThreadSettings pinOnly;
        pinOnly.cpu = s.cpu;
        ThreadSettingsReport report;
        std::thread t([&] { report = applyToCurrentThread(pinOnly); });
        t.join();
        EXPECT_TRUE(report.pinned) << report.message;
    }
}

// ---- replay ------------------------------------------------------------------------------

TEST(Replay, RecordsPerplexitySurpriseAndFinalLabelsForEveryObservation) {
    EngineConfig c = engineConfig(Budget::steps(2));
    const auto frames = makeStream(c.model, 60, 100, 10);
    const ReplayResult r = replayOf(c, frames, false, 2);
    ASSERT_EQ(r.observations.size(), frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const ReplayObservation& o = r.observations[i];
        EXPECT_EQ(o.timestamp, frames[i].timestamp);
        EXPECT_EQ(o.step, static_cast<int64_t>(i));
        EXPECT_TRUE(std::isfinite(o.instantaneous_perplexity) && o.instantaneous_perplexity > 1.0) << i;
        EXPECT_TRUE(std::isfinite(o.final_perplexity) && o.final_perplexity > 1.0) << i;
        EXPECT_TRUE(std::isfinite(o.surprise)) << i;
        ASSERT_EQ(o.labels.size(), frames[i].words.size());
        for (uint16_t z : o.labels) ASSERT_LT(z, c.model.K);
    }
    EXPECT_TRUE(std::isnan(r.observations[0].surprise) || r.observations[0].surprise > 0);
    EXPECT_EQ(r.counters.ingested, frames.size());
}

// The engine's own hooks stay called during a replay (which adds its own
// beside them): every observation reaches the observation hook once, and
// the eviction hook once (as it leaves the ring, or from the window at the
// end), in order; both are the engine's again afterwards.
TEST(Replay, TheEnginesOwnHooksSeeEveryObservationOnce) {
    EngineConfig c = engineConfig(Budget::steps(2));
    const auto frames = makeStream(c.model, 3 * c.model.ring_steps / 2, 50, 11);
    for (const bool threaded : {false, true}) {
        Engine engine(c);
        std::vector<uint64_t> observed, evicted;
        engine.setObservationHook([&](const ObservationResult& r, const Model&) { observed.push_back(r.sequence); });
        engine.setEvictionHook([&](const WindowObservation& w, const Model&) { evicted.push_back(w.observation); });
        ReplayResult r;
        ReplayOptions o;
        o.threaded = threaded;
        ASSERT_TRUE(replay(engine, toStream(frames), o, r).ok());
        std::vector<uint64_t> all(frames.size());
        std::iota(all.begin(), all.end(), uint64_t{0});
        EXPECT_EQ(observed.size(), frames.size()) << threaded;
        EXPECT_EQ(evicted, all) << threaded;
        EXPECT_TRUE(static_cast<bool>(engine.evictionHook())) << "the engine's hook, given back";
    }
}

TEST(Replay, LearnsTheStreamsStructureAndMoreBudgetLowersPerplexity) {
    auto meanLogs = [](int R) {
        EngineConfig c = engineConfig(Budget::steps(static_cast<uint64_t>(R)), StrategyKind::UniformNow);
        const auto frames = makeStream(c.model, 120, 150, 11);
        const ReplayResult r = replayOf(c, frames, false, 5);
        double inst = 0, fin = 0;
        for (const auto& o : r.observations) {
            inst += std::log(o.instantaneous_perplexity);
            fin += std::log(o.final_perplexity);
        }
        const auto n = static_cast<double>(r.observations.size());
        return std::pair<double, double>{std::exp(inst / n), std::exp(fin / n)};
    };
    const auto [inst4, fin4] = meanLogs(4);
    const auto [inst20, fin20] = meanLogs(20);
    EXPECT_LT(fin4, inst4) << "refinement after arrival improves each step";
    EXPECT_LT(fin4, 0.7 * 400) << "well below a uniform model's perplexity (V = 400)";
    EXPECT_LT(fin20, 0.9 * fin4) << "five times the budget learns more";
    EXPECT_LT(inst20, inst4);
}

TEST(Replay, RejectsAStreamWhosePositionsDoNotMatchItsWordsNamingTheObservation) {
    const EngineConfig c = engineConfig(Budget::steps(1));
    auto frames = makeStream(c.model, 3, 10, 1);
    frames[1].positions.pop_back();
    Engine e(c);
    ReplayResult r;
    const Status s = replay(e, toStream(frames), {}, r);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("observation 1"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("10 words but 9 positions"), std::string::npos) << s.message();
    // More positions than words is as wrong.
    frames = makeStream(c.model, 3, 10, 1);
    frames[2].positions.push_back(frames[2].positions.back());
    Engine e2(c);
    const Status more = replay(e2, toStream(frames), {}, r);
    EXPECT_NE(more.message().find("observation 2"), std::string::npos) << more.message();
    EXPECT_NE(more.message().find("10 words but 11 positions"), std::string::npos) << more.message();
}

TEST(Replay, EveryFinalSweepAskedForIsRun) {
    // One final sweep is a sweep: the final labels and perplexities differ
    // from none, and two from one.
    const EngineConfig c = engineConfig(Budget::steps(1));
    const auto frames = makeStream(c.model, 20, 40, 3);
    const ReplayResult none = replayOf(c, frames, false, 0), one = replayOf(c, frames, false, 1),
                       two = replayOf(c, frames, false, 2);
    EXPECT_GT(differences(none, one), 0);
    EXPECT_GT(differences(one, two), 0);
}

TEST(Replay, AStreamWithoutPositionsPutsEveryWordInTheFirstCell) {
    const EngineConfig c = engineConfig(Budget::steps(1));
    WordStream s;
    s.has_positions = false;
    for (int i = 0; i < 5; ++i) s.observations.push_back({i, {1, 2, 3}, {}});
    Engine e(c);
    ReplayResult r;
    ASSERT_TRUE(replay(e, s, {}, r).ok());
    EXPECT_EQ(e.model().cellWordCount(4, 0), 3u);
    EXPECT_EQ(r.observations[4].labels.size(), 3u);
}

// The engine's publication (publishResults / readResult / readFinal) carries
// what the hooks see at the same moment: each observation's result with its
// step's cell histograms and surprises, and each leaving observation's
// final labels; a rejected observation is published too, with zeros where
// the records (two, read after each observation: each reused) held the
// content of an observation before.
TEST(EnginePublication, PublishedResultsEqualWhatTheHooksReport) {
    EngineConfig c;
    c.model = smallConfig();
    c.budget = Budget::steps(2);
    Engine e(c);
    ASSERT_TRUE(e.publishResults(2).ok());
    const Model& model = e.model();
    const auto cells = static_cast<std::size_t>(model.cellsPerStep());
    const auto K = static_cast<std::size_t>(model.K());
    std::vector<PublishedResult> fromHook;
    std::vector<FinalLabels> finalsFromHook;
    e.setObservationHook([&](const ObservationResult& r, const Model& m) {
        PublishedResult p = e.makeResult();
        p.result = r;
        if (r.add.ok())
            for (std::size_t cc = 0; cc < cells; ++cc) {
                const auto h = m.cellHistogram(r.step, static_cast<int>(cc));
                std::copy_n(h.begin(), K, p.histograms.begin() + static_cast<std::ptrdiff_t>(cc * K));
                p.cell_surprise[cc] = m.cellSurprise(r.step)[cc];
            }
        fromHook.push_back(std::move(p));
    });
    e.setEvictionHook([&](const WindowObservation& w, const Model& m) {
        FinalLabels f = e.makeFinal();
        f.where = w;
        f.perplexity = m.stepPerplexity(w.step);
        f.n = m.observationSize(w.observation);
        m.observationWords(w.observation, {f.words.data(), f.n});
        m.observationPositions(w.observation, {f.positions.data(), f.n});
        m.observationLabels(w.observation, {f.labels.data(), f.n});
        finalsFromHook.push_back(std::move(f));
    });
    auto frames = makeStream(c.model, 40, 120, 41);
    frames[7].words[3] = static_cast<uint32_t>(c.model.V) + 5;  // out of range: rejected
    PublishedResult got = e.makeResult();
    FinalLabels gotFinal = e.makeFinal();
    std::size_t results = 0, finals = 0;
    for (const Frame& f : frames) {
        ASSERT_TRUE(e.tryPush(f.view()));
        e.processPending();
        while (e.readResult(got)) {
            ASSERT_LT(results, fromHook.size());
            const PublishedResult& want = fromHook[results++];
            EXPECT_EQ(got.result.observation, want.result.observation);
            EXPECT_EQ(got.result.timestamp, want.result.timestamp);
            EXPECT_EQ(got.result.step, want.result.step);
            EXPECT_EQ(got.result.add.error, want.result.add.error);
            EXPECT_EQ(got.result.refinements, want.result.refinements);
            if (!want.result.add.ok()) {
                EXPECT_EQ(got.histograms, std::vector<int32_t>(got.histograms.size(), 0)) << "a rejected observation";
                EXPECT_EQ(got.cell_surprise, std::vector<float>(got.cell_surprise.size(), 0.f));
                continue;
            }
            EXPECT_EQ(std::memcmp(&got.result.surprise, &want.result.surprise, sizeof(double)), 0);
            EXPECT_EQ(got.histograms, want.histograms);
            EXPECT_EQ(got.cell_surprise, want.cell_surprise);
        }
        while (e.readFinal(gotFinal)) {
            ASSERT_LT(finals, finalsFromHook.size());
            const FinalLabels& want = finalsFromHook[finals++];
            EXPECT_EQ(gotFinal.where.observation, want.where.observation);
            EXPECT_EQ(gotFinal.where.timestamp, want.where.timestamp);
            EXPECT_EQ(gotFinal.where.step, want.where.step);
            EXPECT_EQ(gotFinal.perplexity, want.perplexity);
            ASSERT_EQ(gotFinal.n, want.n);
            for (uint32_t i = 0; i < want.n; ++i) {
                EXPECT_EQ(gotFinal.words[i], want.words[i]);
                EXPECT_EQ(gotFinal.positions[i].x, want.positions[i].x);
                EXPECT_EQ(gotFinal.positions[i].y, want.positions[i].y);
                EXPECT_EQ(gotFinal.labels[i], want.labels[i]);
            }
        }
    }
    EXPECT_EQ(results, frames.size());
    EXPECT_EQ(results, fromHook.size());
    EXPECT_EQ(finals, finalsFromHook.size());
    EXPECT_GT(finals, 0u);
    EXPECT_EQ(e.resultsLost(), 0u);
    EXPECT_EQ(e.counters().rejected, 1u);
}

// A full ring drops the newest record and counts it; publication off reads nothing.
TEST(EnginePublication, AFullRingCountsLostRecordsAndOffPublishesNothing) {
    EngineConfig c;
    c.model = smallConfig();
    c.budget = Budget::steps(1);
    Engine e(c);
    PublishedResult r = e.makeResult();
    const auto frames = makeStream(c.model, 6, 50, 42);
    for (const Frame& f : frames) (void)e.processNow(f.view());
    EXPECT_FALSE(e.readResult(r));
    ASSERT_TRUE(e.publishResults(2).ok());
    for (const Frame& f : frames) (void)e.processNow(f.view());
    EXPECT_EQ(e.resultsLost(), 4u);
    EXPECT_TRUE(e.readResult(r));
    EXPECT_EQ(r.result.observation, 6u);
    EXPECT_TRUE(e.readResult(r));
    EXPECT_FALSE(e.readResult(r));
}

} // namespace
} // namespace rost
