#pragma once

// A persistent pool of refinement workers (internal to the library).
//
// The thread that calls run() is worker 0 and takes part in the job; the
// pool's own threads are workers 1..n-1. Between jobs a worker spins for a
// bounded time (rounds of one window follow each other within microseconds)
// and then parks on a futex (std::atomic::wait), so more threads than cores,
// or other load, never livelock and idle workers cost nothing between time
// steps. run() allocates nothing, takes no lock and makes no blocking call
// while the workers are busy; waking a parked worker is a futex wake.
//
// A job is `count` independent tasks, cut into one contiguous range per
// worker (by default even; the caller may give the cuts, so that a worker
// keeps the cells whose data are already in its cache). Each worker takes
// the tasks of its own range from the front; when it is empty it steals
// from the back of the others'. A range is one word that also holds the
// job's generation, so a worker that wakes late (descheduled on a loaded
// machine) finds the job over and claims nothing: the tasks are done by
// whoever runs, and run() never waits for a worker that is not running.
//
// Every task's writes are visible to the caller when run() returns, and
// the caller's writes before run() to every task.

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "rost/realtime.hpp"

namespace rost::detail {

class WorkerPool {
public:
    // One task of a job, run by worker `worker` (in [0, workers()); its
    // scratch may be indexed by it).
    class Job {
    public:
        virtual void task(int worker, uint32_t index) noexcept = 0;
        // Run by a worker once per job, after it has claimed its first task
        // and before running it (so the job cannot end while it runs); a
        // worker that claims no task of the job does not run it.
        virtual void begin(int /*worker*/) noexcept {}
        // Tasks index and index + 1 at once: with `pairs` set, a worker
        // claims the tasks of its own range two at a time while two are
        // left (thieves still take one). Default: one, then the other.
        virtual void taskPair(int worker, uint32_t index) noexcept {
            task(worker, index);
            task(worker, index + 1);
        }
        bool pairs = false;

    protected:
        ~Job() = default;
    };

    // `workers` counts the caller: workers - 1 threads are started. Set-up
    // code: allocates and may throw std::system_error.
    explicit WorkerPool(int workers);
    ~WorkerPool();
    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

    int workers() const noexcept { return workers_; }

    // Restarts the threads with these scheduling settings: named
    // "rost-worker-N", SCHED_FIFO as requested, and, when settings.cpu >= 0,
    // worker N pinned to CPU (cpu - N) modulo the CPUs of the machine (the
    // refiner keeps `cpu`). Set-up code.
    void applySettings(const ThreadSettings& settings);
    // The CPU worker `index` is pinned to with thread.cpu = `cpu` on a
    // machine of `cpus` CPUs: the CPUs below the refiner's, wrapping round.
    static int workerCpu(int cpu, int index, int cpus) noexcept {
        return cpus > 0 ? ((cpu - index) % cpus + cpus) % cpus : -1;
    }

    // Runs tasks 0..count-1 of the job on the workers and the caller (worker
    // 0); returns when all are done. A job of 2^20 tasks or more runs in
    // parts of 2^19 (its begin() once a worker, its cuts kept), one after
    // the other.
    // `cuts`, when given, holds workers() + 1 ascending task indices from 0
    // to count: worker w's own range is [cuts[w], cuts[w + 1]).
    void run(Job& job, uint32_t count, const uint32_t* cuts = nullptr) noexcept;

    // Runs tasks 0..count-1 of the job on the calling thread, in turn (in
    // pairs where the job takes them so), as worker 0. No begin().
    static void runInTurn(Job& job, uint32_t count) noexcept;

    // Jobs run so far (for tests).
    uint64_t jobs() const noexcept { return jobs_; }

private:
    void start(const ThreadSettings* settings);
    void stopThreads() noexcept;
    void workerMain(int index, const ThreadSettings* settings, uint32_t seen) noexcept;
    static void waitChange(std::atomic<uint32_t>& a, uint32_t old) noexcept;
    // Claims and runs tasks of the job of `generation` until none is left;
    // returns how many it ran.
    uint32_t runTasks(int worker, uint32_t generation) noexcept;
    static bool claimFront(std::atomic<uint64_t>& word, uint64_t c) noexcept;
    // Counts the worker's tasks done (one add per worker and job).
    void countDone(uint32_t ran, uint32_t count) noexcept;
    static void waitFor(std::atomic<uint32_t>& a, uint32_t want) noexcept;

    struct alignas(64) Range {
        // generation (24 bits) | end (20 bits) | next (20 bits)
        std::atomic<uint64_t> word{0};
    };

    int workers_;
    alignas(64) std::atomic<uint32_t> generation_{0};  // bumped per job (workers park on it)
    std::unique_ptr<Range[]> ranges_;
    std::unique_ptr<uint32_t[]> partCuts_;  // a part's cuts (workers + 1), for jobs run in parts
    std::unique_ptr<uint8_t[]> partBegun_;  // whether a worker has begun the job run in parts
    alignas(64) std::atomic<uint32_t> done_{0};  // tasks done
    std::atomic<bool> stop_{false};
    static_assert(std::atomic<uint64_t>::is_always_lock_free && std::atomic<uint32_t>::is_always_lock_free,
                  "the worker pool needs lock-free 32- and 64-bit atomics");
    Job* job_ = nullptr;
    uint32_t count_ = 0;
    uint64_t jobs_ = 0;
    std::vector<std::thread> threads_;
    std::unique_ptr<ThreadSettings> settings_;
};

} // namespace rost::detail
