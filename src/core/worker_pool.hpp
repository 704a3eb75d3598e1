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
// A job is `count` independent tasks. Every thread, the caller included,
// claims tasks one at a time from a shared word that also holds the job's
// generation and task count, so a worker that wakes late (descheduled on a
// loaded machine) finds the job over and claims nothing: run() returns as
// soon as every task is done, whoever did them, and never waits for a
// worker that is not running. Every task's writes are visible to the caller
// when run() returns, and the caller's writes before run() to every task.

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

    // Runs tasks 0..count-1 of the job (count < 2^20) on the workers and the
    // caller (worker 0); returns when all are done.
    void run(Job& job, uint32_t count) noexcept;

    // Jobs run so far (for tests).
    uint64_t jobs() const noexcept { return jobs_; }

private:
    void start(const ThreadSettings* settings);
    void stopThreads() noexcept;
    void workerMain(int index, const ThreadSettings* settings, uint32_t seen) noexcept;
    static void waitChange(std::atomic<uint32_t>& a, uint32_t old) noexcept;
    // Claims and runs tasks of the job of `generation` until none is left.
    void runTasks(int worker, uint32_t generation) noexcept;

    int workers_;
    alignas(64) std::atomic<uint32_t> generation_{0};  // bumped per job (workers park on it)
    // generation (24 bits) | count (20 bits) | next task (20 bits)
    alignas(64) std::atomic<uint64_t> claim_{0};
    alignas(64) std::atomic<uint32_t> done_{0};
    std::atomic<bool> stop_{false};
    Job* job_ = nullptr;
    uint64_t jobs_ = 0;
    std::vector<std::thread> threads_;
    std::unique_ptr<ThreadSettings> settings_;
};

} // namespace rost::detail
