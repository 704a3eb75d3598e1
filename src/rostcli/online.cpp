// --online: documents taken up as they arrive (a pipe, a FIFO, standard
// input, a file), each refined for --online.mint ms by the realtime engine's
// refiner thread while the next is awaited; each document's online line is
// appended and flushed as soon as its time is up. End of input, SIGINT or
// SIGTERM end the stream; the final files are then written as in batch mode.
//
// Threads: this one reads the input (poll with a short timeout, so it also
// writes the online lines), pushes documents into the engine, and writes;
// the refiner ingests, refines and, in the engine's hooks, copies each
// document's labels into preallocated rings (no allocation, no lock, no
// syscall on the refiner).

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <thread>

#include "rost/engine.hpp"
#include "rost/text_io.hpp"
#include "rostcli.hpp"
#include "spsc_ring.hpp"

namespace rost::cli {

namespace {

std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "a signal handler may touch only lock-free atomics");
extern "C" void onStopSignal(int sig) { g_signal.store(sig, std::memory_order_relaxed); }

// SIGINT and SIGTERM end the stream (once: a second one kills as by default).
struct StopSignals {
    struct sigaction old_int {}, old_term {};
    StopSignals() {
        g_signal.store(0);
        struct sigaction sa {};
        sa.sa_handler = onStopSignal;
        sa.sa_flags = SA_RESETHAND;  // no SA_RESTART: a waiting poll() returns
        sigemptyset(&sa.sa_mask);
        sigaction(SIGINT, &sa, &old_int);
        sigaction(SIGTERM, &sa, &old_term);
    }
    ~StopSignals() {
        sigaction(SIGINT, &old_int, nullptr);
        sigaction(SIGTERM, &old_term, nullptr);
    }
    static int caught() { return g_signal.load(std::memory_order_relaxed); }
};

// One document's labels as the refiner copied them (sized once: max.words).
struct LabelRecord {
    uint64_t sequence = 0;
    double perplexity = 0.0;  // its step's plug-in perplexity
    uint64_t tokens = 0;
    AddError error = AddError::None;
    uint32_t n = 0;
    std::vector<uint16_t> ml, sample;
};

// Single producer (the refiner), single consumer (this thread), on the
// library's SPSC ring (its two counters on cache lines of their own); a full
// ring drops the record and counts it.
class RecordRing {
public:
    RecordRing(std::size_t slots, std::size_t words) : ring_(slots, [words](LabelRecord& r) {
        r.ml.resize(words);
        r.sample.resize(words);
    }) {}
    LabelRecord* beginPush() noexcept {
        LabelRecord* r = ring_.beginPush();
        if (!r) lost_.fetch_add(1, std::memory_order_relaxed);
        return r;
    }
    void commitPush() noexcept { ring_.commitPush(); }
    const LabelRecord* front() noexcept { return ring_.front(); }
    void pop() noexcept { ring_.pop(); }
    uint64_t lost() const noexcept { return lost_.load(std::memory_order_relaxed); }

private:
    SpscRing<LabelRecord> ring_;
    std::atomic<uint64_t> lost_{0};
};

// Copies observation `frame`'s labels (ML; the Gibbs sample too when `sample`) into a record.
void capture(RecordRing& ring, const Model& m, uint64_t sequence, uint64_t frame, int64_t step, bool sample,
             uint64_t tokens, AddError error) noexcept {
    LabelRecord* r = ring.beginPush();
    if (!r) return;
    r->sequence = sequence;
    r->tokens = tokens;
    r->error = error;
    r->n = 0;
    if (error == AddError::None) {
        r->n = std::min<uint32_t>(m.observationSize(frame), static_cast<uint32_t>(r->ml.size()));
        m.observationLabels(frame, {r->ml.data(), r->n});
        if (sample) m.observationSamples(frame, {r->sample.data(), r->n});
        r->perplexity = m.stepPluginPerplexity(step);
    }
    ring.commitPush();
}

void appendRow(std::string& out, const std::string& timestamp, const uint16_t* z, uint32_t n) {
    text::TableWriter t(out);
    t.cell(timestamp);
    for (uint32_t i = 0; i < n; ++i) t.cell(z[i]);
    t.end();
}

void appendPerplexity(std::string& out, const std::string& timestamp, double ppx) {
    text::TableWriter(out).cell(timestamp).cell(ppx).end();
}

// The input read as it arrives, split into lines, each parsed into a document.
class LineSource {
public:
    Status open(const RunOptions& o, uint32_t V, int max_words, Corpus& c) {
        o_ = &o, V_ = V, max_words_ = static_cast<std::size_t>(max_words), c_ = &c;
        const std::string& path = o.in_words;
        if (isStandardInput(path)) {
            c.words_name = "<stdin>";
            fd_ = 0;
            return {};
        }
        c.words_name = path;
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0) return Status::error(path + ": " + std::strerror(errno));
        own_ = true;
        struct stat st {};
        if (fstat(fd_, &st) == 0 && S_ISDIR(st.st_mode)) return Status::error(path + ": is a directory, not a file");
        return {};
    }
    ~LineSource() {
        if (own_) ::close(fd_);
    }
    bool ended() const { return ended_; }
    // A bad line ends the input: the documents before it (in `ready` already,
    // however many one read brought) are taken up first, and then this is
    // the run's error.
    const Status& failure() const { return failure_; }
    // Waits up to `ms` for input; every complete line read becomes a document in `ready`.
    Status poll(int ms, std::vector<Document>& ready) {
        pollfd p{fd_, POLLIN, 0};
        const int n = ::poll(&p, 1, ms);
        if (n < 0) return errno == EINTR ? Status() : Status::error(c_->words_name + ": " + std::strerror(errno));
        if (n == 0) return {};
        char buf[65536];
        const ssize_t got = ::read(fd_, buf, sizeof buf);
        if (got < 0) return errno == EINTR || errno == EAGAIN ? Status() : Status::error(c_->words_name + ": read error: " + std::strerror(errno));
        if (got == 0) ended_ = true;
        pending_.append(buf, static_cast<std::size_t>(got));
        std::size_t start = 0;
        for (std::size_t nl; (nl = pending_.find('\n', start)) != std::string::npos; start = nl + 1)
            if (Status st = take(std::string_view(pending_).substr(start, nl - start), ready); !st.ok()) return fail(st);
        pending_.erase(0, start);
        if (ended_ && !pending_.empty()) {  // a last line without '\n'
            if (Status st = take(pending_, ready); !st.ok()) return fail(st);
            pending_.clear();
        }
        return {};
    }

private:
    Status fail(Status st) {
        failure_ = std::move(st);
        ended_ = true;
        pending_.clear();
        return {};
    }

