// The engine with its threads: a producer, the refiner, readers.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "rost/engine.hpp"
#include "test_engine_support.hpp"

namespace rost {
namespace {

using rost::testing::Frame;
using rost::testing::makeStream;
using rost::testing::smallConfig;
using namespace std::chrono_literals;

// Resident set size of this process in bytes (Linux), 0 when unknown.
std::size_t residentBytes() {
    std::ifstream f("/proc/self/statm");
    std::size_t pages = 0, resident = 0;
    if (!(f >> pages >> resident)) return 0;
    return resident * 4096;
}

EngineConfig threadedConfig(Budget b) {
    EngineConfig e;
    e.model = smallConfig();
    e.budget = b;
    e.queue_slots = 8;
    return e;
}

// The time budget of the test below: 1 ms natively; 10 ms under a sanitizer
// (5 to 15 times slower) and 20 ms under qemu-user (10 to 50 times slower).
// There the ingest and the publication of an observation alone took the
// millisecond and a newer frame was always waiting (stop on arrival), so in
// about one run in four no round ever started.
#if defined(ROST_TESTS_EMULATED)
constexpr double kProducerTestBudgetMs = 20.0;
#elif defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
constexpr double kProducerTestBudgetMs = 10.0;
#else
constexpr double kProducerTestBudgetMs = 1.0;
#endif

TEST(EngineThreads, TimeBudgetKeepsCountsConsistentAfterStopWithProducerAndReaderRunning) {
    EngineConfig c = threadedConfig(Budget::time(kProducerTestBudgetMs));
    c.drop = DropPolicy::DropOldest;
    Engine e(c);
    const auto frames = makeStream(c.model, 300, 200, 21);
    Snapshot snap = e.makeSnapshot();
    ASSERT_TRUE(e.start().ok());
    std::atomic<bool> done{false};
    std::atomic<uint64_t> reads{0};
    std::thread reader([&] {
        Snapshot s = e.makeSnapshot();
        while (!done.load()) {
            if (e.readSnapshot(s)) reads.fetch_add(1);
            std::this_thread::sleep_for(100us);
        }
    });
    for (const Frame& f : frames) {
        (void)e.tryPush(f.view());
        std::this_thread::sleep_for(500us);
    }
    e.stop();
    done.store(true);
    reader.join();
    std::string why;
    EXPECT_TRUE(e.model().checkInvariants(&why)) << why;
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.pushed, frames.size());
    EXPECT_EQ(k.ingested + k.dropped(), k.pushed);
    EXPECT_EQ(k.ingested, e.model().observations());
    EXPECT_GT(k.refinements, 0u);
    EXPECT_LE(k.overruns, k.ingested);
    EXPECT_GT(reads.load(), 0u);
    ASSERT_TRUE(e.readSnapshot(snap));
    EXPECT_EQ(snap.observation + 1, k.ingested);
}

// The budget of the test below: 5 ms natively; 50 ms under a sanitizer,
// where a round takes 5 to 15 times as long and the engine rightly starts no
// round whose predicted cost (1.5 times, learned per token) no longer fits:
// under ThreadSanitizer one observation once stopped at 3.2 ms of 5.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
constexpr double kDeadlineTestBudgetMs = 50.0;
#else
constexpr double kDeadlineTestBudgetMs = 5.0;
#endif

TEST(EngineThreads, EachObservationRefinesUntilNearItsTimeBudgetDeadline) {
    Engine e(threadedConfig(Budget::time(kDeadlineTestBudgetMs)));
    std::vector<int64_t> elapsed;
    elapsed.reserve(64);
    e.setObservationHook([&](const ObservationResult& r, const Model&) { elapsed.push_back(r.elapsed_ns); });
    const auto frames = makeStream(e.config().model, 20, 200, 22);
    ASSERT_TRUE(e.start().ok());
    for (const Frame& f : frames) ASSERT_TRUE(e.pushWait(f.view()));
    e.stop();
    ASSERT_EQ(elapsed.size(), frames.size());
    const auto atLeast = static_cast<int64_t>(kDeadlineTestBudgetMs * 0.8e6);
    // Every observation from the eleventh on: a first round or publication
    // preempted on a loaded machine sets a predictor too high, and the first
    // observations after it may end early while it comes back (clamped: see
    // EngineBudget.APreemptedFirstRoundCannotStopRefinementForGood); a later
    // outlier moves it by a bounded step only. And the median of all.
    for (std::size_t i = 10; i < elapsed.size(); ++i)
        EXPECT_GE(elapsed[i], atLeast) << "observation " << i << " spends (nearly) its whole " << kDeadlineTestBudgetMs
                                       << " ms budget";
    std::vector<int64_t> sorted = elapsed;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_GE(sorted[sorted.size() / 2], atLeast) << "the median observation spends (nearly) its whole budget";
}

TEST(EngineThreads, StopOnArrivalEndsATimeBudgetEarlyWhenANewerObservationWaits) {
    EngineConfig c = threadedConfig(Budget::time(300.0));
    c.flags.stop_on_arrival = true;
    Engine e(c);
    std::vector<int64_t> elapsed;
    elapsed.reserve(8);
    e.setObservationHook([&](const ObservationResult& r, const Model&) { elapsed.push_back(r.elapsed_ns); });
    const auto frames = makeStream(c.model, 5, 200, 23);
    for (const Frame& f : frames) ASSERT_TRUE(e.tryPush(f.view()));  // queued before the refiner starts
    ASSERT_TRUE(e.start().ok());
    e.stop();  // drains
    ASSERT_EQ(elapsed.size(), 5u);
    for (int i = 0; i < 4; ++i) EXPECT_LT(elapsed[i], 150'000'000) << "a newer observation was waiting";
    EXPECT_GE(elapsed[4], 200'000'000) << "the newest refines until its deadline";
}

// A producer far faster than the refiner: frames are lost, every loss is
// counted, and nothing grows.
void overload(DropPolicy policy) {
    EngineConfig c = threadedConfig(Budget::steps(30));
    c.drop = policy;
    Engine e(c);
    const auto frames = makeStream(c.model, 64, 200, 24);
    const std::size_t memory = e.memoryBytes();
    ASSERT_TRUE(e.start().ok());
    const uint64_t pushes = 20000;
    uint64_t accepted = 0;
    std::size_t rssAfterWarmup = 0;
    for (uint64_t i = 0; i < pushes; ++i) {
        accepted += e.tryPush(frames[i % frames.size()].view()) ? 1 : 0;
        if (i == 2000) rssAfterWarmup = residentBytes();
    }
    const std::size_t rssEnd = residentBytes();
    e.stop();
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.pushed, pushes);
    EXPECT_EQ(k.ingested + k.dropped(), k.pushed) << "every frame is either ingested or counted as dropped";
    EXPECT_EQ(k.ingested, e.model().observations());
    EXPECT_GT(k.dropped(), pushes / 2) << "the producer really was faster";
    EXPECT_EQ(accepted, pushes - k.dropped_newest);
    if (policy == DropPolicy::DropNewest) {
        EXPECT_EQ(k.dropped_oldest, 0u);
    }
    EXPECT_EQ(e.memoryBytes(), memory);
#if !defined(__SANITIZE_THREAD__)
    // (Not under ThreadSanitizer: it maps the shadow of each ring slot the
    // first time the refiner touches it, after this warm-up point.)
    if (rssAfterWarmup > 0) {
        EXPECT_LT(rssEnd, rssAfterWarmup + (1u << 20)) << "resident memory stays flat";
    }
#else
    (void)rssAfterWarmup;
    (void)rssEnd;
#endif
    std::string why;
    EXPECT_TRUE(e.model().checkInvariants(&why)) << why;
}

