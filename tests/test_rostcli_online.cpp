// topics.refine.t --online as a stream: documents written into a pipe one at
// a time while the command runs. Each document's online lines must be in the
// online files (complete, in order) before the pipe is closed; end of input,
// SIGINT and SIGTERM end the run with exit 0, the final files written
// whole and no temporary file left. Every wait is on a condition, with a
// generous deadline (a loaded 2-core machine).

#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string readText(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

// The complete lines of a file (a last line without '\n' is not complete yet).
std::vector<std::string> lines(const std::string& path) {
    std::vector<std::string> out;
    const std::string text = readText(path);
    std::size_t start = 0;
    for (std::size_t nl; (nl = text.find('\n', start)) != std::string::npos; start = nl + 1)
        out.push_back(text.substr(start, nl - start));
    return out;
}

bool waitFor(const std::function<bool()>& done, double seconds = 20.0) {
    const auto end = Clock::now() + std::chrono::duration<double>(seconds);
    while (!done()) {
        if (Clock::now() > end) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
}

// Document i's timestamp and its delimiter: "7.50,".
std::string stamp(int i) {
    std::string s = std::to_string(i);
    s.append(".50,");
    return s;
}

// Document i: 12 words of topic (i / 5) % 3, V = 30.
std::string document(int i) {
    std::string line = stamp(i);
    const int topic = (i / 5) % 3;
    for (int w = 0; w < 12; ++w) {
        if (w) line.push_back(',');
        line.append(std::to_string(topic * 10 + (w * 7 + i) % 10));
    }
    line.push_back('\n');
    return line;
}

// topics.refine.t --online in `dir`, reading its standard input from a pipe this test writes.
class Streamed {
public:
    Streamed(const std::string& dir, int mint) {
        int fds[2];
        EXPECT_EQ(pipe(fds), 0);
        pid_ = fork();
        if (pid_ == 0) {
            dup2(fds[0], 0);
            close(fds[0]);
            close(fds[1]);
            if (chdir(dir.c_str()) != 0) _exit(99);
            const int err = open("stderr.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
            dup2(err, 2);
            const std::string m = std::to_string(mint);
            execl(ROSTCLI_REFINE_T, ROSTCLI_REFINE_T, "-i", "-", "-V", "30", "-K", "3", "--online", "--online.mint",
                  m.c_str(), "--threads", "1", static_cast<char*>(nullptr));
            _exit(98);
        }
        close(fds[0]);
        fd_ = fds[1];
    }
    ~Streamed() {
        closeInput();
        if (pid_ > 0 && status_ < 0) kill(pid_, SIGKILL), waitpid(pid_, nullptr, 0);
    }
    void write(const std::string& text) { ASSERT_EQ(::write(fd_, text.data(), text.size()), static_cast<ssize_t>(text.size())); }
    void closeInput() {
        if (fd_ >= 0) close(fd_), fd_ = -1;
    }
    void signal(int sig) { kill(pid_, sig); }
    // The exit status (-1: still running after the deadline; 128 + n: killed by signal n).
    int wait(double seconds = 30.0) {
        waitFor([&] {
            int st = 0;
            if (waitpid(pid_, &st, WNOHANG) != pid_) return false;
            status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
            return true;
        }, seconds);
        return status_;
    }

private:
    pid_t pid_ = -1;
    int fd_ = -1;
    int status_ = -1;
};

class RostCliOnline : public ::testing::Test {
protected:
    void SetUp() override {
        std::signal(SIGPIPE, SIG_IGN);
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir = (fs::temp_directory_path() / ("rostcli_online_" + std::to_string(getpid()) + "_" + info->name())).string();
        fs::remove_all(dir);
        fs::create_directories(dir);
    }
    void TearDown() override { fs::remove_all(dir); }

    // The online files hold `n` complete lines (and no more): documents 0..n-1, in order.
    void expectOnline(std::size_t n) {
        const auto topics = lines(dir + "/topics.online.csv"), ppx = lines(dir + "/perplexity.online.csv");
        ASSERT_EQ(topics.size(), n);
        ASSERT_EQ(ppx.size(), n);
        for (std::size_t i = 0; i < n; ++i) {
            const std::string ts = stamp(static_cast<int>(i));
            EXPECT_EQ(topics[i].rfind(ts, 0), 0u) << topics[i];
            EXPECT_EQ(std::count(topics[i].begin(), topics[i].end(), ','), 12) << topics[i];
            EXPECT_EQ(ppx[i].rfind(ts, 0), 0u) << ppx[i];
        }
    }
    // The final files: a line per document, in order; nothing else in the directory.
    void expectFinal(std::size_t n) {
        for (const char* f : {"topics.csv", "topics.maxlikelihood.csv", "perplexity.csv"}) {
            const auto rows = lines(dir + "/" + f);
            ASSERT_EQ(rows.size(), n) << f;
            for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(rows[i].rfind(stamp(static_cast<int>(i)), 0), 0u) << f << ": " << rows[i];
        }
        EXPECT_EQ(lines(dir + "/topicmodel.csv").size(), 3u);
        const std::set<std::string> expected{"topics.csv", "topics.maxlikelihood.csv", "perplexity.csv",
                                             "topicmodel.csv", "topics.log", "topics.online.csv",
                                             "perplexity.online.csv", "stderr.txt"};
        for (const auto& e : fs::directory_iterator(dir))
            EXPECT_TRUE(expected.count(e.path().filename().string())) << "left behind: " << e.path();
    }

    std::string dir;
};

// Each document's online lines appear while the pipe is still open; after it
// closes, the final files hold every document (more than the 256 time steps
// the window keeps: the first ones left it with their labels).
TEST_F(RostCliOnline, WritesEachDocumentsLinesAsItsTimeIsUp) {
    Streamed run(dir, 5);
    for (int i = 0; i < 4; ++i) {
        run.write(document(i));
        ASSERT_TRUE(waitFor([&] { return lines(dir + "/perplexity.online.csv").size() == static_cast<std::size_t>(i) + 1; }))
            << "document " << i << "'s online line did not appear while the pipe was open: " << readText(dir + "/stderr.txt");
        expectOnline(static_cast<std::size_t>(i) + 1);
        std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the writer's pace
    }
    EXPECT_FALSE(fs::exists(dir + "/topics.csv")) << "the final files come at the end";
    std::string rest;
    for (int i = 4; i < 300; ++i) rest += document(i);
    run.write(rest);
    run.closeInput();
    ASSERT_EQ(run.wait(), 0) << readText(dir + "/stderr.txt");
    expectOnline(300);
    expectFinal(300);
    const std::string log = readText(dir + "/topics.log");
    EXPECT_NE(log.find("300 documents from <stdin>"), std::string::npos);
    EXPECT_NE(log.find("\nseed = "), std::string::npos) << log;
    EXPECT_EQ(log.find("final.sweeps"), std::string::npos) << "--online runs no final sweeps: " << log;
}

// SIGINT or SIGTERM mid-stream: exit 0, the final files of the documents taken up.
TEST_F(RostCliOnline, ASignalEndsTheStreamWithTheFinalFiles) {
    for (int sig : {SIGINT, SIGTERM}) {
        SCOPED_TRACE(sig == SIGINT ? "SIGINT" : "SIGTERM");
        for (const auto& e : fs::directory_iterator(dir)) fs::remove(e.path());
        Streamed run(dir, 10);
        std::string first;
        for (int i = 0; i < 5; ++i) first += document(i);
        run.write(first);
        ASSERT_TRUE(waitFor([&] { return lines(dir + "/perplexity.online.csv").size() == 5; }))
            << readText(dir + "/stderr.txt");
        run.write("5.50,1,2");  // a line not finished when the signal comes: not a document
        run.signal(sig);
        ASSERT_EQ(run.wait(), 0) << readText(dir + "/stderr.txt");
        expectOnline(5);
        expectFinal(5);
        EXPECT_NE(readText(dir + "/topics.log").find(sig == SIGINT ? "stopped by SIGINT" : "stopped by SIGTERM"),
                  std::string::npos);
    }
}

// The vocabulary is needed before the first document arrives.
TEST_F(RostCliOnline, NeedsTheVocabularySize) {
    const std::string cmd = "cd '" + dir + "' && echo 1,2,3 | '" + ROSTCLI_REFINE_T + "' --online 2>err.txt";
    const int rc = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(rc), 2);
    EXPECT_NE(readText(dir + "/err.txt").find("give -V/--vocabsize"), std::string::npos) << readText(dir + "/err.txt");
}

// A --cell.time whose cells could not hold its documents' words is named, with
// its bound (rost-cli has no flag for the cell's capacity it would need).
TEST_F(RostCliOnline, ACellTimeTooLongForACellIsNamedWithItsBound) {
    const std::string cmd = "cd '" + dir + "' && echo 1,2,3 | '" + ROSTCLI_REFINE_T +
                            "' -V 5 --online --cell.time 300 2>err.txt";
    const int rc = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(rc), 2);
    const std::string err = readText(dir + "/err.txt");
    EXPECT_NE(err.find("--cell.time 300: online, a cell keeps room for 300 documents of up to 4096 words, more than "
                       "the 1048576 a cell can hold (--cell.time 256 at most)"),
              std::string::npos) << err;
}