    Status take(std::string_view line, std::vector<Document>& ready) {
        ++line_;
        Document d;
        bool got = false;
        if (Status st = parseDocumentLine(line, line_, c_->words_name, o_->delim, V_, d, got); !st.ok()) return st;
        if (!got) return {};
        if (d.words.size() > max_words_)
            return Status::error(text::where(c_->words_name, line_) + std::to_string(d.words.size()) +
                                 " words, more than the " + std::to_string(max_words_) +
                                 " an online document may hold (the schema's max.words)");
        d.positions.assign(d.words.size(), Position{0, 0});
        ready.push_back(std::move(d));
        return {};
    }

    const RunOptions* o_ = nullptr;
    Corpus* c_ = nullptr;
    uint32_t V_ = 0;
    std::size_t max_words_ = 0;
    int fd_ = -1;
    bool own_ = false, ended_ = false;
    std::string pending_;
    int line_ = 0;
    Status failure_;
};

// An online file, appended to and flushed line by line, a whole line at a
// time: a write that fails is cut back to the last whole line, so a reader
// sees whole lines only. It is opened (an earlier run's file of that name
// replaced) when its first line is written: a run that fails before its
// first document's time is up leaves the earlier run's file as it was.
struct LineFile {
    int fd = -1;
    std::string path;
    off_t whole = 0;  // bytes of whole lines written

