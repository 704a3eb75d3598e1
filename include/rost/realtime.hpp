#pragma once

// Scheduling of the refiner thread, in one named configuration (priority,
// CPU pinning, memory locking). Where the system does not permit a setting
// (an unprivileged desktop, a container without CAP_SYS_NICE) the thread runs
// on with the default scheduler, and the fallback is logged to stderr once
// per process and per setting.

#include <cstdint>
#include <string>

#include "rost/settings_schema.hpp"

namespace rost {

struct ThreadSettings {
    const char* name = "rost-refiner";  // thread name (15 characters at most are kept)
    bool fifo = settingDefault<bool>("thread.fifo");              // request SCHED_FIFO
    int priority = settingDefault<int>("thread.priority");        // SCHED_FIFO priority
    int cpu = settingDefault<int>("thread.cpu");                  // pin to this CPU; -1 leaves the affinity alone
    bool lock_memory = settingDefault<bool>("thread.lock-memory"); // mlockall(MCL_CURRENT | MCL_FUTURE) at start()

    // What an onboard deployment uses: SCHED_FIFO 80, pinned to the last CPU,
    // memory locked. The library default leaves all three off, so tests and
    // desktop runs never compete with the system at realtime priority.
    static ThreadSettings onboard() noexcept;
};

// What applying the settings achieved.
struct ThreadSettingsReport {
    bool fifo = false;
    bool pinned = false;
    bool memory_locked = false;
    std::string message;  // one line per fallback, empty when everything requested was applied
};

// Applies the thread-level settings (name, SCHED_FIFO, affinity) to the
// calling thread. Logs each fallback to stderr once per process. Set-up
// code: may allocate (the report's message).
ThreadSettingsReport applyToCurrentThread(const ThreadSettings& s);
// mlockall(MCL_CURRENT | MCL_FUTURE); false (logged once) when not permitted.
bool lockProcessMemory(std::string* why = nullptr);

} // namespace rost
