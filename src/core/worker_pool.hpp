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
// The job decides what a worker does; the pool only guarantees that every
// worker's writes before it finishes are visible to the caller when run()
// returns, and the caller's writes before run() to every worker.

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "rost/realtime.hpp"

namespace rost::detail {

class WorkerPool {
public:
    // What every worker runs for one job: work(worker) with worker in [0, workers()).
    class Job {
    public:
        virtual void work(int worker) noexcept = 0;

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

    // Runs the job on every worker, the caller as worker 0, and returns when
    // all have finished.
    void run(Job& job) noexcept;

    // Jobs run so far (for tests).
    uint64_t jobs() const noexcept { return jobs_; }

private:
    void start(const ThreadSettings* settings);
    void stopThreads() noexcept;
    void workerMain(int index, const ThreadSettings* settings, uint32_t seen) noexcept;
    static void waitChange(std::atomic<uint32_t>& a, uint32_t old) noexcept;

    int workers_;
    alignas(64) std::atomic<uint32_t> generation_{0};
    alignas(64) std::atomic<uint32_t> remaining_{0};
    std::atomic<bool> stop_{false};
    Job* job_ = nullptr;
    uint64_t jobs_ = 0;
    std::vector<std::thread> threads_;
    std::unique_ptr<ThreadSettings> settings_;
};

} // namespace rost::detail