    Status open(const std::string& p) {
        path = p;
        return {};
    }
    Status write(const std::string& text) {
        if (path.empty() || text.empty()) return {};
        if (fd < 0 && (fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666)) < 0) {
            const int err = errno;
            return Status::fromErrno(err, path + ": cannot write: " + std::strerror(err));
        }
        for (std::size_t done = 0; done < text.size();) {
            const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
            if (n > 0) {
                done += static_cast<std::size_t>(n);
                continue;
            }
            if (n < 0 && errno == EINTR) continue;
            const int err = n < 0 ? errno : ENOSPC;
            if (::ftruncate(fd, whole) == 0) (void)::lseek(fd, whole, SEEK_SET);  // else not a regular file
            return Status::fromErrno(err, path + ": write error: " + std::strerror(err));
        }
        whole += static_cast<off_t>(text.size());
        return {};
    }
    ~LineFile() {
        if (fd >= 0) ::close(fd);
    }
};

struct OnlineState {
    Corpus& c;
    Engine& engine;
    RecordRing done, left;    // documents whose time was up; documents leaving the window
    LineFile topics, ppx;
    std::vector<Document> ready;  // read, not yet pushed
    std::size_t next = 0;         // the first of `ready` not pushed
    uint64_t written = 0, tokens = 0;
    std::string final_topics, final_ml, final_ppx;  // the documents that left the window, in order
    uint64_t finals = 0;
    bool any_word = false, keep_positions = false;

    OnlineState(Corpus& corpus, Engine& e, std::size_t words)
        : c(corpus), engine(e), done(512, words), left(512, words) {}

    // Writes the online lines of the documents whose time was up; keeps the final labels of those that left.
    Status drain() {
        std::string t, p;
        for (const LabelRecord* r; (r = done.front()) != nullptr; done.pop(), ++written) {
            const Document& d = c.docs[r->sequence];
            if (r->error != AddError::None)
                return Status::error(c.words_name + ":" + std::to_string(d.line) + ": " + toString(r->error));
            appendRow(t, d.timestamp, r->ml.data(), r->n);
            appendPerplexity(p, d.timestamp, r->perplexity);
            tokens += r->tokens;
        }
        if (Status st = topics.write(t); !st.ok()) return st;
        if (Status st = ppx.write(p); !st.ok()) return st;
        for (const LabelRecord* r; (r = left.front()) != nullptr; left.pop(), ++finals) {
            const Document& d = c.docs[r->sequence];
            appendRow(final_topics, d.timestamp, r->sample.data(), r->n);
            appendRow(final_ml, d.timestamp, r->ml.data(), r->n);
            appendPerplexity(final_ppx, d.timestamp, r->perplexity);
        }
        if (done.lost() + left.lost() > 0)
            return Status::error("the online writer fell behind: " + std::to_string(done.lost() + left.lost()) +
                                 " records lost");
        return {};
    }

    // Pushes the documents read while the engine has room; true when one went in.
    bool push() {
        bool any = false;
        while (next < ready.size() && engine.canPush()) {
            Document& d = ready[next];
            if (!engine.tryPush({0, d.words, d.positions})) break;
            any_word = any_word || !d.words.empty();
            d.words = {};  // the model holds them now
            if (!keep_positions) d.positions = {};
            c.docs.push_back(std::move(d));
            ++next, any = true;
        }
        if (next == ready.size()) ready.clear(), next = 0;
        return any;
    }
};

void attachHooks(OnlineState& st) {
    st.engine.setObservationHook([&st](const ObservationResult& r, const Model& m) {
        capture(st.done, m, r.sequence, r.observation, r.step, false, r.tokens, r.add.ok() ? AddError::None : r.add.error);
    });
    st.engine.setEvictionHook([&st](const WindowObservation& w, const Model& m) {
        capture(st.left, m, w.sequence, w.observation, w.step, true, 0, AddError::None);
    });
}