// A bad line mid-stream is named by its line.
TEST_F(RostCliOnline, ABadLineIsNamedByItsLine) {
    const std::string cmd = "cd '" + dir + "' && printf '1,2,3\\n\\n2,4,x\\n' | '" + ROSTCLI_REFINE_T +
                            "' -V 30 --online --online.mint 1 2>err.txt";
    const int rc = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(rc), 2);
    EXPECT_NE(readText(dir + "/err.txt").find("<stdin>:3:5: expected word id"), std::string::npos) << readText(dir + "/err.txt");
    EXPECT_FALSE(fs::exists(dir + "/topics.csv"));
}

// From a file, read in one go: the documents before the bad line are taken
// up and get their online lines all the same, then the error.
TEST_F(RostCliOnline, ABadLineInAFileComesAfterTheDocumentsBeforeIt) {
    std::ofstream(dir + "/ob.csv") << "0,1,2,3\n1,2,3,4\n2,x\n3,1\n";
    const std::string cmd = "cd '" + dir + "' && '" + ROSTCLI_REFINE_T +
                            "' -i ob.csv -V 10 -K 4 --online --online.mint 5 2>err.txt";
    const int rc = std::system(cmd.c_str());
    EXPECT_EQ(WEXITSTATUS(rc), 2);
    EXPECT_EQ(readText(dir + "/err.txt"), "topics.refine.t: ob.csv:3:3: expected word id (a non-negative integer), found 'x'\n");
    const auto topics = lines(dir + "/topics.online.csv"), ppx = lines(dir + "/perplexity.online.csv");
    ASSERT_EQ(topics.size(), 2u) << readText(dir + "/topics.online.csv");
    ASSERT_EQ(ppx.size(), 2u);
    EXPECT_EQ(topics[0].rfind("0,", 0), 0u);
    EXPECT_EQ(topics[1].rfind("1,", 0), 0u);
    EXPECT_FALSE(fs::exists(dir + "/topics.csv"));
}

} // namespace

