#include "worker_pool.hpp"

#include <algorithm>
#include <cstdio>
#include <string>
#include <system_error>

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
// A range word's top 24 bits: the job's generation, so that a claim can tell
// this job's word from a later one's (the one definition both sides use).
constexpr int kTagShift = 40;
constexpr uint64_t tagOf(uint32_t generation) noexcept { return generation & 0xFFFFFFu; }

inline void cpuRelax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#elif defined(__aarch64__) || (defined(__arm__) && defined(__ARM_ARCH) && __ARM_ARCH >= 7)
    __asm__ __volatile__("yield");
#endif
}

} // namespace

WorkerPool::WorkerPool(int workers)
    : workers_(workers < 1 ? 1 : workers),
      ranges_(std::make_unique<Range[]>(static_cast<std::size_t>(workers_))),
      partCuts_(std::make_unique<uint32_t[]>(static_cast<std::size_t>(workers_) + 1)),
      partBegun_(std::make_unique<uint8_t[]>(static_cast<std::size_t>(workers_))) {
    start(nullptr);
}

WorkerPool::~WorkerPool() { stopThreads(); }

void WorkerPool::start(const ThreadSettings* settings) {
    stop_.store(false, std::memory_order_relaxed);
    threads_.reserve(static_cast<std::size_t>(workers_ - 1));
    // Each thread starts from the generation of now, so a job posted before
    // it first looks is not missed.
    const uint32_t gen = generation_.load(std::memory_order_relaxed);
    try {
        for (int i = 1; i < workers_; ++i)
            threads_.emplace_back([this, i, settings, gen] { workerMain(i, settings, gen); });
    } catch (const std::system_error& e) {
        // A process or memory limit, after some threads or none: those started
        // are stopped and joined (a joinable std::thread destroyed would call
        // std::terminate), and the error names the setting to lower.
        stopThreads();
        throw std::system_error(e.code(), "cannot start the refinement's threads (threads = " +
                                              std::to_string(workers_) + "; lower it)");
    } catch (...) {  // no memory for a thread's state: the same clean-up
        stopThreads();
        throw;
    }
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

void WorkerPool::waitFor(std::atomic<uint32_t>& a, uint32_t want) noexcept {
    for (int i = 0; i < kSpinIterations; ++i) {
        if (a.load(std::memory_order_acquire) == want) return;
        cpuRelax();
    }
    for (uint32_t v; (v = a.load(std::memory_order_acquire)) != want;) a.wait(v, std::memory_order_acquire);
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
            s.cpu = workerCpu(s.cpu, index, n);
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
        const uint32_t ran = runTasks(index, seen);
        if (ran > 0) countDone(ran, count_);
    }
}

// Claims the front task of the range the caller owns (only the owner moves
// its front; thieves move the end), c being the word as the caller's last
// claim left it. False when no task is left there.
bool WorkerPool::claimFront(std::atomic<uint64_t>& word, uint64_t c) noexcept {
    const uint64_t next = c & kField;
    for (;;) {
        if (next >= ((c >> 20) & kField)) return false;
        if (word.compare_exchange_weak(c, c + 1, std::memory_order_acquire, std::memory_order_acquire)) return true;
    }
}

uint32_t WorkerPool::runTasks(int worker, uint32_t generation) noexcept {
    const uint64_t gen = tagOf(generation);
    uint32_t ran = 0;
    bool begun = false;
    // Its own range from the front, then the others' from the back.
    for (int i = 0; i < workers_; ++i) {
        std::atomic<uint64_t>& word = ranges_[static_cast<std::size_t>((worker + i) % workers_)].word;
        uint64_t c = word.load(std::memory_order_acquire);
        for (;;) {
            if ((c >> kTagShift) != gen) return ran;  // a later job's word: this one is over
            const uint64_t end = (c >> 20) & kField, next = c & kField;
            if (next >= end) break;
            // A successful claim of a task not yet done pins the job: the
            // caller cannot start another before this task is counted done.
            // Nothing of the job (job_ included) is read before it.
            const uint64_t claimed = i == 0 ? c + 1 : c - (uint64_t{1} << 20);
            if (!word.compare_exchange_weak(c, claimed, std::memory_order_acquire, std::memory_order_acquire)) continue;
            ++ran;
            if (!begun) {
                begun = true;
                job_->begin(worker);
            }
            // A job that takes pairs: the owner takes the next task of its
            // range too while one is left.
            const bool two = i == 0 && job_->pairs && claimFront(word, claimed);
            if (two) {
                ++ran;
                job_->taskPair(worker, static_cast<uint32_t>(next));
            } else {
                job_->task(worker, static_cast<uint32_t>(i == 0 ? next : end - 1));
            }
            c = word.load(std::memory_order_acquire);
        }
    }
    return ran;
}