TEST(EngineThreads, OverloadWithDropOldestLosesOnlyCountedFramesAndMemoryStaysFlat) { overload(DropPolicy::DropOldest); }
TEST(EngineThreads, OverloadWithDropNewestLosesOnlyCountedFramesAndMemoryStaysFlat) { overload(DropPolicy::DropNewest); }

// Each observation carries its sequence number in every word and in its
// size, so a reader can tell a torn snapshot from a consistent one.
TEST(EngineThreads, ReadersNeverSeeATornSnapshotWhileTheRefinerPublishes) {
    EngineConfig c = threadedConfig(Budget::steps(1));
    c.model.V = 997;
    c.model.cell_capacity = 400;
    c.drop = DropPolicy::DropOldest;
    Engine e(c);
    ASSERT_TRUE(e.start().ok());
    std::atomic<bool> done{false};
    std::atomic<int> torn{0};
    std::atomic<uint64_t> reads{0};
    auto readLoop = [&] {
        Snapshot s = e.makeSnapshot();
        uint64_t lastVersion = 0;
        while (!done.load(std::memory_order_relaxed)) {
            if (!e.readSnapshot(s)) continue;
            reads.fetch_add(1, std::memory_order_relaxed);
            const auto seq = static_cast<uint64_t>(s.timestamp);
            bool ok = s.version >= lastVersion && s.words() == 1 + seq % 300 && s.sequence == seq;
            for (uint32_t w : s.wordIds()) ok = ok && w == seq % 997;
            int64_t total = 0;
            for (int32_t h : s.histograms()) total += h;
            ok = ok && total == static_cast<int64_t>(s.words());
            if (!ok) torn.fetch_add(1);
            lastVersion = s.version;
        }
    };
    std::thread r1(readLoop), r2(readLoop);
    std::vector<uint32_t> words(300);
    std::vector<Position> pos(300);
    for (uint64_t seq = 0; seq < 3000; ++seq) {
        const auto n = static_cast<std::size_t>(1 + seq % 300);
        for (std::size_t i = 0; i < n; ++i) {
            words[i] = static_cast<uint32_t>(seq % 997);
            pos[i] = {static_cast<int32_t>(i % 256), static_cast<int32_t>((i * 7) % 192)};
        }
        (void)e.tryPush({static_cast<int64_t>(seq), {words.data(), n}, {pos.data(), n}});
        if (seq % 16 == 0) std::this_thread::yield();
    }
    e.stop();
    done.store(true);
    r1.join();
    r2.join();
    EXPECT_EQ(torn.load(), 0);
    EXPECT_GT(reads.load(), 0u);
}

