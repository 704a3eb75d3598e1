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
constexpr int kSpinIterations = 4096;

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
        job_->work(index);
        if (remaining_.fetch_sub(1, std::memory_order_acq_rel) == 1) remaining_.notify_one();
    }
}

void WorkerPool::run(Job& job) noexcept {
    ++jobs_;
    if (workers_ == 1) {
        job.work(0);
        return;
    }
    job_ = &job;
    remaining_.store(static_cast<uint32_t>(workers_ - 1), std::memory_order_relaxed);
    generation_.fetch_add(1, std::memory_order_release);
    generation_.notify_all();
    job.work(0);
    for (int i = 0; i < kSpinIterations; ++i) {
        if (remaining_.load(std::memory_order_acquire) == 0) return;
        cpuRelax();
    }
    for (uint32_t r; (r = remaining_.load(std::memory_order_acquire)) != 0;) remaining_.wait(r, std::memory_order_acquire);
}

} // namespace rost::detail
