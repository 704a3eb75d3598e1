#pragma once

// A one-line progress bar on stderr (frames, frames/s, ETA), drawn only when
// stderr is a terminal and the user did not ask for quiet.

#include <signal.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

namespace rost::tool {

class Progress {
public:
    // total < 0: unknown length (no bar, no ETA).
    Progress(std::string label, int64_t total, bool quiet);
    ~Progress() { finish(); }
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    bool enabled() const noexcept { return enabled_; }
    // Redraws at most ten times a second (and always for the last frame).
    void update(int64_t done, const std::string& note = {});
    // Clears the line.
    void finish();

private:
    std::string label_;
    int64_t total_;
    bool enabled_;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point start_, last_;
};

// Whether stderr is a terminal.
bool stderrIsTerminal() noexcept;

// Ctrl-C (SIGINT) and SIGTERM while a file run works: from construction to
// destruction they set interruptFlag() instead of killing the process, so
// the command abandons its staging directory and exits 130 (a camera run
// ends and writes its outputs). The handlers before it come back after.
//
// By default a system call the signal lands in is restarted (threads of a
// run need not see EINTR). A command whose blocking calls are its reads of
// input files (rost merge: a checkpoint's engine starts pool threads, which
// wait in calls that retry) asks for Reads::Interrupted: a read blocked on
// a FIFO or a pipe then fails, and the command, seeing interrupted(),
// exits 130 rather than waiting for a writer. `reads(Reads::Restarted)`
// changes that once the inputs are read (rost refine), the flag kept.
class InterruptScope {
public:
    enum class Reads : uint8_t { Restarted, Interrupted };
    explicit InterruptScope(Reads reads = Reads::Restarted) noexcept;
    ~InterruptScope();
    void reads(Reads reads) noexcept;
    InterruptScope(const InterruptScope&) = delete;
    InterruptScope& operator=(const InterruptScope&) = delete;

private:
    struct sigaction old_int_ {};
    struct sigaction old_term_ {};
};
const std::atomic<bool>& interruptFlag() noexcept;
inline bool interrupted() noexcept { return interruptFlag().load(std::memory_order_relaxed); }
// A file run abandoned by a signal: says so on stderr ("rost: interrupted;
// no outputs written") and returns the exit code, 130 (kExitInterrupted).
// The staging directory goes with the command's OutputDir.
int abandonedRun();

} // namespace rost::tool
