// Zero heap allocations on the capture (tryPush), refiner and reader paths
// after start(), and in synchronous processNow(). This binary replaces
// operator new/delete and the malloc family with counting versions (the
// technique of Eigen's test/nomalloc.cpp); counting is armed only around
// the code under test, and the first test shows the counter does catch
// allocations. (Under ThreadSanitizer, which owns malloc, only operator new
// and delete are replaced.)

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <thread>
#include <vector>

#include "rost/engine.hpp"
#include "test_engine_support.hpp"

#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
#define ROST_TEST_REPLACE_MALLOC 0
#else
#define ROST_TEST_REPLACE_MALLOC 1
#endif

namespace {
std::atomic<bool> g_armed{false};
std::atomic<uint64_t> g_allocations{0};
inline void noteAllocation() noexcept {
    if (g_armed.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
} // namespace

#if ROST_TEST_REPLACE_MALLOC
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t n) {
    noteAllocation();
    return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
    noteAllocation();
    return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
    noteAllocation();
    return __libc_realloc(p, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
    noteAllocation();
    return __libc_memalign(a, n);
}
void* memalign(std::size_t a, std::size_t n) {
    noteAllocation();
    return __libc_memalign(a, n);
}
int posix_memalign(void** out, std::size_t a, std::size_t n) {
    noteAllocation();
    void* p = __libc_memalign(a, n);
    if (p == nullptr) return 12;  // ENOMEM
    *out = p;
    return 0;
}
void free(void* p) { __libc_free(p); }
}
#endif

// operator new counts itself and allocates without going through the
// (counting) malloc, so one allocation counts once.
namespace {
void* rawMalloc(std::size_t n) noexcept {
#if ROST_TEST_REPLACE_MALLOC
    return __libc_malloc(n ? n : 1);
#else
    return std::malloc(n ? n : 1);
#endif
}
void* rawAligned(std::size_t al, std::size_t n) noexcept {
#if ROST_TEST_REPLACE_MALLOC
    return __libc_memalign(al, n ? n : 1);
#else
    return std::aligned_alloc(al, (n + al - 1) / al * al);
#endif
}
// Out of line, so the compiler does not pair operator new with free().
[[gnu::noinline]] void rawFree(void* p) noexcept {
#if ROST_TEST_REPLACE_MALLOC
    __libc_free(p);
#else
    std::free(p);
#endif
}
} // namespace

void* operator new(std::size_t n) {
    noteAllocation();
    if (void* p = rawMalloc(n)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
    noteAllocation();
    return rawMalloc(n);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a) {
    noteAllocation();
    if (void* p = rawAligned(static_cast<std::size_t>(a), n)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p) noexcept { rawFree(p); }
void operator delete[](void* p) noexcept { rawFree(p); }
void operator delete(void* p, std::size_t) noexcept { rawFree(p); }
void operator delete[](void* p, std::size_t) noexcept { rawFree(p); }
void operator delete(void* p, std::align_val_t) noexcept { rawFree(p); }
void operator delete[](void* p, std::align_val_t) noexcept { rawFree(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { rawFree(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { rawFree(p); }

namespace rost {
namespace {

using rost::testing::Frame;
using rost::testing::makeStream;
using rost::testing::smallConfig;

// Arms the counter for its lifetime and reports what it counted.
class Counting {
public:
    Counting() {
        g_allocations.store(0);
        g_armed.store(true);
    }
    ~Counting() { g_armed.store(false); }
    uint64_t count() const { return g_allocations.load(); }
};

TEST(NoMalloc, TheCounterCatchesNewMallocAndAGrowingVector) {
    {
        Counting c;
        int* volatile p = new int(3);  // volatile: a new/delete pair may be elided otherwise
        delete p;
        EXPECT_EQ(c.count(), 1u) << "operator new";
    }
#if ROST_TEST_REPLACE_MALLOC
    {
        Counting c;
        void* volatile p = std::malloc(64);
        std::free(p);
        EXPECT_EQ(c.count(), 1u) << "malloc";
    }
#endif
    {
        Counting c;
        std::vector<int> v;
        for (int i = 0; i < 100; ++i) v.push_back(i);
        EXPECT_GT(c.count(), 0u) << "std::vector growth";
    }
    {
        Counting c;
        std::thread t([] {});
        t.join();
        EXPECT_GT(c.count(), 0u) << "starting a thread";
    }
}

EngineConfig config(Budget b, DropPolicy drop, int threads = 1, bool grow = false);

// The counter also sees allocations made on the refiner thread: a hook that
// allocates is caught.
TEST(NoMalloc, TheCounterCatchesAnAllocationOnTheRefinerThread) {
    EngineConfig c;
    c.model = smallConfig();
    c.budget = Budget::steps(1);
    Engine e(c);
    e.setObservationHook([](const ObservationResult&, const Model&) {
        std::vector<int>* volatile v = new std::vector<int>(16);
        delete v;
    });
    const auto frames = makeStream(c.model, 8, 50, 30);
    ASSERT_TRUE(e.start().ok());
    uint64_t counted = 0;
    {
        Counting count;
        for (const Frame& f : frames) ASSERT_TRUE(e.pushWait(f.view()));
        while (e.counters().ingested < frames.size()) std::this_thread::yield();
        counted = count.count();
    }
    e.stop();
    EXPECT_GE(counted, frames.size());
}

EngineConfig config(Budget b, DropPolicy drop, int threads, bool grow) {
    EngineConfig e;
    e.model = smallConfig();
    e.model.threads = threads;
    e.model.grow = grow;
    e.model.gamma = 0.5;
    e.budget = b;
    e.drop = drop;
    e.queue_slots = 4;
    return e;
}

// Thousands of observations through tryPush, the refiner thread and
// snapshot reads, under each budget kind and drop policy: nothing allocates
// between start() returning and stop().
void runThreaded(Budget b, DropPolicy drop, int threads = 1, bool grow = false) {
    Engine e(config(b, drop, threads, grow));
    const auto frames = makeStream(e.config().model, 64, 300, 31);
    Snapshot snap = e.makeSnapshot();
    ASSERT_TRUE(e.start().ok());
    uint64_t reads = 0, accepted = 0;
    {
        Counting c;
        for (int i = 0; i < 4000; ++i) {
            // Nine pushes in ten wait for a free slot (pushWait); the tenth
            // may hit a full queue and exercise the drop path.
            const ObservationView v = frames[static_cast<std::size_t>(i) % frames.size()].view();
            accepted += (i % 10 != 0 ? e.pushWait(v) : e.tryPush(v)) ? 1 : 0;
            if (i % 4 == 0) reads += e.readSnapshot(snap) ? 1 : 0;
            if (i % 8 == 0) (void)e.counters();
            if (i % 2 == 0) std::this_thread::yield();
        }
        // Let the refiner catch up while still counting.
        while (e.queued() > 0) std::this_thread::yield();
        reads += e.readSnapshot(snap) ? 1 : 0;
        EXPECT_EQ(c.count(), 0u) << "allocations on the realtime paths";
    }
    e.stop();
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.pushed, 4000u);
    EXPECT_EQ(k.ingested + k.dropped(), k.pushed);
    EXPECT_GT(k.ingested, 3000u) << "thousands of observations went through";
    EXPECT_GT(reads, 0u);
    EXPECT_GT(accepted, 0u);
    if (grow) {
        EXPECT_GT(e.model().growthMovesAccepted(), 0u) << "split and merge moves ran on the refiner";
    }
}

TEST(NoMalloc, ThreadedEngineMakesNoAllocationAfterStartWithAStepBudget) {
    runThreaded(Budget::steps(2), DropPolicy::DropOldest);
}
TEST(NoMalloc, ThreadedEngineMakesNoAllocationAfterStartWithATokenBudget) {
    runThreaded(Budget::tokens(300), DropPolicy::DropNewest);
}
TEST(NoMalloc, ThreadedEngineMakesNoAllocationAfterStartWithATimeBudget) {
    runThreaded(Budget::time(0.2), DropPolicy::DropOldest);
}

// With refinement workers (refine.window 256, threads 3): the rounds, the
// pool's barrier and parking between observations allocate nothing.
TEST(NoMalloc, ThreadedEngineWithRefinementWorkersMakesNoAllocationAfterStart) {
    runThreaded(Budget::steps(4), DropPolicy::DropOldest, 3);
    runThreaded(Budget::time(0.2), DropPolicy::DropNewest, 3);
}

// Growing topics: opening and closing topics, the open set recomputed after
// each round, numbering the outputs, allocate nothing.
TEST(NoMalloc, ThreadedEngineWithGrowingTopicsMakesNoAllocationAfterStart) {
    runThreaded(Budget::steps(2), DropPolicy::DropOldest, 1, true);
    runThreaded(Budget::steps(4), DropPolicy::DropOldest, 3, true);
}

// The engine's publication of results (Engine::publishResults): the refiner
// copies every observation's results and every leaving observation's final
// labels into its rings, and this thread reads them, with nothing allocated
// on either side after start().
TEST(NoMalloc, ThreadedEngineWithPublishedResultsMakesNoAllocationAfterStart) {
    Engine e(config(Budget::steps(2), DropPolicy::DropOldest));
    ASSERT_TRUE(e.publishResults(8).ok());
    const auto frames = makeStream(e.config().model, 64, 300, 33);
    PublishedResult result = e.makeResult();
    FinalLabels final = e.makeFinal();
    ASSERT_TRUE(e.start().ok());
    uint64_t results = 0, finals = 0;
    {
        Counting c;
        for (int i = 0; i < 2000; ++i) {
            ASSERT_TRUE(e.pushWait(frames[static_cast<std::size_t>(i) % frames.size()].view()));
            while (e.readResult(result)) ++results;
            while (e.readFinal(final)) ++finals;
        }
        // Every observation published a result; all but the last ring's worth left the window.
        const uint64_t expected = 2000u + (2000u - static_cast<uint64_t>(e.config().model.ring_steps));
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
        while (results + finals + e.resultsLost() < expected && std::chrono::steady_clock::now() < until) {
            while (e.readResult(result)) ++results;
            while (e.readFinal(final)) ++finals;
            std::this_thread::yield();
        }
        EXPECT_EQ(c.count(), 0u) << "allocations on the publication paths";
    }
    e.stop();
    EXPECT_GT(results, 0u);
    EXPECT_GT(finals, 0u);
    EXPECT_EQ(results + finals + e.resultsLost(), 2000u + (2000u - static_cast<uint64_t>(e.config().model.ring_steps)));
}

// The measurements on the workers (threads 3, observations of 300 words over
// 12 cells, above the 256 words that go to the pool): the surprise of
// addObservation, both perplexities of a step, the labels, from the model and
// from the engine's eviction hook, allocate nothing.
TEST(NoMalloc, MeasurementsOnTheWorkersMakeNoAllocation) {
    Engine e(config(Budget::steps(2), DropPolicy::DropOldest, 3));
    const auto frames = makeStream(e.config().model, 64, 300, 34);
    std::vector<uint16_t> labels(512);
    double sum = 0.0;
    e.setEvictionHook([&](const WindowObservation& w, const Model& m) { sum += m.stepPerplexity(w.step); });
    Model& m = e.model();
    uint64_t measured = 0;
    {
        Counting c;
        for (int i = 0; i < 200; ++i) {
            e.processNow(frames[static_cast<std::size_t>(i) % frames.size()].view());
            const uint64_t jobs = m.poolJobs();
            const int64_t t = m.steps() - 1;
            sum += m.stepPerplexity(t) + m.stepPluginPerplexity(t);
            m.observationLabels(m.observations() - 1, {labels.data(), m.observationSize(m.observations() - 1)});
            measured += m.poolJobs() - jobs;
        }
        e.flushWindowToEvictionHook();
        EXPECT_EQ(c.count(), 0u) << "allocations on the measurement paths";
    }
    EXPECT_EQ(measured, 3u * 200u) << "every measurement ran on the workers";
    EXPECT_GT(sum, 0.0);
}

TEST(NoMalloc, SynchronousProcessNowEvictionAndFinalPassMakeNoAllocation) {
  for (const int threads : {1, 2}) {
    Engine e(config(Budget::steps(2), DropPolicy::DropOldest, threads));
    const auto frames = makeStream(e.config().model, 64, 300, 32);
    Snapshot snap = e.makeSnapshot();
    uint64_t evicted = 0;
    e.setEvictionHook([&](const WindowObservation&, const Model&) { ++evicted; });
    {
        Counting c;
        for (int i = 0; i < 2000; ++i) e.processNow(frames[static_cast<std::size_t>(i) % frames.size()].view());
        EXPECT_TRUE(e.readSnapshot(snap));
        e.refineExtra(Budget::steps(10));
        e.finalPass(1);
        e.flushWindowToEvictionHook();
        EXPECT_EQ(c.count(), 0u) << threads << " threads";
    }
    EXPECT_EQ(evicted, 2000u);
  }
}

} // namespace
} // namespace rost
