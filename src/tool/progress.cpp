#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <utility>

#include "tool.hpp"

namespace rost::tool {

bool stderrIsTerminal() noexcept { return ::isatty(STDERR_FILENO) == 1; }

namespace {
std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "a signal handler may touch only lock-free atomics");
extern "C" void onInterrupt(int) { g_interrupted.store(true, std::memory_order_relaxed); }
} // namespace

const std::atomic<bool>& interruptFlag() noexcept { return g_interrupted; }

int abandonedRun() {
    std::fputs("rost: interrupted; no outputs written\n", stderr);
    return kExitInterrupted;
}

InterruptScope::InterruptScope(Reads reads) noexcept {
    g_interrupted.store(false, std::memory_order_relaxed);  // an earlier command's (tests run several in one process)
    ::sigaction(SIGINT, nullptr, &old_int_);
    ::sigaction(SIGTERM, nullptr, &old_term_);
    this->reads(reads);
}

void InterruptScope::reads(Reads reads) noexcept {
    struct sigaction on {};
    on.sa_handler = onInterrupt;
    sigemptyset(&on.sa_mask);
    on.sa_flags = reads == Reads::Restarted ? SA_RESTART : 0;
    for (const auto& [sig, old] : {std::pair{SIGINT, &old_int_}, std::pair{SIGTERM, &old_term_}})
        // A signal ignored on entry stays ignored (a shell's `rost refine ... &`
        // ignores SIGINT, so that Ctrl-C at the terminal ends only the foreground).
        if (old->sa_handler != SIG_IGN) ::sigaction(sig, &on, nullptr);
}

InterruptScope::~InterruptScope() {
    ::sigaction(SIGINT, &old_int_, nullptr);
    ::sigaction(SIGTERM, &old_term_, nullptr);
}

Progress::Progress(std::string label, int64_t total, bool quiet)
    : label_(std::move(label)), total_(total), enabled_(!quiet && stderrIsTerminal()) {
    start_ = last_ = std::chrono::steady_clock::now();
}

void Progress::update(int64_t done, const std::string& note) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    const bool last = total_ > 0 && done >= total_;
    if (drawn_ && !last && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    drawn_ = true;
    const double secs = std::chrono::duration<double>(now - start_).count();
    const double fps = secs > 0 ? static_cast<double>(done) / secs : 0.0;
    char line[256];
    if (total_ > 0) {
        constexpr int kWidth = 28;
        const double f = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
        const int filled = static_cast<int>(f * kWidth);
        char bar[kWidth + 1];
        for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '-';
        bar[kWidth] = '\0';
        const double eta = fps > 0 ? static_cast<double>(total_ - done) / fps : 0.0;
        const int e = static_cast<int>(eta + 0.5);
        std::snprintf(line, sizeof line, "\r%s [%s] %lld/%lld frames  %.1f frames/s  ETA %d:%02d  %s\033[K",
                      label_.c_str(), bar, static_cast<long long>(done), static_cast<long long>(total_), fps, e / 60,
                      e % 60, note.c_str());
    } else {
        std::snprintf(line, sizeof line, "\r%s %lld frames  %.1f frames/s  %s\033[K", label_.c_str(),
                      static_cast<long long>(done), fps, note.c_str());
    }
    std::fputs(line, stderr);
    std::fflush(stderr);
}

void Progress::finish() {
    if (enabled_ && drawn_) {
        std::fputs("\r\033[K", stderr);
        std::fflush(stderr);
    }
    drawn_ = false;
}

} // namespace rost::tool