// Reads, pushes and writes until the input ends (or a signal), then until
// every document pushed had its time.
Status stream(OnlineState& st, LineSource* src) {
    while (StopSignals::caught() == 0) {
        if (Status s = st.drain(); !s.ok()) return s;
        if (st.push()) continue;
        if (st.next < st.ready.size() || !src || src->ended()) {
            if (st.next == st.ready.size() && st.written == st.c.docs.size())  // all in and done
                return src ? src->failure() : Status{};
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            continue;
        }
        if (Status s = src->poll(2, st.ready); !s.ok()) return s;
    }
    return {};
}

// The final files: the documents that left the window as they left it, then those still in it.
void finalFiles(const RunOptions& o, OnlineState& st, const Model& m, Outputs& out) {
    out.topics = std::move(st.final_topics);
    out.topics_ml = std::move(st.final_ml);
    out.ppx = std::move(st.final_ppx);
    std::vector<uint16_t> z;
    for (uint64_t d = st.finals; d < st.c.docs.size(); ++d) {
        const Document& doc = st.c.docs[d];
        z.resize(m.observationSize(d));
        m.observationSamples(d, z);
        appendRow(out.topics, doc.timestamp, z.data(), static_cast<uint32_t>(z.size()));
        m.observationLabels(d, z);
        appendRow(out.topics_ml, doc.timestamp, z.data(), static_cast<uint32_t>(z.size()));
        appendPerplexity(out.ppx, doc.timestamp, m.stepPluginPerplexity(m.stepOfObservation(d)));
    }
    if (o.cmd == Command::RefineTxy)
        for (const Document& doc : st.c.docs) {
            text::TableWriter t(out.position);
            t.cell(doc.timestamp);
            for (const Position& p : doc.positions) t.cell(p.x).cell(p.y);
            t.end();
        }
}

} // namespace

Status runOnline(const RunOptions& o, Corpus& c, const Settings& s, Engine& engine, Outputs& out) {
    const Config& m = engine.config().model;
    OnlineState st(c, engine, static_cast<std::size_t>(m.max_words_per_frame));
    LineSource src;
    const bool streaming = c.docs.empty();  // topics.refine.t: read as it arrives
    if (streaming) {
        if (Status e = src.open(o, static_cast<uint32_t>(m.V), m.max_words_per_frame, c); !e.ok()) return e;
    } else {
        st.ready = std::move(c.docs);  // topics.refine.txy: its positions file was read with the words
        c.docs.clear();
        st.keep_positions = true;
    }
    if (Status e = st.topics.open(o.out_topics_online); !e.ok()) return e;
    if (Status e = st.ppx.open(o.out_ppx_online); !e.ok()) return e;
    attachHooks(st);
    const auto t0 = std::chrono::steady_clock::now();
    if (Status e = engine.start(); !e.ok()) return e;
    Status result;
    {
        StopSignals signals;
        result = stream(st, streaming ? &src : nullptr);
        engine.stop(Engine::StopMode::Drain);  // the documents pushed have their time
        if (result.ok()) result = st.drain();
        if (const int sig = StopSignals::caught(); sig != 0)
            out.log += std::string("online: stopped by ") + (sig == SIGINT ? "SIGINT" : "SIGTERM") + "\n";
    }
    if (!result.ok()) return result;
    if (c.docs.empty()) return Status::error(c.words_name + ": no documents (the input is empty or blank)");
    if (!st.any_word)
        return Status::error(c.words_name + ": no words in its " + std::to_string(c.docs.size()) +
                             " documents (each line is timestamp" + o.delim + "word" + o.delim + "word...)");
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.log += std::string("online: ") + std::to_string(c.docs.size()) + " documents, " + formatDouble(s.engine.budget.ms) +
               " ms each, refined " + std::to_string(st.tokens) + " tokens in " + formatDouble(secs) + " s\n";
    finalFiles(o, st, engine.model(), out);
    return {};
}

} // namespace rost::cli