namespace {

// Runs topics.refine.t in `dir` with `args`; its exit status, stderr in err.txt.
int refineT(const std::string& dir, const std::string& args) {
    const std::string cmd = "cd '" + dir + "' && '" + ROSTCLI_REFINE_T + "' " + args + " 2>err.txt";
    const int rc = std::system(cmd.c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

} // namespace

// An online document may hold max.words words (the schema's 4096): that
// many are taken, one more is refused naming the line and the bound.
TEST_F(RostCliOnline, ADocumentOfMaxWordsIsTakenAndOneMoreIsRefused) {
    const auto doc = [](int stamp, int words) {
        std::string line = std::to_string(stamp);
        for (int w = 0; w < words; ++w) line += "," + std::to_string(w % 10);
        return line + "\n";
    };
    std::ofstream(dir + "/full.csv") << doc(0, 4096) << doc(1, 3);
    EXPECT_EQ(refineT(dir, "-i full.csv -V 10 -K 2 --online --online.mint 1"), 0) << readText(dir + "/err.txt");
    EXPECT_EQ(lines(dir + "/topics.online.csv").size(), 2u);
    std::ofstream(dir + "/over.csv") << doc(0, 3) << doc(1, 4097);
    EXPECT_EQ(refineT(dir, "-i over.csv -V 10 -K 2 --online --online.mint 1"), 2);
    EXPECT_EQ(readText(dir + "/err.txt"),
              "topics.refine.t: over.csv:2: 4097 words, more than the 4096 an online document may hold (the schema's "
              "max.words)\n");
}

// A last line without '\n' is a document too, however short: a bare time
// stamp of one character (a document without words) as much as a longer one.
TEST_F(RostCliOnline, ALastLineWithoutANewlineIsADocumentHoweverShort) {
    for (const std::string& last : {std::string("5"), std::string("5,1"), std::string("15")}) {
        SCOPED_TRACE(last);
        std::ofstream(dir + "/tail.csv") << "0,1,2\n" << last;
        ASSERT_EQ(refineT(dir, "-i tail.csv -V 3 -K 2 --online --online.mint 5"), 0) << readText(dir + "/err.txt");
        for (const char* file : {"topics.csv", "topics.online.csv", "topics.maxlikelihood.csv"}) {
            const auto got = lines(dir + "/" + file);
            ASSERT_EQ(got.size(), 2u) << file;
            EXPECT_EQ(got[1].substr(0, got[1].find(',')), last.substr(0, last.find(','))) << file;
        }
    }
}

// The final topics.csv holds each document's Gibbs sample, those that left
// the window before the end (sampled as they left) as much as the rest, and
// topics.maxlikelihood.csv their maximum-likelihood labels: over 300
// documents of random words (a window of 256 steps) in 20 topics, the two
// differ in the documents that left, as a sample and its mode do.
TEST_F(RostCliOnline, DocumentsThatLeftTheWindowKeepTheirSampleApartFromTheirMaximumLikelihoodLabels) {
    std::string text;
    uint64_t x = 12345;
    for (int d = 0; d < 300; ++d) {
        text += std::to_string(d);
        for (int w = 0; w < 12; ++w) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            text += "," + std::to_string((x >> 33) % 30);
        }
        text += "\n";
    }
    std::ofstream(dir + "/random.csv") << text;
    ASSERT_EQ(refineT(dir, "-i random.csv -V 30 -K 20 --online --online.mint 1"), 0) << readText(dir + "/err.txt");
    const auto sample = lines(dir + "/topics.csv"), ml = lines(dir + "/topics.maxlikelihood.csv");
    ASSERT_EQ(sample.size(), 300u);
    ASSERT_EQ(ml.size(), 300u);
    int differ = 0;
    for (std::size_t d = 0; d < 300 - 256; ++d) differ += sample[d] != ml[d];
    EXPECT_GT(differ, 0) << "the documents that left the window: topics.csv holds their maximum-likelihood labels";
}
