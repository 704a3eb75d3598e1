#include "worker_pool.hpp"

#include <cstdio>

#if defined(__x86_64__) || defined(__i386__)
#include <emmintrin.h>
#endif

namespace rost::detail {
namespace {

// About 50-200 microseconds of spinning before a worker parks: longer than
// the gap between two rounds of a window, far shorter than the gap between
// two observations.
constexpr int kSpinIterations = 2048;
constexpr uint64_t kField = (uint64_t{1} << 20) - 1;

inline void cpuRelax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#elif defined(__aarch64__) || (defined(__arm__) && defined(__ARM_ARCH) && __ARM_ARCH >= 7)
    __asm__ __volatile__("yield");
#endif
}

} // namespace

WorkerPool::WorkerPool(int workers) : workers_(workers < 1 ? 1 : workers) { start(nullptr); }

WorkerPool::~WorkerPool() { stopThreads(); }

void WorkerPool::start(const ThreadSettings* settings) {
    stop_.store(false, std::memory_order_relaxed);
    threads_.reserve(static_cast<std::size_t>(workers_ - 1));
    // Each thread starts from the generation of now, so a job posted before
    // it first looks is not missed.
    const uint32_t gen = generation_.load(std::memory_order_relaxed);
    for (int i = 1; i < workers_; ++i)
        threads_.emplace_back([this, i, settings, gen] { workerMain(i, settings, gen); });
}

void WorkerPool::stopThreads() noexcept {
    if (threads_.empty()) return;
    stop_.store(true, std::memory_order_relaxed);
    generation_.fetch_add(1, std::memory_order_release);
    generation_.notify_all();
    for (std::thread& t : threads_) t.join();
    threads_.clear();
}

void WorkerPool::applySettings(const ThreadSettings& settings) {
    stopThreads();
    settings_ = std::make_unique<ThreadSettings>(settings);
    start(settings_.get());
}

void WorkerPool::waitChange(std::atomic<uint32_t>& a, uint32_t old) noexcept {
    for (int i = 0; i < kSpinIterations; ++i) {
        if (a.load(std::memory_order_acquire) != old) return;
        cpuRelax();
    }
    while (a.load(std::memory_order_acquire) == old) a.wait(old, std::memory_order_acquire);
}

void WorkerPool::workerMain(int index, const ThreadSettings* settings, uint32_t seen) noexcept {
    if (settings) {
        ThreadSettings s = *settings;
        char name[16];
        std::snprintf(name, sizeof name, "rost-worker-%d", index);
        s.name = name;
        s.lock_memory = false;  // the process's memory is the engine's to lock
        if (s.cpu >= 0) {
            const int n = static_cast<int>(std::thread::hardware_concurrency());
            s.cpu = n > 0 ? ((s.cpu - index) % n + n) % n : -1;
        }
        try {
            (void)applyToCurrentThread(s);
        } catch (...) {  // a report that could not be built: the thread runs unpinned
        }
    }
    for (;;) {
        waitChange(generation_, seen);
        seen = generation_.load(std::memory_order_acquire);
        if (stop_.load(std::memory_order_relaxed)) return;
        runTasks(index, seen);
    }
}

void WorkerPool::runTasks(int worker, uint32_t generation) noexcept {
    const uint64_t gen = generation & 0xFFFFFFu;
    uint64_t c = claim_.load(std::memory_order_acquire);
    for (;;) {
        if ((c >> 40) != gen) return;  // a later job's word: this one is over
        const uint64_t count = (c >> 20) & kField, next = c & kField;
        if (next >= count) return;
        // A successful claim of a task not yet done pins the job: the caller
        // cannot start another before this task is counted done.
        if (!claim_.compare_exchange_weak(c, c + 1, std::memory_order_acquire, std::memory_order_acquire)) continue;
        job_->task(worker, static_cast<uint32_t>(next));
        if (done_.fetch_add(1, std::memory_order_acq_rel) + 1 == count) done_.notify_one();
        c = claim_.load(std::memory_order_acquire);
    }
}

void WorkerPool::run(Job& job, uint32_t count) noexcept {
    ++jobs_;
    if (count == 0) return;
    if (workers_ == 1) {
        for (uint32_t i = 0; i < count; ++i) job.task(0, i);
        return;
    }
    job_ = &job;
    done_.store(0, std::memory_order_relaxed);
    const uint32_t g = generation_.load(std::memory_order_relaxed) + 1;
    claim_.store((static_cast<uint64_t>(g & 0xFFFFFFu) << 40) | (static_cast<uint64_t>(count) << 20),
                 std::memory_order_release);
    generation_.store(g, std::memory_order_release);
    generation_.notify_all();
    runTasks(0, g);
    for (int i = 0; i < kSpinIterations; ++i) {
        if (done_.load(std::memory_order_acquire) == count) return;
        cpuRelax();
    }
    for (uint32_t d; (d = done_.load(std::memory_order_acquire)) != count;) done_.wait(d, std::memory_order_acquire);
}

} // namespace rost::detail
