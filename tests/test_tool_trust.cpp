// The rost tool's mission options (docs/trust.md): --checkpoint FILE
// --checkpoint.every N, --resume FILE and --config FILE, their outputs and
// their errors (one line naming what and where, exit code 2, no outputs left).

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "rost/checkpoint.hpp"
#include "rost/config_file.hpp"
#include "rost/random.hpp"
#include "rost/topic_model_csv.hpp"
#include "test_vision_support.hpp"

using rost::testing::RunResult;
using rost::testing::TempDir;

namespace {

std::string tool() { return std::string("'") + ROST_TOOL + "'"; }
RunResult runRost(const std::string& args) { return rost::testing::runShell(tool() + " " + args); }

// A refused run: exit 2, one line naming the error, and nothing left in
// `out` but the files named in `before` (there before the run).
void expectError(const RunResult& r, const std::string& needle, const std::string& out,
                 const std::vector<std::string>& before = {}) {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "stderr: " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_EQ(r.err.rfind("rost: error: ", 0), 0u) << r.err;
    if (std::filesystem::exists(out))
        for (const auto& e : std::filesystem::directory_iterator(out))
            if (std::find(before.begin(), before.end(), e.path().filename().string()) == before.end())
                ADD_FAILURE() << "left behind: " << e.path();
}

// A small word stream: 40 observations of 12 words in a 64 x 64 frame.
void writeStream(const TempDir& t) {
    std::string words, positions;
    rost::Rng r(3);
    for (int f = 0; f < 40; ++f) {
        words += std::to_string(f);
        positions += std::to_string(f);
        for (int i = 0; i < 12; ++i) {
            const uint32_t x = r.below(64), y = r.below(64);
            words += ',';
            words += std::to_string((x < 32 ? 0u : 20u) + r.below(20));
            positions += ',';
            positions += std::to_string(x);
            positions += ',';
            positions += std::to_string(y);
        }
        words += "\n";
        positions += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    rost::testing::writeText(t / "positions.csv", positions);
}

std::string refine(const TempDir& t, const std::string& out, const std::string& extra) {
    return "refine " + (t / "words.csv") + " --positions " + (t / "positions.csv") + " --width 64 --height 64 -V 40 --out " +
           (t / out) + " --no-summary -q " + extra;
}

// The first n lines of a file, into another.
void head(const std::string& from, const std::string& to, int n) {
    std::istringstream in(rost::testing::readText(from));
    std::string line, text;
    for (int i = 0; i < n && std::getline(in, line); ++i) text += line + "\n";
    rost::testing::writeText(to, text);
}

// The lines of a file after the first n.
std::string tail(const std::string& path, int n) {
    std::istringstream in(rost::testing::readText(path));
    std::string line, text;
    for (int i = 0; std::getline(in, line); ++i)
        if (i >= n) text += line + "\n";
    return text;
}

// A mission stopped after the first 25 observations of writeStream's
// stream: w25.csv/p25.csv, outputs in first/, its checkpoint m.ckpt.
RunResult stopAfter25(const TempDir& t, const std::string& extra) {
    head(t / "words.csv", t / "w25.csv", 25);
    head(t / "positions.csv", t / "p25.csv", 25);
    return runRost("refine " + (t / "w25.csv") + " --positions " + (t / "p25.csv") + " --width 64 --height 64 -V 40 --out " +
                   (t / "first") + " --no-summary -q --checkpoint " + (t / "m.ckpt") + " " + extra);
}

int lines(const std::string& path) {
    const std::string text = rost::testing::readText(path);
    return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

TEST(ToolTrust, CheckpointHoldsTheWholeRunAndResumesInTheLibrary) {
    TempDir t;
    writeStream(t);
    const RunResult r = runRost(refine(t, "o", "--checkpoint " + (t / "run.ckpt") + " --checkpoint.every 7 --seed 5"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    rost::CheckpointInfo info;
    const rost::Status st = rost::readCheckpointInfo(t / "run.ckpt", info);
    ASSERT_TRUE(st.ok()) << st.message();
    EXPECT_EQ(info.observations, 40u);  // the final capture, after the last observation
    EXPECT_EQ(info.next_sequence, 40u);
    EXPECT_EQ(info.last_timestamp, 39);
    EXPECT_EQ(info.config.model.seed, 5u);
    EXPECT_EQ(info.config.model.V, 40);
    rost::Status s2;
    auto engine = rost::resumeEngine(t / "run.ckpt", s2);
    ASSERT_TRUE(engine) << s2.message();
    std::string why;
    EXPECT_TRUE(engine->model().checkInvariants(&why)) << why;
    // The topic model in the checkpoint is the one the run wrote.
    const std::string csv = rost::testing::readText(t / "o/topicmodel.csv");
    std::vector<int32_t> counts;
    ASSERT_TRUE(rost::parseTopicModelCsv(csv, engine->model().K(), engine->model().V(), counts).ok());
    for (int k = 0; k < engine->model().K(); ++k)
        for (int v = 0; v < engine->model().V(); ++v)
            ASSERT_EQ(counts[static_cast<std::size_t>(k) * 40 + static_cast<std::size_t>(v)],
                      engine->model().topicWordCount(k, v));
}

TEST(ToolTrust, CheckpointErrorsNameThePathWithExitCode2) {
    TempDir t;
    writeStream(t);
    // Probed before the input is read: nothing is written, not even the output directory.
    expectError(runRost(refine(t, "o", "--checkpoint /nonexistent/run.ckpt")),
                "--checkpoint: /nonexistent/run.ckpt: cannot write in /nonexistent: No such file or directory", t / "o");
    EXPECT_FALSE(std::filesystem::exists(t / "o"));
    std::filesystem::create_directory(t / "taken");
    expectError(runRost(refine(t, "o/deeper", "--checkpoint " + (t / "taken"))),
                "--checkpoint: " + (t / "taken") + ": is a directory, not a file that can be written", t / "o");
    EXPECT_FALSE(std::filesystem::exists(t / "o")) << "the directories a failed run made are removed";
    expectError(runRost(refine(t, "o", "--checkpoint " + (t / "c.ckpt") + " --checkpoint.every 0")),
                "--checkpoint.every", t / "o");
}

TEST(ToolTrust, ConfigFileSetsWhatTheCommandLineDoesNotAndTheCommandLineWins) {
    TempDir t;
    writeStream(t);
    rost::testing::writeText(t / "m.conf", "# mission\nK = 5\nalpha = 0.25\nbudget.refines = 3\nframe.width = 64\n");
    RunResult r = runRost(refine(t, "a", "--config " + (t / "m.conf") + " --checkpoint " + (t / "a.ckpt")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(lines(t / "a/topicmodel.csv"), 5);
    rost::CheckpointInfo info;
    ASSERT_TRUE(rost::readCheckpointInfo(t / "a.ckpt", info).ok());
    EXPECT_EQ(info.config.model.alpha, 0.25);
    EXPECT_EQ(info.config.budget.count, 3u);
    r = runRost(refine(t, "b", "--config " + (t / "m.conf") + " -K 7 --budget.refines 2 --checkpoint " + (t / "b.ckpt")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(lines(t / "b/topicmodel.csv"), 7);
    ASSERT_TRUE(rost::readCheckpointInfo(t / "b.ckpt", info).ok());
    EXPECT_EQ(info.config.model.K, 7);
    EXPECT_EQ(info.config.model.alpha, 0.25);
    EXPECT_EQ(info.config.budget.count, 2u);
}

TEST(ToolTrust, ConfigFileErrorsNameFileLineAndKeyWithExitCode2) {
    TempDir t;
    writeStream(t);
    const auto conf = [&](const std::string& text) {
        rost::testing::writeText(t / "x.conf", text);
        return refine(t, "o", "--config " + (t / "x.conf"));
    };
    expectError(runRost(conf("K = 5\nalfa = 0.1\n")), "--config: " + (t / "x.conf") + ":2: unknown key 'alfa' (did you mean 'alpha'?)",
                t / "o");
    expectError(runRost(conf("K = five\n")), (t / "x.conf") + ":1: key 'K': expected an integer, found 'five'", t / "o");
    expectError(runRost(conf("beta = 0\n")), (t / "x.conf") + ":1: key 'beta': invalid configuration: beta = 0", t / "o");
    expectError(runRost(conf("\nstop-on-arrival = true\n")),
                (t / "x.conf") + ":2: key 'stop-on-arrival' is not a setting of this command", t / "o");
    expectError(runRost(refine(t, "o", "--config " + (t / "missing.conf"))),
                "--config: " + (t / "missing.conf") + ": cannot open: No such file or directory", t / "o");
}

TEST(ToolTrust, FrameSourceFailingMidStreamStopsCleanlySaysWhyAndKeepsWhatWasLearnedAndWritten) {
    // Eight frames of textured noise; the fifth file is not an image.
    TempDir t;
    std::filesystem::create_directory(t / "frames");
    cv::RNG rng(7);
    for (int i = 1; i <= 8; ++i) {
        cv::Mat img(96, 128, CV_8UC3);
        rng.fill(img, cv::RNG::UNIFORM, 0, 255);
        ASSERT_TRUE(cv::imwrite(t / ("frames/f" + std::to_string(i) + ".png"), img));
    }
    rost::testing::writeText(t / "frames/f5.png", std::string(300, '\x5a'));
    // An earlier run's outputs in the same directory: the failed run must not touch them.
    RunResult r = runRost("run " + (t / "frames") + " --max-frames 3 --out " + (t / "o") + " --no-overlay --no-summary -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::string before = rost::testing::readText(t / "o/topics.csv");
    ASSERT_FALSE(before.empty());
    r = runRost("run " + (t / "frames") + " --out " + (t / "o") + " --checkpoint " + (t / "m.ckpt") +
                " --no-overlay --no-summary -q");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("f5.png: cannot decode image"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(rost::testing::readText(t / "o/topics.csv"), before);
    // What was learned before the failure is in the checkpoint, and loads.
    rost::CheckpointInfo info;
    rost::Status st;
    auto engine = rost::resumeEngine(t / "m.ckpt", st, &info);
    ASSERT_TRUE(engine) << st.message();
    EXPECT_EQ(info.observations, 4u);
    EXPECT_EQ(info.last_timestamp, 3);
}

// Ctrl-C or SIGTERM while `rost refine` works (here in final sweeps that
// would take minutes): the sweeps end at once, exit 130 with one line, and
// the output directory is as it was: an earlier run's file kept, nothing
// staged left behind. (The shell's `wait` gives 130 for a process killed by
// SIGINT too: the line says the tool took it; a kill by SIGTERM gives 143.)
TEST(ToolTrust, ASignalAbandonsARefineRunWithExitCode130AndKeepsWhatWasThere) {
    TempDir t;
    std::string words, positions;
    rost::Rng r(11);
    for (int f = 0; f < 200; ++f) {  // 12,000 words: a final sweep takes about half a millisecond
        words += std::to_string(f);
        positions += std::to_string(f);
        for (int i = 0; i < 60; ++i) {
            words += ',';
            words += std::to_string(r.below(40));
            positions += ',';
            positions += std::to_string(r.below(64));
            positions += ',';
            positions += std::to_string(r.below(64));
        }
        words += "\n";
        positions += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    rost::testing::writeText(t / "positions.csv", positions);
    for (const char* sig : {"INT", "TERM"}) {
        SCOPED_TRACE(sig);
        std::filesystem::remove_all(t / "out");
        std::filesystem::create_directories(t / "out");
        rost::testing::writeText(t / "out/topics.csv", "an earlier run's\n");
        // The signal comes half a second after the run has staged its files;
        // `timeout` passes it on, and kills a run still going 30 s later (137).
        const std::string script = "{ timeout -s KILL 30 " + tool() + " " + refine(t, "out", "--final.sweeps 1000000") +
                                   " & pid=$!; i=0; while ! ls -A '" + (t / "out") +
                                   "' | grep -q rost-partial && [ $i -lt 600 ]; do i=$((i+1)); sleep 0.05; done; "
                                   "sleep 0.5; kill -" + sig + " $pid; wait $pid; }";
        const RunResult res = rost::testing::runShell(script);
        EXPECT_EQ(res.exit_code, 130) << "137: the final sweeps went on after the signal; " << res.err;
        EXPECT_EQ(res.err, "rost: interrupted; no outputs written\n");
        EXPECT_EQ(rost::testing::readText(t / "out/topics.csv"), "an earlier run's\n");
        for (const auto& e : std::filesystem::directory_iterator(t / "out"))
            if (e.path().filename() != "topics.csv") ADD_FAILURE() << "left behind: " << e.path();
    }
    // A SIGINT ignored on entry stays ignored: a non-interactive shell's
    // `rost refine ... &` ignores it (so Ctrl-C ends only the foreground job),
    // and the run goes on to write its outputs.
    std::filesystem::remove_all(t / "out");
    const std::string script = "{ " + tool() + " " + refine(t, "out", "--final.sweeps 3000") +
                               " & pid=$!; i=0; while ! ls -A '" + (t / "out") +
                               "' 2>/dev/null | grep -q rost-partial && [ $i -lt 600 ]; do i=$((i+1)); sleep 0.05; done; "
                               "sleep 0.2; kill -INT $pid; wait $pid; }";
    const RunResult res = rost::testing::runShell(script);
    EXPECT_EQ(res.exit_code, 0) << res.err;
    EXPECT_TRUE(std::filesystem::exists(t / "out/topics.csv"));
}

namespace {

// Starts `rost ARGS...` with its stderr to `err`; the child's pid.
pid_t spawnRost(const std::vector<std::string>& args, const std::string& err) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        // SIGINT as a terminal's foreground job has it, whatever this test
        // binary inherited (a script's background job ignores it).
        ::signal(SIGINT, SIG_DFL);
        ::signal(SIGTERM, SIG_DFL);
        sigset_t none;
        sigemptyset(&none);
        ::sigprocmask(SIG_SETMASK, &none, nullptr);
        const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
        ::dup2(fd, 2);
        std::vector<char*> argv{const_cast<char*>(ROST_TOOL)};
        for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        ::execv(ROST_TOOL, argv.data());
        ::_exit(127);
    }
    return pid;
}

// Opens FIFO for writing once a reader has it open (O_NONBLOCK fails before
// that), within `limit`; -1 if none came.
int openWriterOnceRead(const std::string& fifo, std::chrono::seconds limit) {
    const auto until = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < until) {
        const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
        if (fd >= 0) return fd;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return -1;
}

// Waits for `pid` to end within `limit`: true and its status if it did.
// With `signal`, sends it every 100 ms meanwhile (one that lands between
// opening a file and blocking in its read is seen only after the read).
bool endsWithin(pid_t pid, std::chrono::seconds limit, int& status, int signal = 0) {
    const auto until = std::chrono::steady_clock::now() + limit;
    for (int i = 0; std::chrono::steady_clock::now() < until; ++i) {
        if (::waitpid(pid, &status, WNOHANG) == pid) return true;
        if (signal != 0 && i % 10 == 0) ::kill(pid, signal);
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
}

// Whether `file` (a run's stderr) says `what` within `limit`.
bool saysWithin(const std::string& file, const std::string& what, std::chrono::seconds limit) {
    const auto until = std::chrono::steady_clock::now() + limit;
    for (; std::chrono::steady_clock::now() < until; std::this_thread::sleep_for(std::chrono::milliseconds(20)))
        if (rost::testing::readText(file).find(what) != std::string::npos) return true;
    return false;
}

} // namespace

// rost merge, interrupted while it reads its models (one comes from a FIFO
// that this test serves once it is opened, the signal first):
// exit 130, the one-line note, and nothing written, a previous merge's file
// kept, as a refine's.
TEST(ToolTrust, ASignalAbandonsAMergeWithExitCode130AndKeepsWhatWasThere) {
    TempDir t;
    std::string words;
    for (int i = 0; i < 20; ++i) {
        words += std::to_string(i);
        for (int j = 0; j < 30; ++j) (words += ',') += std::to_string((i * 7 + j * 3) % 40);
        words += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    const RunResult made = runRost("refine " + (t / "words.csv") + " -K 3 --out " + (t / "a") + " -q --no-summary");
    ASSERT_EQ(made.exit_code, 0) << made.err;
    const std::string model = rost::testing::readText(t / "a/topicmodel.csv");
    const std::string pipe = t / "b.csv";
    ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
    std::filesystem::create_directories(t / "m");
    rost::testing::writeText(t / "m/topicmodel.csv", "an earlier merge's\n");
    const std::string err = t / "err.txt";
    const pid_t pid = spawnRost({"merge", t / "a/topicmodel.csv", pipe, "--out", t / "m"}, err);
    ASSERT_GE(pid, 0);
    void (*pipeHandler)(int) = std::signal(SIGPIPE, SIG_IGN);  // the merge may close its end first
    bool signalled = false, served = false;
    int status = 0;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (::waitpid(pid, &status, WNOHANG) == 0) {
        if (std::chrono::steady_clock::now() > until) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            break;
        }
        // Opens for writing only once the merge opens the FIFO to read it:
        // past its set-up, reading its models.
        const int fd = served ? -1 : ::open(pipe.c_str(), O_WRONLY | O_NONBLOCK);
        if (fd < 0) {
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
            continue;
        }
        if (!signalled) {
            ::kill(pid, SIGINT);
            signalled = true;
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        ::fcntl(fd, F_SETFL, 0);
        (void)!::write(fd, model.data(), model.size());
        ::close(fd);
        served = true;
    }
    std::signal(SIGPIPE, pipeHandler);
    ASSERT_TRUE(signalled) << "the merge never opened its FIFO";
    ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    EXPECT_EQ(WEXITSTATUS(status), 130);
    EXPECT_EQ(rost::testing::readText(err), "rost: interrupted; no outputs written\n");
    EXPECT_EQ(rost::testing::readText(t / "m/topicmodel.csv"), "an earlier merge's\n");
    for (const auto& e : std::filesystem::directory_iterator(t / "m"))
        if (e.path().filename() != "topicmodel.csv") ADD_FAILURE() << "left behind: " << e.path();
}


// A merge whose model comes through a FIFO that a writer holds open and
// stops writing to: Ctrl-C ends the read the merge is blocked in, and the
// merge exits 130 as interrupted (a restarted read waited for the writer;
// a read interrupted with a line in hand read on and waited again).
TEST(ToolTrust, CtrlCEndsAMergeBlockedReadingAFifo) {
    // The writer sends nothing, or a line and then nothing more (a read
    // interrupted with bytes in hand must end too, not wait again).
    for (const std::string& sent : {std::string(), std::string("0,1,2\n")}) {
        SCOPED_TRACE(sent.empty() ? "nothing sent" : "a line sent");
        TempDir t;
        const std::string pipe = t / "a.csv";
        ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
        const pid_t pid = spawnRost({"merge", pipe, pipe, "--out", t / "m"}, t / "err.txt");
        ASSERT_GE(pid, 0);
        const int writer = openWriterOnceRead(pipe, std::chrono::seconds(60));
        EXPECT_GE(writer, 0) << "the merge never opened its FIFO";
        if (writer >= 0 && !sent.empty()) (void)!::write(writer, sent.data(), sent.size());
        std::this_thread::sleep_for(std::chrono::milliseconds(300));  // into its read
        ::kill(pid, SIGINT);
        int status = 0;
        const bool ended = endsWithin(pid, std::chrono::seconds(10), status);
        // Not ended: one Ctrl-C was not enough; more (as a user would press) tell a hang from that.
        const bool endedLater = ended || endsWithin(pid, std::chrono::seconds(10), status, SIGINT);
        if (writer >= 0) ::close(writer);
        if (!endedLater) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
        }
        ASSERT_TRUE(ended) << (endedLater ? "one Ctrl-C did not end a merge blocked reading a FIFO (more did)"
                                          : "Ctrl-C did not end a merge blocked reading a FIFO");
        ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
        EXPECT_EQ(WEXITSTATUS(status), 130);
        EXPECT_EQ(rost::testing::readText(t / "err.txt"), "rost: interrupted; no outputs written\n");
        EXPECT_FALSE(std::filesystem::exists(t / "m"));
    }
}

// Whether process `pid` waits in the kernel at `channel` (/proc/PID/wchan),
// checked every 10 ms for up to `limit`. False where /proc does not say.
bool waitsAt(pid_t pid, const std::string& channel, std::chrono::seconds limit) {
    const std::string path = "/proc/" + std::to_string(pid) + "/wchan";
    for (const auto until = std::chrono::steady_clock::now() + limit; std::chrono::steady_clock::now() < until;
         std::this_thread::sleep_for(std::chrono::milliseconds(10)))
        if (rost::testing::readText(path) == channel) return true;
    return false;
}

// rost refine and rost merge of a FIFO whose writer never comes, Ctrl-C
// while they wait in open() for it: exit 130 at once, nothing written (the
// refine's open was restarted after the signal and waited for ever).
TEST(ToolTrust, CtrlCEndsAWaitForAFifosWriterThatNeverComes) {
    for (const std::string command : {"refine", "merge"}) {
        SCOPED_TRACE(command);
        TempDir t;
        const std::string pipe = t / "words.csv";
        ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
        const pid_t pid = spawnRost({command, pipe, "--out", t / "o"}, t / "err.txt");
        ASSERT_GE(pid, 0);
        // In open(), waiting for a writer: the kernel's "wait_for_partner" (a second where /proc does not say).
        if (!waitsAt(pid, "wait_for_partner", std::chrono::seconds(30)))
            std::this_thread::sleep_for(std::chrono::seconds(1));
        ::kill(pid, SIGINT);
        int status = 0;
        const bool ended = endsWithin(pid, std::chrono::seconds(10), status);
        if (!ended) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
        }
        ASSERT_TRUE(ended) << "Ctrl-C did not end a " << command << " waiting for its FIFO's writer";
        ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
        EXPECT_EQ(WEXITSTATUS(status), 130);
        EXPECT_EQ(rost::testing::readText(t / "err.txt"), "rost: interrupted; no outputs written\n");
        EXPECT_FALSE(std::filesystem::exists(t / "o"));
    }
}

// A checkpoint merged through a FIFO: read once, as a topic model's CSV is
// (it was opened a second time to be loaded, and the merge hung).
TEST(ToolTrust, ACheckpointMergesThroughAFifo) {
    TempDir t;
    writeStream(t);
    const RunResult made = runRost("refine " + (t / "words.csv") + " -K 3 --out " + (t / "a") +
                                   " --checkpoint " + (t / "a.ckpt") + " -q --no-summary");
    ASSERT_EQ(made.exit_code, 0) << made.err;
    const RunResult direct = runRost("merge " + (t / "a.ckpt") + " " + (t / "a/topicmodel.csv") + " --out " + (t / "d") + " -q");
    ASSERT_EQ(direct.exit_code, 0) << direct.err;
    const std::string pipe = t / "b.ckpt";
    ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
    const pid_t pid = spawnRost({"merge", pipe, t / "a/topicmodel.csv", "--out", t / "m", "-q"}, t / "err.txt");
    ASSERT_GE(pid, 0);
    void (*pipeHandler)(int) = std::signal(SIGPIPE, SIG_IGN);
    const int writer = openWriterOnceRead(pipe, std::chrono::seconds(60));
    if (writer >= 0) {
        const std::string ckpt = rost::testing::readText(t / "a.ckpt");
        ::fcntl(writer, F_SETFL, 0);
        (void)!::write(writer, ckpt.data(), ckpt.size());
        ::close(writer);
    }
    std::signal(SIGPIPE, pipeHandler);
    int status = 0;
    const bool ended = endsWithin(pid, std::chrono::seconds(30), status);
    if (!ended) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        FAIL() << "the merge of a checkpoint through a FIFO hung";
    }
    ASSERT_GE(writer, 0) << "the merge never opened its FIFO";
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0) << rost::testing::readText(t / "err.txt");
    EXPECT_EQ(rost::testing::readText(t / "m/topicmodel.csv"), rost::testing::readText(t / "d/topicmodel.csv"));
    EXPECT_EQ(rost::testing::readText(t / "m/lifting.csv"), rost::testing::readText(t / "d/lifting.csv"));
}

// A checkpoint to a FIFO no process reads: its writer waited for a reader
// for ever, and Ctrl-C or SIGTERM only restarted the wait. Now the save
// fails at once, the run ends naming it (exit 2) and leaves no outputs.
// (`timeout` turns a hang back into a failure here rather than a stuck suite.)
TEST(ToolTrust, ACheckpointToAFifoNoProcessReadsFailsTheRunAtOnce) {
    TempDir t;
    writeStream(t);
    const std::string fifo = t / "ckpt";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const RunResult r = rost::testing::runShell("timeout -s KILL 120 " + tool() + " " + refine(t, "o", "--checkpoint " + fifo));
    expectError(r, "--checkpoint: " + fifo + ": cannot open for writing: a FIFO that no process reads (start its reader first)",
                t / "o");
}

// A checkpoint (or a bag) written over an input of the same run would replace
// it: refused by name, however the path is spelled, before anything is read.
TEST(ToolTrust, ACheckpointOverAnInputIsRefusedAndTheInputKept) {
    TempDir t;
    writeStream(t);
    const std::string words = rost::testing::readText(t / "words.csv");
    expectError(runRost(refine(t, "o", "--checkpoint " + (t / "words.csv"))),
                "rost: error: --checkpoint: " + (t / "words.csv") + " is an input of this run: writing there would replace it",
                t / "o");
    expectError(runRost(refine(t, "o", "--checkpoint " + t.path() + "/../" +
                                           std::filesystem::path(t.path()).filename().string() + "/positions.csv")),
                "is the same file as the input " + (t / "positions.csv") + ": writing there would replace it", t / "o");
    EXPECT_EQ(rost::testing::readText(t / "words.csv"), words);
    // Nor one of the run's own outputs, nor the bag's file: one would replace the other.
    expectError(runRost(refine(t, "o", "--checkpoint " + (t / "o/topicmodel.csv"))),
                "rost: error: --checkpoint: " + (t / "o/topicmodel.csv") + " is one of the run's outputs (" +
                    (t / "o/topicmodel.csv") + "): one would replace the other",
                t / "o");
    expectError(runRost("run " + (t / "clip.avi") + " --out " + (t / "v") + " --checkpoint " + (t / "x.bag") +
                        " --out.bag " + (t / "x.bag")),
                "rost: error: --out.bag: " + (t / "x.bag") + " is the --checkpoint file too: one would replace the other",
                t / "v");
    // An image directory's frames: a checkpoint among them would change the input.
    std::filesystem::create_directories(t / "frames");
    rost::testing::writeText(t / "frames/0001.png", "not read: the outputs are checked first");
    expectError(runRost("run " + (t / "frames") + " --out " + (t / "v") + " --checkpoint " + (t / "frames/0002.png")),
                "rost: error: --checkpoint: " + (t / "frames/0002.png") + " would be read by the input " +
                    (t / "frames") + ": writing there would change it",
                t / "v");
    EXPECT_FALSE(std::filesystem::exists(t / "frames/0002.png"));
    // The vocabulary is an input too (refused before it is read: any content will do).
    rost::testing::writeText(t / "v.rostvoc", "a vocabulary");
    expectError(runRost("run " + (t / "frames") + " --out " + (t / "v") + " --vocabulary " + (t / "v.rostvoc") +
                        " --checkpoint " + (t / "v.rostvoc")),
                "rost: error: --checkpoint: " + (t / "v.rostvoc") + " is an input of this run: writing there would replace it",
                t / "v");
    EXPECT_EQ(rost::testing::readText(t / "v.rostvoc"), "a vocabulary");
    // A words file the run's own results would replace.
    std::filesystem::create_directories(t / "o2");
    std::filesystem::copy_file(t / "words.csv", t / "o2/perplexity.csv");
    expectError(runRost("refine " + (t / "o2/perplexity.csv") + " --out " + (t / "o2") + " -q --no-summary"),
                "rost: error: --out: " + (t / "o2/perplexity.csv") + " is an input of this run: writing there would replace it",
                t / "o2", {"perplexity.csv"});
    EXPECT_EQ(rost::testing::readText(t / "o2/perplexity.csv"), words);
    // Only the files the run writes count: no summary.png under --no-summary.
    std::filesystem::create_directories(t / "o3");
    std::filesystem::copy_file(t / "words.csv", t / "o3/summary.png");
    expectError(runRost("refine " + (t / "o3/summary.png") + " --out " + (t / "o3") + " -q"),
                "rost: error: --out: " + (t / "o3/summary.png") + " is an input of this run: writing there would replace it",
                t / "o3", {"summary.png"});
    const RunResult kept = runRost("refine " + (t / "o3/summary.png") + " --out " + (t / "o3") + " -q --no-summary");
    EXPECT_EQ(kept.exit_code, 0) << kept.err;
    EXPECT_EQ(rost::testing::readText(t / "o3/summary.png"), words);
    EXPECT_TRUE(std::filesystem::exists(t / "o3/topics.csv"));
    std::filesystem::create_directories(t / "o4/summary.png");  // nor is a directory in its place refused
    expectError(runRost("refine " + (t / "words.csv") + " --out " + (t / "o4") + " -q"),
                "rost: error: " + (t / "o4/summary.png") + ": is a directory, not a file that can be written", t / "o4",
                {"summary.png"});
    const RunResult noSummary = runRost("refine " + (t / "words.csv") + " --out " + (t / "o4") + " -q --no-summary");
    EXPECT_EQ(noSummary.exit_code, 0) << noSummary.err;
    ASSERT_EQ(runRost(refine(t, "o", "--checkpoint " + (t / "m.ckpt"))).exit_code, 0);
}

TEST(ToolTrust, ResumedRefineContinuesBitForBitAsIfNeverStopped) {
    TempDir t;
    writeStream(t);
    // Uninterrupted: all 40 observations.
    const std::string ring = " --ring.steps 48 --seed 5 --budget.refines 6";
    RunResult r = runRost(refine(t, "full", ring));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    // Stopped after 25 (the stream so far), then resumed with the whole stream:
    // the 25 observations the checkpoint holds are skipped.
    r = stopAfter25(t, ring);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    r = runRost("refine " + (t / "words.csv") + " --positions " + (t / "positions.csv") + " --out " + (t / "rest") +
                " --no-summary --resume " + (t / "m.ckpt") + " --checkpoint " + (t / "m.ckpt"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("resuming " + (t / "m.ckpt") + " at observation 25 (time stamp 24); 25 observations skipped"),
              std::string::npos)
        << r.err;
    // Same topic model, same final labels for every observation (all still in
    // the window), and the rows of the 15 new observations are the last 15 of
    // the uninterrupted run's.
    EXPECT_EQ(rost::testing::readText(t / "rest/topicmodel.csv"), rost::testing::readText(t / "full/topicmodel.csv"));
    EXPECT_EQ(rost::testing::readText(t / "rest/topics.csv"), rost::testing::readText(t / "full/topics.csv"));
    EXPECT_EQ(lines(t / "rest/perplexity.csv"), 16);
    EXPECT_EQ(tail(t / "rest/perplexity.csv", 1), tail(t / "full/perplexity.csv", 26));
    EXPECT_EQ(tail(t / "rest/surprise.csv", 1), tail(t / "full/surprise.csv", 26));
    // The checkpoint now holds the whole stream.
    rost::CheckpointInfo info;
    ASSERT_TRUE(rost::readCheckpointInfo(t / "m.ckpt", info).ok());
    EXPECT_EQ(info.observations, 40u);
    EXPECT_EQ(info.last_timestamp, 39);
}

TEST(ToolTrust, ResumeMayChangeRefinementAndSaysSo) {
    TempDir t;
    writeStream(t);
    RunResult r = stopAfter25(t, "--ring.steps 48");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    r = runRost(refine(t, "next", "--resume " + (t / "m.ckpt") + " --sampler now --budget.refines 2 --checkpoint " +
                                      (t / "n.ckpt")));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    rost::CheckpointInfo info;
    ASSERT_TRUE(rost::readCheckpointInfo(t / "n.ckpt", info).ok());
    EXPECT_EQ(info.observations, 40u);
    EXPECT_EQ(info.config.budget.count, 2u);
    EXPECT_STREQ(rost::toString(info.config.strategy.kind), "now");
    EXPECT_EQ(info.config.model.ring_steps, 48);  // the model is the checkpoint's
    EXPECT_EQ(r.err, "") << "-q: nothing on stderr, the resume's note neither";
    // -q keeps the note off stderr; without it the note says the run is not bit for bit.
    r = runRost("refine " + (t / "words.csv") + " --positions " + (t / "positions.csv") + " --out " + (t / "again") +
                " --no-summary --resume " + (t / "m.ckpt") + " --eta 0.25 --sampler uni+now");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("refinement settings changed (not bit for bit)"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("rost: resuming " + (t / "m.ckpt") + " at observation 25 (time stamp 24); 25 observations skipped"),
              std::string::npos)
        << r.err;
}

// The rows of rost refine's files begin with the
// observation's own time stamp, whatever it is (every other test counts
// from 0, where a time stamp and an observation's number agree).
TEST(ToolTrust, OutputRowsCarryTheStreamsOwnTimeStamps) {
    TempDir t;
    rost::testing::writeText(t / "w.csv", "100,1,2,3\n250,2,3,4\n1700000000000000000,3,4,5\n");
    rost::testing::writeText(t / "p.csv", "100,1,1,2,2,3,3\n250,1,1,2,2,3,3\n1700000000000000000,1,1,2,2,3,3\n");
    const RunResult r = runRost("refine " + (t / "w.csv") + " --positions " + (t / "p.csv") + " -K 2 -q --no-summary --out " +
                                (t / "o"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    for (const char* f : {"topics.csv", "perplexity.csv", "surprise.csv", "surprise_cells.csv"}) {
        std::vector<std::string> firsts;
        std::istringstream lines(rost::testing::readText(t / (std::string("o/") + f)));
        for (std::string line; std::getline(lines, line);)
            if (!line.starts_with("frame,")) firsts.push_back(line.substr(0, line.find(',')));
        EXPECT_EQ(firsts, (std::vector<std::string>{"100", "250", "1700000000000000000"})) << f;
    }
}

TEST(ToolTrust, ResumeErrorsNameWhatAndWhereWithExitCode2AndWriteNothing) {
    TempDir t;
    writeStream(t);
    RunResult r = stopAfter25(t, "--seed 5");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::string ckpt = t / "m.ckpt";
    const std::string bytes = rost::testing::readText(ckpt);
    const auto resume = [&](const std::string& file, const std::string& extra) {
        return runRost(refine(t, "o", "--resume " + file + " " + extra));
    };
    // The model cannot change; repeating it is fine (refine() passes -V 40 and the frame size).
    expectError(resume(ckpt, "-K 8"), "-K 8 differs from " + ckpt + "'s K = 16 (a resumed mission keeps its model; leave -K out)",
                t / "o");
    expectError(resume(ckpt, "--alpha 0.2"), "--alpha 0.2 differs from " + ckpt + "'s alpha = 0.1",
                t / "o");
    expectError(resume(ckpt, "--seed 6"), "--seed 6 differs from " + ckpt + "'s seed = 5", t / "o");
    expectError(resume(ckpt, "--in.topicmodel " + (t / "first/topicmodel.csv")),
                "--in.topicmodel cannot be used with --resume", t / "o");
    expectError(runRost("refine " + (t / "words.csv") + " --positions " + (t / "positions.csv") + " --width 80 --out " +
                        (t / "o") + " -q --no-summary --resume " + ckpt),
                "--resume " + ckpt + ": the frames are 80 pixels wide but " + ckpt + " models 64x64 frames", t / "o");
    // A word the checkpoint's vocabulary does not have.
    rost::testing::writeText(t / "big.csv", "30,1,2\n31,45,3\n");
    expectError(runRost("refine " + (t / "big.csv") + " --out " + (t / "o") + " -q --resume " + ckpt),
                (t / "big.csv") + ":2:4: word id 45 out of range [0, 40)", t / "o");
    // Nothing after the checkpoint.
    expectError(runRost("refine " + (t / "w25.csv") + " --positions " + (t / "p25.csv") + " --out " + (t / "o") +
                        " -q --resume " + ckpt),
                (t / "w25.csv") + ": nothing to resume with: its 25 observations are all in " + ckpt,
                t / "o");
    // Another stream numbered by frame as this one (time stamp 24 is its
    // observation 25 too): its words there are not the checkpoint's.
    {
        std::istringstream in(rost::testing::readText(t / "words.csv"));
        std::string line, other;
        while (std::getline(in, line)) {
            std::istringstream cells(line);
            std::string cell;
            std::getline(cells, cell, ',');
            other += cell;  // the time stamp kept, each word moved by one
            while (std::getline(cells, cell, ',')) other += "," + std::to_string((std::stoi(cell) + 1) % 40);
            other += "\n";
        }
        rost::testing::writeText(t / "other.csv", other);
    }
    expectError(runRost("refine " + (t / "other.csv") + " --positions " + (t / "positions.csv") + " --out " + (t / "o") +
                        " -q --no-summary --resume " + ckpt),
                (t / "other.csv") + ": not the stream " + ckpt + " was made from: its observation 25 (time stamp 24) lacks word ",
                t / "o");
    // Missing, truncated, corrupt files.
    expectError(resume(t / "none.ckpt", ""), "--resume: " + (t / "none.ckpt") + ": cannot open: No such file or directory",
                t / "o");
    rost::testing::writeText(t / "short.ckpt", bytes.substr(0, 300));
    expectError(resume(t / "short.ckpt", ""), "--resume: " + (t / "short.ckpt") + ": truncated: the file ends at byte 300",
                t / "o");
    std::string bad = bytes;
    bad[bytes.size() / 2] = static_cast<char>(bad[bytes.size() / 2] ^ 0x10);
    rost::testing::writeText(t / "bad.ckpt", bad);
    expectError(resume(t / "bad.ckpt", ""), "is corrupt: checksum", t / "o");
    // None of this touched the checkpoint.
    EXPECT_EQ(rost::testing::readText(ckpt), bytes);
}

TEST(ToolTrust, RunResumedAfterItsSourceFailedEndsAsIfItHadNeverFailed) {
    TempDir t;
    std::filesystem::create_directory(t / "frames");
    cv::RNG rng(11);
    std::vector<cv::Mat> images;
    for (int i = 1; i <= 8; ++i) {
        cv::Mat img(96, 128, CV_8UC3);
        rng.fill(img, cv::RNG::UNIFORM, 0, 255);
        images.push_back(img);
        ASSERT_TRUE(cv::imwrite(t / ("frames/f" + std::to_string(i) + ".png"), img));
    }
    // --max-frames counts the mission, so the same command line resumed ends where the first would have.
    const std::string opts = " --no-overlay --no-summary -q --budget.refines 4 --max-frames 7";
    RunResult r = runRost("run " + (t / "frames") + " --out " + (t / "full") + opts);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    // The sixth frame goes bad: the run stops there and keeps its checkpoint.
    rost::testing::writeText(t / "frames/f6.png", std::string(300, '\x5a'));
    r = runRost("run " + (t / "frames") + " --out " + (t / "o") + " --checkpoint " + (t / "m.ckpt") + opts);
    ASSERT_EQ(r.exit_code, 2) << r.err;
    // The frame is back; the mission carries on from the checkpoint.
    ASSERT_TRUE(cv::imwrite(t / "frames/f6.png", images[5]));
    r = runRost("run " + (t / "frames") + " --out " + (t / "o") + " --resume " + (t / "m.ckpt") + opts);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(rost::testing::readText(t / "o/topicmodel.csv"), rost::testing::readText(t / "full/topicmodel.csv"));
    EXPECT_EQ(rost::testing::readText(t / "o/topics.csv"), rost::testing::readText(t / "full/topics.csv"));
    EXPECT_EQ(tail(t / "o/perplexity.csv", 1), tail(t / "full/perplexity.csv", 6));
    EXPECT_EQ(lines(t / "o/frames.csv"), 1 + 2);
    EXPECT_NE(rost::testing::readText(t / "o/run.txt").find("resumed: " + (t / "m.ckpt") + " at observation 5 (frame 4)"),
              std::string::npos);
    // Frames of another size do not fit the checkpoint's model.
    expectError(runRost("run " + (t / "frames") + " --width 64 --out " + (t / "p") + " --resume " + (t / "m.ckpt") + opts),
                "--resume " + (t / "m.ckpt") + ": the frames are 64 pixels wide but " + (t / "m.ckpt") + " models 128x96 frames",
                t / "p");
    // Other words: the ids would mean something else.
    expectError(runRost("run " + (t / "frames") + " --no-orb --out " + (t / "p") + " --resume " + (t / "m.ckpt") + opts),
                "--resume " + (t / "m.ckpt") + ": its model has V = 5436 words but the extractors produce 436", t / "p");
    // Nothing after the checkpoint: refused before anything is read or written, the checkpoint untouched.
    const std::string bytes = rost::testing::readText(t / "m.ckpt");
    const auto mtime = std::filesystem::last_write_time(t / "m.ckpt");
    expectError(runRost("run " + (t / "frames") + " --max-frames 5 --out " + (t / "p") + " --resume " + (t / "m.ckpt") +
                        " --checkpoint " + (t / "m.ckpt") + " -q --no-overlay --no-summary --budget.refines 4"),
                "nothing to resume with: " + (t / "m.ckpt") + " has every frame up to 4 (--max-frames 5 counts the mission)",
                t / "p");
    EXPECT_FALSE(std::filesystem::exists(t / "p"));
    EXPECT_EQ(rost::testing::readText(t / "m.ckpt"), bytes);
    EXPECT_EQ(std::filesystem::last_write_time(t / "m.ckpt"), mtime);
}

namespace {

// `input`'s first `first` frames run into a checkpoint (DIR/a), then the
// rest resumed under --realtime (DIR/b): how long the resumed run took, in
// seconds (negative when either run failed).
double resumedRealtimeSeconds(const TempDir& t, const std::string& input, int first) {
    const std::string opts = " --no-overlay --no-summary -q --budget.refines 2 -K 4";
    RunResult r = runRost("run " + input + " --max-frames " + std::to_string(first) + " --out " + (t / "a") +
                          " --checkpoint " + (t / "m.ckpt") + opts);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const auto start = std::chrono::steady_clock::now();
    const RunResult resumed = runRost("run " + input + " --realtime --out " + (t / "b") + " --resume " + (t / "m.ckpt") + opts);
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(resumed.exit_code, 0) << resumed.err;
    return r.exit_code == 0 && resumed.exit_code == 0 ? took : -1.0;
}

} // namespace

// A resumed --realtime run of a file is paced from the first frame it
// plays: frame i is due (i - the checkpoint's frames) / rate after the start,
// not i / rate (which waited out the checkpoint's 19 s before its first
// frame). 200 images (10 frames/s, an image sequence's pace), 190 in the
// checkpoint: the resumed run plays 10, in about 0.9 s.
TEST(ToolTrust, AResumedRealtimeRunIsPacedFromItsFirstFramePlayed) {
    TempDir t;
    std::filesystem::create_directory(t / "frames");
    cv::RNG rng(12);
    cv::Mat img(48, 64, CV_8UC3);
    for (int i = 0; i < 200; ++i) {
        rng.fill(img, cv::RNG::UNIFORM, 0, 255);
        char name[32];
        std::snprintf(name, sizeof name, "frames/f%03d.png", i);
        ASSERT_TRUE(cv::imwrite(t / name, img));
    }
    const double took = resumedRealtimeSeconds(t, t / "frames", 190);
    ASSERT_GE(took, 0.0);
    EXPECT_EQ(lines(t / "b/frames.csv"), 1 + 10);
    EXPECT_GE(took, 0.85) << "paced: the tenth frame played is due 0.9 s after the first";
    EXPECT_LT(took, 12.0) << "paced from frame 0, the checkpoint's 190 frames (19 s) were waited out first";
}

// A variable-frame-rate video under --realtime plays at its frames' own
// times, and frames.csv carries them. The clip's last 5 frames come 0.5 s
// apart, after 10 at 10 a second: resumed after the first 10, a run plays
// the 5 in 2 s, where the clip's nominal rate (15 frames over its duration,
// 6.5 a second) would have played them in 0.6 s.
TEST(ToolTrust, ARealtimeRunPlaysAVariableRateVideoAtItsFramesTimes) {
    namespace rt = rost::testing;
    TempDir t;
    if (!rt::writeVariableRateClip(t / "vfr.mp4")) GTEST_SKIP() << "no ffmpeg to encode a variable-rate clip with";
    const double took = resumedRealtimeSeconds(t, t / "vfr.mp4", 10);
    ASSERT_GE(took, 0.0);
    EXPECT_GE(took, 1.95) << "the clip's last frame is due 2 s after its eleventh";
    std::vector<std::string> rows = rt::lines(rt::readText(t / "a/frames.csv"));
    const std::vector<std::string> resumed = rt::lines(rt::readText(t / "b/frames.csv"));
    ASSERT_EQ(rows.size(), 1 + 10u);
    ASSERT_EQ(resumed.size(), 1 + 5u);
    rows.insert(rows.end(), resumed.begin() + 1, resumed.end());
    for (std::size_t i = 0; i < rt::kVariableRateClipUs.size(); ++i)
        EXPECT_EQ(rt::fields(rows[1 + i]).at(1), std::to_string(rt::kVariableRateClipUs[i])) << "frame " << i;
}

// A jump in a video's times (two transport streams joined, the second's
// clock 60 s on) is played as one frame period, not waited out; a long
// wait that is the video's own (a frame every 20 s) ends at Ctrl-C.
TEST(ToolTrust, ARealtimeRunNeitherStallsOnAJumpInItsTimesNorIgnoresCtrlCWhileWaiting) {
    TempDir t;
    const std::string clip = "ffmpeg -v error -f lavfi -i testsrc=size=160x120:rate=";
    const std::string enc = " -c:v libx264 -pix_fmt yuv420p ";
    const std::string make = "command -v ffmpeg > /dev/null && " + clip + "10 -frames:v 10" + enc + "'" + (t / "a.ts") +
                             "' && " + clip + "10 -frames:v 10" + enc + "-output_ts_offset 60 '" + (t / "b.ts") +
                             "' && cat '" + (t / "a.ts") + "' '" + (t / "b.ts") + "' > '" + (t / "ab.ts") + "' && " +
                             clip + "0.05 -frames:v 3" + enc + "'" + (t / "slow.mp4") + "'";
    if (std::system((make + " > /dev/null 2>&1").c_str()) != 0) GTEST_SKIP() << "no ffmpeg to encode the clips with";
    const std::string opts = " --realtime --no-overlay --no-summary -q --budget.refines 2 -K 4";
    const auto start = std::chrono::steady_clock::now();
    const RunResult r = rost::testing::runShell("timeout 40 " + std::string(ROST_TOOL) + " run " + (t / "ab.ts") +
                                                " --out " + (t / "o") + opts);
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(lines(t / "o/frames.csv"), 1 + 20);
    EXPECT_LT(took, 25.0) << "the 60 s jump between the streams was waited out";

    const pid_t pid = spawnRost({"run", t / "slow.mp4", "--out", t / "s", "--realtime", "--no-overlay", "--no-summary"},
                                t / "err.txt");
    // Signalled 1 s after the run describes its model ("rost: V = ...", the
    // last of its set-up, the first frame played at once after it): the
    // second frame is due 20 s after the first.
    const bool started = saysWithin(t / "err.txt", "rost: V = ", std::chrono::seconds(60));
    std::this_thread::sleep_for(std::chrono::seconds(1));
    const auto signalled = std::chrono::steady_clock::now();
    ::kill(pid, SIGINT);
    int status = 0;
    ASSERT_TRUE(endsWithin(pid, std::chrono::seconds(30), status));
    ASSERT_TRUE(started) << "the run never began: " << rost::testing::readText(t / "err.txt");
    const double after = std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130) << rost::testing::readText(t / "err.txt");
    EXPECT_LT(after, 2.5) << "Ctrl-C waited for the next frame's time (20 s after the first)";
}

TEST(ToolTrust, ResumedRefineFindsWhereItsStreamContinuesWhateverItsTimeStamps) {
    TempDir t;
    // Time stamps that are neither increasing nor unique: position in the stream decides.
    std::string words, positions;
    const int stamps[] = {0, 1, 2, 3, 4, 10, 11, 12, 5, 6, 7, 7, 7, 20, 21};
    rost::Rng rng(9);
    for (int ts : stamps) {
        words += std::to_string(ts);
        positions += std::to_string(ts);
        for (int i = 0; i < 10; ++i) {
            for (uint32_t v : {rng.below(30)}) words.append(",").append(std::to_string(v));
            for (uint32_t v : {rng.below(64), rng.below(64)}) positions.append(",").append(std::to_string(v));
        }
        words += "\n";
        positions += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    rost::testing::writeText(t / "positions.csv", positions);
    const auto cmd = [&](const std::string& w, const std::string& p, const std::string& out, const std::string& extra) {
        return runRost("refine " + (t / w) + " --positions " + (t / p) + " --width 64 --height 64 -V 30 --ring.steps 20 "
                       "--no-summary -q --out " + (t / out) + " " + extra);
    };
    RunResult r = cmd("words.csv", "positions.csv", "full", "");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    for (int n : {9, 12}) {  // stopped after "5" (a time stamp seen before), or between the repeated 7s
        SCOPED_TRACE(n);
        head(t / "words.csv", t / "wn.csv", n);
        head(t / "positions.csv", t / "pn.csv", n);
        r = cmd("wn.csv", "pn.csv", "first", "--checkpoint " + (t / "n.ckpt"));
        ASSERT_EQ(r.exit_code, 0) << r.err;
        r = cmd("words.csv", "positions.csv", "rest", "--resume " + (t / "n.ckpt"));
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_EQ(rost::testing::readText(t / "rest/topicmodel.csv"), rost::testing::readText(t / "full/topicmodel.csv"));
        EXPECT_EQ(rost::testing::readText(t / "rest/topics.csv"), rost::testing::readText(t / "full/topics.csv"));
        EXPECT_EQ(lines(t / "rest/perplexity.csv"), 1 + 15 - n);
    }
    // Only what came after (every time stamp later than the checkpoint's last): taken whole.
    head(t / "words.csv", t / "wn.csv", 14);
    head(t / "positions.csv", t / "pn.csv", 14);
    ASSERT_EQ(cmd("wn.csv", "pn.csv", "first", "--checkpoint " + (t / "m.ckpt")).exit_code, 0);
    rost::testing::writeText(t / "after.csv", tail(t / "words.csv", 14));
    rost::testing::writeText(t / "pafter.csv", tail(t / "positions.csv", 14));
    r = cmd("after.csv", "pafter.csv", "rest2", "--resume " + (t / "m.ckpt"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(rost::testing::readText(t / "rest2/topicmodel.csv"), rost::testing::readText(t / "full/topicmodel.csv"));
    // Neither: refused, saying why.
    rost::testing::writeText(t / "other.csv", "3,1,2\n30,4,5\n");
    rost::testing::writeText(t / "pother.csv", "3,0,0,1,1\n30,2,2,3,3\n");
    expectError(cmd("other.csv", "pother.csv", "x", "--resume " + (t / "m.ckpt")),
                (t / "other.csv") + ": 2 observations, fewer than the 14 " + (t / "m.ckpt") +
                    " holds, and not the ones after them (they would start after time stamp 20)",
                t / "x");
    // A stream that starts at the checkpoint's last time stamp is not what came after it.
    rost::testing::writeText(t / "same.csv", "20,1,2\n30,4,5\n");
    rost::testing::writeText(t / "psame.csv", "20,0,0,1,1\n30,2,2,3,3\n");
    expectError(cmd("same.csv", "psame.csv", "x", "--resume " + (t / "m.ckpt")),
                (t / "same.csv") + ": 2 observations, fewer than the 14 " + (t / "m.ckpt") +
                    " holds, and not the ones after them (they would start after time stamp 20)",
                t / "x");
    std::string longWords, longPositions;
    for (int i = 0; i < 15; ++i) {
        longWords += std::to_string(i) + ",1,2\n";
        longPositions += std::to_string(i) + ",0,0,1,1\n";
    }
    rost::testing::writeText(t / "long.csv", longWords);
    rost::testing::writeText(t / "plong.csv", longPositions);
    expectError(cmd("long.csv", "plong.csv", "x", "--resume " + (t / "m.ckpt")),
                (t / "long.csv") + ": neither the stream " + (t / "m.ckpt") +
                    " was made from (its observation 14 has time stamp 20, here 13) nor what came after it (the first "
                    "time stamp here, 0, is not after 20)",
                t / "x");
    expectError(cmd("wn.csv", "pn.csv", "x", "--resume " + (t / "m.ckpt")),
                "nothing to resume with", t / "x");
    // No positions for a model of 64 x 64 frames.
    expectError(runRost("refine " + (t / "words.csv") + " -q --out " + (t / "x") + " --resume " + (t / "m.ckpt")),
                (t / "words.csv") + ": no --positions, but " + (t / "m.ckpt") + " models 64x64 frames: give the words' positions",
                t / "x");
    // No positions but a frame size asked for: refused, not ignored (every word would share one cell).
    expectError(runRost("refine " + (t / "words.csv") + " -q --out " + (t / "x") + " --width 100"),
                (t / "words.csv") + ": no --positions, but a frame size was given (width 100): give the words' "
                                    "positions, or leave the frame size out",
                t / "x");
    expectError(runRost("refine " + (t / "words.csv") + " -q --out " + (t / "x") + " --width 100 --height 50"),
                "(width 100, height 50)", t / "x");
    // 1 x 1 is what no positions means: taken.
    EXPECT_EQ(runRost("refine " + (t / "words.csv") + " -q --no-summary --out " + (t / "one") + " --width 1 --height 1").exit_code, 0);
}

TEST(ToolTrust, ResumeRefusalsNameTheConfigFileLineAndEmptyOrDirectoryPaths) {
    TempDir t;
    writeStream(t);
    ASSERT_EQ(stopAfter25(t, "").exit_code, 0);
    rost::testing::writeText(t / "k.conf", "alpha = 0.1\nK = 8\n");
    expectError(runRost(refine(t, "o", "--resume " + (t / "m.ckpt") + " --config " + (t / "k.conf"))),
                (t / "k.conf") + ":2: key 'K' = 8 differs from " + (t / "m.ckpt") +
                    "'s K = 16 (a resumed mission keeps its model; leave the key out)",
                t / "o");
    expectError(runRost(refine(t, "o", "--resume ''")), "--resume: no file given", t / "o");
    // Every path option: an empty value (a script's unset variable) is refused, not read as "none".
    for (const char* option : {"--checkpoint", "--config", "--in.topicmodel"})
        expectError(runRost(refine(t, "o", std::string(option) + " ''")), std::string(option) + ": no file given", t / "o");
    expectError(runRost("refine " + (t / "words.csv") + " --out " + (t / "o") + " --positions ''"),
                "--positions: no file given", t / "o");
    expectError(runRost("refine " + (t / "words.csv") + " --out ''"), "--out: no directory given", t / "o");
    // And every positional path: the error names the argument, not a file of no name.
    expectError(runRost("refine '' --out " + (t / "o")), "words: no file given", t / "o");
    expectError(runRost("merge '' --out " + (t / "o")), "model: no file given", t / "o");
    expectError(runRost("run " + (t / "clip.avi") + " '' --out " + (t / "o")), "input: no input given", t / "o");
    expectError(runRost("vocab '' --out " + (t / "o") + "/v.voc"), "input: no input given", t / "o");
    expectError(runRost("vocab " + (t / "clip.avi") + " --out " + (t / "o") + "/v.voc --threads 0"), "--threads 0 outside 1..1024", t / "o");
    expectError(runRost("vocab " + (t / "clip.avi") + " --out " + (t / "o") + "/v.voc --threads 1000000"),
                "--threads 1000000 outside 1..1024", t / "o");
    expectError(runRost("vocab " + (t / "clip.avi") + " --out " + (t / "o") + "/v.voc --iterations 0"),
                "--iterations 0: must be at least 1", t / "o");
    expectError(runRost("run " + (t / "clip.avi") + " --out " + (t / "v") + " --out.bag ''"), "--out.bag: no file given",
                t / "v");
    // "-", standard input or output to many tools, names no file here: refused, no file or directory "-" made.
    {
        const std::string dash = "names no file: the rost tool neither reads standard input nor writes standard output "
                                 "(./- for a file of that name)";
        const auto inDir = [&t](const std::string& args) {
            return rost::testing::runShell("cd '" + t.path() + "' && " + tool() + " " + args);
        };
        for (const char* option : {"--checkpoint", "--config", "--in.topicmodel", "--resume"})
            expectError(inDir(std::string("refine words.csv --out o ") + option + " -"), std::string(option) + ": '-' " + dash,
                        t / "o");
        expectError(inDir("refine words.csv --out -"),
                    "--out: '-' names no directory: the rost tool neither reads standard input nor writes standard "
                    "output (./- for a directory of that name)",
                    t / "-");
        expectError(inDir("refine - --out o"), "words: '-' " + dash, t / "o");
        expectError(inDir("run clip.avi --out v --out.bag -"),
                    "--out.bag: '-' " + dash, t / "v");
        EXPECT_FALSE(std::filesystem::exists(t / "-"));
    }
    std::filesystem::create_directory(t / "dir.ckpt");
    expectError(runRost(refine(t, "o", "--resume " + (t / "dir.ckpt"))),
                "--resume: " + (t / "dir.ckpt") + " is a directory, not a checkpoint file", t / "o");
}

// Out of memory is an error naming what ran out, exit 2, not an abort, and
// the run's staging directory goes with it: a word stream that never ends
// (/dev/zero, read whole) and frames resized beyond the memory there is
// (OpenCV's allocation). Under a 700 MB address-space limit (not under the
// sanitizers, whose shadow memory needs more).
TEST(ToolTrust, RunningOutOfMemoryIsAnErrorNotAnAbort) {
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "an address-space limit and a sanitizer's shadow memory do not mix";
#else
    TempDir t;
    const auto limited = [](const std::string& args) {
        return rost::testing::runShell("ulimit -v 700000; " + tool() + " " + args);
    };
    RunResult r = limited("refine /dev/zero -q --out " + (t / "o"));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("rost: error: /dev/zero: out of memory reading it whole, after ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(t / "o")) << "nothing left, a staging directory included";
    std::filesystem::create_directory(t / "frames");
    for (int i = 0; i < 2; ++i)
        ASSERT_TRUE(cv::imwrite(t / ("frames/f" + std::to_string(i) + ".png"), cv::Mat(32, 32, CV_8UC3, cv::Scalar(i * 90, 40, 200))));
    r = limited("run " + (t / "frames") + " --width 30000 --height 30000 --cell.space 4096 --max.words 500 --threads 1 -q --no-overlay "
                "--no-summary --out " + (t / "v"));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind("rost: error: out of memory: OpenCV: Failed to allocate ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(t / "v")) << "nothing left, a staging directory included";
#endif
}

TEST(ToolTrust, HostileWordStreamsAndVideosGetOneLineErrorsWithExitCode2) {
    TempDir t;
    const auto refineIt = [&](const std::string& words, const std::string& positions, const std::string& extra) {
        rost::testing::writeText(t / "w.csv", words);
        std::string cmd = "refine " + (t / "w.csv");
        if (!positions.empty()) {
            rost::testing::writeText(t / "p.csv", positions);
            cmd += " --positions " + (t / "p.csv");
        }
        return runRost(cmd + " --out " + (t / "o") + " -q --no-summary " + extra);
    };
    const std::string words = "0,1,2\n1,3,4\n";
    expectError(refineIt(words, "0,0,0,-1,5\n1,0,0,1,1\n", ""),
                (t / "p.csv") + ":1:7: position (-1, 5) has a negative coordinate: positions are pixels from the frame's top-left corner, 0 or more", t / "o");
    expectError(refineIt(words, "0,0,0,99999999999,5\n1,0,0,1,1\n", ""),
                (t / "p.csv") + ":1:7: position (99999999999, 5) outside the largest frame", t / "o");
    expectError(refineIt(words, "0,0,0,5,70000\n1,0,0,1,1\n", "--width 640"),
                (t / "p.csv") + ":1:9: position (5, 70000) outside the frame 640 wide and at most 65536 high", t / "o");
    expectError(refineIt(words, "0,0,0,5000,5\n1,0,0,1,1\n", "--width 640 --height 480"),
                (t / "p.csv") + ":1:7: position (5000, 5) outside the frame 640x480", t / "o");
    // Beyond the largest frame and V the schema allows, with neither given: the
    // data's place named, not a setting out of range (and no int overflow).
    expectError(refineIt(words, "0,0,0,1,1\n1,2147483647,3,1,1\n", ""),
                (t / "p.csv") + ":2:3: position (2147483647, 3) outside the largest frame a model can hold, 65536x65536",
                t / "o");
    expectError(refineIt("0,1,2\n1,16777216,4\n", "", ""),
                (t / "w.csv") + ":2:3: word id 16777216 out of range [0, 16777216)", t / "o");
    std::string enormous = "0";
    for (int i = 0; i < 5000; ++i) enormous += ",1";
    // max.words given: a longer observation is an error naming the line; not given, it is the
    // stream's longest observation (nothing subsampled).
    expectError(refineIt(enormous + "\n", "", "--max.words 4096"),
                (t / "w.csv") + ":1:1: 5000 words in one observation, at most 4096", t / "o");
    ASSERT_EQ(refineIt(enormous + "\n1,2\n", "", "").exit_code, 0);
    EXPECT_EQ(lines(t / "o/topics.csv"), 2);
    EXPECT_EQ(rost::testing::fields(rost::testing::lines(rost::testing::readText(t / "o/topics.csv"))[0]).size(), 5001u);
    std::filesystem::remove_all(t / "o");
    expectError(refineIt("0,1,-2\n", "", ""), (t / "w.csv") + ":1:5", t / "o");
    expectError(refineIt("# nothing\n\n", "", ""), (t / "w.csv") + ": no observations", t / "o");
    // An empty frame (no words: a dark or featureless image) is an observation, not an error.
    RunResult r = refineIt("0,1,2\n1\n2,3\n", "", "");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(lines(t / "o/perplexity.csv"), 4);
    // Videos: empty, not video at all.
    rost::testing::writeText(t / "empty.mp4", "");
    expectError(runRost("run " + (t / "empty.mp4") + " --out " + (t / "v") + " -q"), (t / "empty.mp4") + ": cannot decode video",
                t / "v");
    rost::testing::writeText(t / "text.mp4", "hello, not a video\n");
    expectError(runRost("run " + (t / "text.mp4") + " --out " + (t / "v") + " -q"), (t / "text.mp4") + ": cannot decode video",
                t / "v");
}

} // namespace