TEST(EngineThreads, StopDrainTakesUpEveryQueuedObservation) {
    EngineConfig c = threadedConfig(Budget::steps(2));
    c.queue_slots = 64;
    Engine e(c);
    const auto frames = makeStream(c.model, 64, 100, 25);
    for (const Frame& f : frames) ASSERT_TRUE(e.tryPush(f.view()));
    ASSERT_TRUE(e.start().ok());
    e.stop(Engine::StopMode::Drain);
    EXPECT_EQ(e.counters().ingested, 64u);
    EXPECT_EQ(e.queued(), 0u);
}

TEST(EngineThreads, StopDiscardLeavesQueuedObservationsAccountedFor) {
    EngineConfig c = threadedConfig(Budget::time(20.0));
    c.queue_slots = 64;
    Engine e(c);
    const auto frames = makeStream(c.model, 64, 100, 26);
    for (const Frame& f : frames) ASSERT_TRUE(e.tryPush(f.view()));
    ASSERT_TRUE(e.start().ok());
    std::this_thread::sleep_for(5ms);
    e.stop(Engine::StopMode::Discard);
    const EngineCounters k = e.counters();
    EXPECT_LT(k.ingested, 64u) << "did not drain 64 x 20 ms";
    EXPECT_EQ(k.ingested + e.queued(), 64u);
    // The engine restarts and drains the rest.
    ASSERT_TRUE(e.start().ok());
    e.stop(Engine::StopMode::Drain);
    EXPECT_EQ(e.counters().ingested, 64u);
}

// stop(Discard) does not wait out the count budget of the observation in
// hand: its refinement starts no further window (10^12 step draws would take
// days), it is still published, the queued ones stay queued, and a later
// refinement of the stopped engine gets its whole budget again.
TEST(EngineThreads, StopDiscardCutsTheCountBudgetInHandShort) {
    constexpr uint64_t kDays = 1'000'000'000'000;
    EngineConfig c = threadedConfig(Budget::steps(kDays));
    c.model.refine_window = 1;  // a window a cell: the stop is seen after one cell
    Engine e(c);
    const auto frames = makeStream(c.model, 3, 100, 28);
    for (const Frame& f : frames) ASSERT_TRUE(e.tryPush(f.view()));
    ASSERT_TRUE(e.start().ok());
    while (e.counters().ingested == 0) std::this_thread::sleep_for(1ms);
    std::this_thread::sleep_for(20ms);  // well into the budget
    std::atomic<bool> stopped{false};
    std::thread watchdog([&] {  // a stop that waits the budget out fails here, not at ctest's timeout
        for (int i = 0; i < 600 && !stopped.load(); ++i) std::this_thread::sleep_for(100ms);
        if (stopped.load()) return;
        std::fprintf(stderr, "stop(Discard) still waiting after 60 s: the count budget in hand was not cut short\n");
        std::_Exit(1);
    });
    e.stop(Engine::StopMode::Discard);
    stopped.store(true);
    watchdog.join();
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.ingested, 1u);
    EXPECT_EQ(e.queued(), 2u);
    EXPECT_EQ(k.published, 1u);
    EXPECT_GT(k.tokens, 0u) << "nothing was refined before the stop";
    EXPECT_LT(k.refinements, kDays);
    // Stopped, the engine's own calls are not cut short: 40 step draws, each refined whole.
    const uint64_t before = e.model().tokensRefined();
    EXPECT_EQ(e.refineExtra(Budget::steps(40)), 40u);
    EXPECT_EQ(e.model().tokensRefined() - before, 40u * e.model().wordsInStep(0))
        << "a step of the one observation in the model: 40 draws of it";
}

TEST(EngineThreads, SynchronousCallsAreRefusedWhileRunningAndStartTwiceIsAnError) {
    Engine e(threadedConfig(Budget::steps(1)));
    const auto frames = makeStream(e.config().model, 1, 10, 27);
    ASSERT_TRUE(e.start().ok());
    EXPECT_TRUE(e.running());
    const Status again = e.start();
    EXPECT_FALSE(again.ok());
    EXPECT_NE(again.message().find("already running"), std::string::npos);
    EXPECT_EQ(e.processNow(frames[0].view()).step, -1);
    EXPECT_EQ(e.processPending(), 0u);
    e.stop();
    EXPECT_FALSE(e.running());
}

} // namespace
} // namespace rost
