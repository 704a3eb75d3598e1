#include "rost/realtime.hpp"
#include "realtime_log.hpp"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <thread>

#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#endif

namespace rost {

namespace {

// Each fallback is logged once per process, so a program that starts many
// engines (tests, benches) says it once.
std::atomic<bool> g_logged_fifo{false};
std::atomic<bool> g_logged_pin{false};
std::atomic<bool> g_logged_lock{false};

} // namespace

void detail::forgetLoggedFallbacks() noexcept {
    g_logged_fifo.store(false);
    g_logged_pin.store(false);
    g_logged_lock.store(false);
}

namespace {

void logOnce(std::atomic<bool>& flag, const std::string& line) {
    if (!flag.exchange(true)) std::fprintf(stderr, "rost: %s\n", line.c_str());
}

} // namespace

ThreadSettings ThreadSettings::onboard() noexcept {
    ThreadSettings s;
    s.fifo = true;
    s.priority = 80;
    const unsigned n = std::thread::hardware_concurrency();
    s.cpu = n > 1 ? static_cast<int>(n) - 1 : -1;
    s.lock_memory = true;
    return s;
}

ThreadSettingsReport applyToCurrentThread(const ThreadSettings& s) {
    ThreadSettingsReport report;
    auto fallback = [&](std::atomic<bool>& flag, const std::string& line) {
        if (!report.message.empty()) report.message += '\n';
        report.message += line;
        logOnce(flag, line);
    };
#if defined(__linux__)
    if (s.name != nullptr && s.name[0] != '\0') {
        char name[16];
        std::snprintf(name, sizeof(name), "%s", s.name);
        pthread_setname_np(pthread_self(), name);
    }
    if (s.cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        if (s.cpu < CPU_SETSIZE) CPU_SET(s.cpu, &set);
        const int rc = s.cpu < CPU_SETSIZE ? pthread_setaffinity_np(pthread_self(), sizeof(set), &set) : EINVAL;
        if (rc == 0) {
            report.pinned = true;
        } else {
            fallback(g_logged_pin, "could not pin the refiner thread to CPU " + std::to_string(s.cpu) + " (" +
                                       std::strerror(rc) + "); it runs on any CPU");
        }
    }
    if (s.fifo) {
        sched_param sp{};
        sp.sched_priority = s.priority;
        const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
        if (rc == 0) {
            report.fifo = true;
        } else {
            fallback(g_logged_fifo, "SCHED_FIFO priority " + std::to_string(s.priority) +
                                        " not permitted for the refiner thread (" + std::strerror(rc) +
                                        "); it runs with the default scheduler. Grant CAP_SYS_NICE or an "
                                        "rtprio limit (/etc/security/limits.conf) to enable it");
        }
    }
#else
    if (s.cpu >= 0) fallback(g_logged_pin, "CPU pinning is not supported on this system; the refiner runs on any CPU");
    if (s.fifo) fallback(g_logged_fifo, "SCHED_FIFO is not supported on this system; the refiner runs with the default scheduler");
#endif
    return report;
}

bool lockProcessMemory(std::string* why) {
#if defined(__linux__)
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) return true;
    const std::string line = std::string("mlockall not permitted (") + std::strerror(errno) +
                             "); memory may be paged out. Grant CAP_IPC_LOCK or raise the memlock limit to enable it";
#else
    const std::string line = "mlockall is not supported on this system; memory may be paged out";
#endif
    if (why) *why = line;
    logOnce(g_logged_lock, line);
    return false;
}

} // namespace rost