void WorkerPool::runInTurn(Job& job, uint32_t count) noexcept {
    for (uint32_t i = 0; i < count;) {
        if (job.pairs && i + 1 < count) {
            job.taskPair(0, i);
            i += 2;
        } else {
            job.task(0, i++);
        }
    }
}

void WorkerPool::countDone(uint32_t ran, uint32_t count) noexcept {
    // The line holding the count moves between cores once per worker and job, not per task.
    if (done_.fetch_add(ran, std::memory_order_acq_rel) + ran == count) done_.notify_one();
}

namespace {
// Tasks base.. of a job too large for one range's 20 bits, as a job of its
// own. The whole job's begin() runs once per worker, at its first task of
// any part (`begun`: one flag a worker, each written by its own worker).
struct JobPart final : WorkerPool::Job {
    WorkerPool::Job* whole = nullptr;
    uint32_t base = 0;
    uint8_t* begun = nullptr;
    void begin(int worker) noexcept override {
        if (begun[worker] == 0) {
            begun[worker] = 1;
            whole->begin(worker);
        }
    }
    void task(int worker, uint32_t index) noexcept override { whole->task(worker, base + index); }
    void taskPair(int worker, uint32_t index) noexcept override { whole->taskPair(worker, base + index); }
};
} // namespace

void WorkerPool::run(Job& job, uint32_t count, const uint32_t* cuts) noexcept {
    ++jobs_;
    if (count == 0) return;
    if (workers_ == 1) {
        job.begin(0);
        runInTurn(job, count);
        return;
    }
    if (count > kField) {
        // A range holds 20 bits: a job of 2^20 tasks or more (the cells of a
        // 1024 x 1024 grid of 1-pixel cells) runs in parts of 2^19, one after
        // the other, each task once, each worker's begin() once, and each
        // worker's own range (cuts) its own within every part.
        constexpr uint32_t kPart = uint32_t{1} << 19;
        const auto n = static_cast<std::size_t>(workers_);
        std::fill(partBegun_.get(), partBegun_.get() + n, uint8_t{0});
        JobPart part;
        part.whole = &job;
        part.pairs = job.pairs;
        part.begun = partBegun_.get();
        for (uint32_t base = 0; base < count; base += kPart) {
            part.base = base;
            const uint32_t size = std::min(kPart, count - base);
            if (cuts)
                for (std::size_t w = 0; w <= n; ++w)
                    partCuts_[w] = std::clamp(cuts[w], base, base + size) - base;
            run(part, size, cuts ? partCuts_.get() : nullptr);
            --jobs_;
        }
        return;
    }
    job_ = &job;
    count_ = count;
    done_.store(0, std::memory_order_relaxed);
    const uint32_t g = generation_.load(std::memory_order_relaxed) + 1;
    const uint64_t gen = tagOf(g) << kTagShift;
    const auto n = static_cast<uint64_t>(workers_);
    for (uint64_t w = 0; w < n; ++w) {
        const uint64_t lo = cuts ? cuts[w] : count * w / n, hi = cuts ? cuts[w + 1] : count * (w + 1) / n;
        // Release: a worker's claim (an acquire CAS) that matches this job's tag, even one
        // that read a generation 2^24 jobs old, is then ordered after job_ and count_.
        ranges_[w].word.store(gen | (hi << 20) | lo, std::memory_order_release);
    }
    generation_.store(g, std::memory_order_release);
    generation_.notify_all();
    const uint32_t ran = runTasks(0, g);
    if (ran > 0) countDone(ran, count);
    waitFor(done_, count);
}

} // namespace rost::detail
