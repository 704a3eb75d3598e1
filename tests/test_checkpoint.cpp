// Checkpoints (rost/checkpoint.hpp) and the topic model CSV
// (rost/topic_model_csv.hpp): bit-for-bit resume, the documented format,
// and a clear error, with the engine untouched, for every kind of bad file.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "rost/checkpoint.hpp"
#include "rost/config_file.hpp"
#include "rost/mission.hpp"
#include "rost/topic_model_csv.hpp"
#include "rost/word_stream.hpp"
#include "test_engine_support.hpp"

namespace rost {
namespace {

namespace fs = std::filesystem;
using rost::testing::Frame;
using rost::testing::makeStream;
using rost::testing::smallConfig;

fs::path tempDir(const std::string& name) {
    const fs::path d = fs::temp_directory_path() / ("rost_checkpoint_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

EngineConfig baseConfig() {
    EngineConfig e;
    e.model = smallConfig();
    e.model.ring_steps = 6;  // the ring wraps during the tests' streams
    e.model.max_words_per_frame = 40;  // some frames are subsampled at push (seeded by the sequence number)
    e.budget = Budget::steps(3);
    e.strategy.kind = StrategyKind::UniformNow;
    e.queue_slots = 4;
    return e;
}

// What a run produces per observation, to compare runs bit for bit.
struct Record {
    uint64_t sequence = 0;
    int64_t step = -1;
    uint64_t tokens = 0;
    uint64_t surprise_bits = 0;
    uint64_t perplexity_bits = 0;
    std::vector<uint16_t> labels;
    std::vector<uint16_t> samples;
};

uint64_t bits(double d) {
    uint64_t u;
    std::memcpy(&u, &d, sizeof u);
    return u;
}

void recordInto(Engine& engine, std::vector<Record>& out) {
    engine.setObservationHook([&out](const ObservationResult& r, const Model& m) {
        Record rec;
        rec.sequence = r.sequence;
        rec.step = r.step;
        rec.tokens = r.tokens;
        rec.surprise_bits = bits(r.surprise);
        rec.perplexity_bits = bits(r.perplexity);
        const uint32_t n = m.observationSize(r.observation);
        rec.labels.resize(n);
        rec.samples.resize(n);
        m.observationLabels(r.observation, rec.labels);
        m.observationSamples(r.observation, rec.samples);
        out.push_back(std::move(rec));
    });
}

std::vector<uint8_t> stateOf(Engine& e) {
    std::vector<uint8_t> b;
    const Status st = encodeCheckpoint(e, b);
    EXPECT_TRUE(st.ok()) << st.message();
    return b;
}

void expectSameRecords(const std::vector<Record>& a, const std::vector<Record>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].sequence, b[i].sequence) << i;
        EXPECT_EQ(a[i].step, b[i].step) << i;
        EXPECT_EQ(a[i].tokens, b[i].tokens) << i;
        EXPECT_EQ(a[i].surprise_bits, b[i].surprise_bits) << i;
        EXPECT_EQ(a[i].perplexity_bits, b[i].perplexity_bits) << i;
        EXPECT_EQ(a[i].labels, b[i].labels) << i;
        EXPECT_EQ(a[i].samples, b[i].samples) << i;
    }
}

// A stream whose frames sometimes exceed max_words_per_frame (subsampled at
// push, seeded by the producer sequence number) and sometimes are empty.
std::vector<Frame> stream(const EngineConfig& cfg, int frames, uint64_t seed) {
    std::vector<Frame> out = makeStream(cfg.model, frames, 30, seed);
    Rng r(seed + 1);
    for (Frame& f : out) {
        const uint32_t n = r.below(4) == 0 ? 0u : 10u + r.below(50);
        f.words.resize(std::min<std::size_t>(n, f.words.size()));
        f.positions.resize(f.words.size());
        while (f.words.size() < n) {  // more words than max_words_per_frame
            f.words.push_back(r.below(static_cast<uint32_t>(cfg.model.V)));
            f.positions.push_back({static_cast<int32_t>(r.below(static_cast<uint32_t>(cfg.model.frame_width))),
                                   static_cast<int32_t>(r.below(static_cast<uint32_t>(cfg.model.frame_height)))});
        }
    }
    return out;
}

// ---- the documented format, read independently of the loader ----------------

uint32_t le32(const std::vector<uint8_t>& b, std::size_t at) {
    return uint32_t{b[at]} | uint32_t{b[at + 1]} << 8 | uint32_t{b[at + 2]} << 16 | uint32_t{b[at + 3]} << 24;
}
uint64_t le64(const std::vector<uint8_t>& b, std::size_t at) { return le32(b, at) | uint64_t{le32(b, at + 4)} << 32; }
void put32(std::vector<uint8_t>& b, std::size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
}

struct SectionAt {
    std::string name;
    std::size_t header, payload, bytes;
    uint32_t width;
};

// Walks a checkpoint by the format in checkpoint.hpp, independently of the loader.
std::vector<SectionAt> sectionsOf(const std::vector<uint8_t>& b) {
    std::vector<SectionAt> out;
    std::size_t at = 32;
    for (uint32_t i = 0; i < le32(b, 12); ++i) {
        SectionAt s;
        s.name = std::string(reinterpret_cast<const char*>(&b[at]));
        s.width = le32(b, at + 32);
        s.bytes = static_cast<std::size_t>(le64(b, at + 40));
        s.header = at;
        s.payload = at + 56;
        at = s.payload + s.bytes;
        out.push_back(s);
    }
    return out;
}

// The sections in which two checkpoints differ (for failure messages).
std::string differingSections(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
    if (a.size() < 32 || b.size() < 32) return "(not checkpoints)";
    const auto sa = sectionsOf(a), sb = sectionsOf(b);
    if (sa.size() != sb.size()) return "(different section counts)";
    std::string out;
    for (std::size_t i = 0; i < sa.size(); ++i)
        if (sa[i].bytes != sb[i].bytes ||
            std::memcmp(&a[sa[i].payload], &b[sb[i].payload], sa[i].bytes) != 0)
        {
            out += sa[i].name;
            if (sa[i].name == "engine.counters" && sa[i].bytes == sb[i].bytes)
                for (std::size_t k = 0; k < sa[i].bytes / 8; ++k)
                    if (le64(a, sa[i].payload + 8 * k) != le64(b, sb[i].payload + 8 * k))
                    {
                        out += '[';
                        out += std::to_string(k);
                        out += "]=";
                        out += std::to_string(le64(a, sa[i].payload + 8 * k));
                        out += '/';
                        out += std::to_string(le64(b, sb[i].payload + 8 * k));
                    }
            out += " ";
        }
    return out.empty() ? "(none)" : out;
}

// Runs `frames` through a fresh engine, saving a checkpoint after `stopAt`
// observations; then resumes from the file in another engine and compares
// every later observation and the final state with the uninterrupted run.
void expectResumeBitForBit(const EngineConfig& cfg, const std::vector<int32_t>* prior, int stopAt, int total,
                           const std::string& tag) {
    SCOPED_TRACE(tag);
    const fs::path dir = tempDir("resume");
    const std::string path = (dir / "run.ckpt").string();
    const auto frames = stream(cfg, total, 17);

    Engine a(cfg);
    if (prior) {
        ASSERT_TRUE(a.model().addTopicCounts(*prior).ok());
    }
    std::vector<Record> recA;
    recordInto(a, recA);
    for (int f = 0; f < total; ++f) {
        a.processNow(frames[static_cast<std::size_t>(f)].view());
        if (f + 1 == stopAt) {
            const Status st = saveCheckpoint(a, path);
            ASSERT_TRUE(st.ok()) << st.message();
        }
    }

    Status st;
    CheckpointInfo info;
    auto b = resumeEngine(path, st, &info);
    ASSERT_TRUE(b) << st.message();
    EXPECT_EQ(info.observations, static_cast<uint64_t>(stopAt));
    EXPECT_EQ(info.next_sequence, static_cast<uint64_t>(stopAt));
    EXPECT_EQ(info.last_timestamp, frames[static_cast<std::size_t>(stopAt - 1)].timestamp);
    std::vector<Record> recB;
    recordInto(*b, recB);
    for (auto f = static_cast<int>(info.next_sequence); f < total; ++f) b->processNow(frames[static_cast<std::size_t>(f)].view());

    const std::vector<Record> tailA(recA.begin() + stopAt, recA.end());
    expectSameRecords(tailA, recB);
    const auto sa = stateOf(a), sb = stateOf(*b);
    EXPECT_TRUE(sa == sb) << "final states differ in sections " << differingSections(sa, sb);
    const EngineCounters ca = a.counters(), cb = b->counters();
    EXPECT_EQ(ca.pushed, cb.pushed);
    EXPECT_EQ(ca.ingested, cb.ingested);
    EXPECT_EQ(ca.tokens, cb.tokens);
    EXPECT_EQ(ca.words_truncated, cb.words_truncated);
    std::string why;
    EXPECT_TRUE(b->model().checkInvariants(&why)) << why;
    fs::remove_all(dir);
}

// ---- CRC-32C -----------------------------------------------------------------

TEST(Crc32c, MatchesTheStandardCheckValueAndChains) {
    const std::string s = "123456789";
    const std::span<const uint8_t> b(reinterpret_cast<const uint8_t*>(s.data()), s.size());
    EXPECT_EQ(crc32c(b), 0xE3069283u);  // the CRC-32C check value (RFC 3720, iSCSI)
    EXPECT_EQ(crc32c(b.subspan(4), crc32c(b.first(4))), 0xE3069283u);
    EXPECT_EQ(crc32c({}), 0u);
    std::vector<uint8_t> zeros(32, 0);
    EXPECT_EQ(crc32c(zeros), 0x8A9136AAu);  // RFC 3720 B.4: 32 bytes of zeros
    std::vector<uint8_t> ones(32, 0xFF);
    EXPECT_EQ(crc32c(ones), 0x62A8AB43u);  // RFC 3720 B.4: 32 bytes of 0xFF
}

// ---- resume ------------------------------------------------------------------

TEST(CheckpointResume, CountBudgetRunContinuesBitForBitAsIfNeverStopped) {
    const EngineConfig base = baseConfig();
    expectResumeBitForBit(base, nullptr, 23, 60, "steps budget, keep, ring wraps");

    EngineConfig sub = base;
    sub.model.eviction = EvictionPolicy::Subtract;
    sub.budget = Budget::tokens(150);
    sub.strategy.kind = StrategyKind::AgeProportionalExponential;
    expectResumeBitForBit(sub, nullptr, 31, 60, "tokens budget, subtract, agep+exp");

    EngineConfig ct = base;
    ct.model.cell_time = 3;
    ct.model.g_time = 1;
    ct.strategy.kind = StrategyKind::Exponential;
    expectResumeBitForBit(ct, nullptr, 17, 50, "cell.time 3, stopped mid-step");

    // A topic model imported before the run (counts outside the window).
    std::vector<int32_t> prior(static_cast<std::size_t>(base.model.K) * static_cast<std::size_t>(base.model.V));
    Rng r(5);
    for (auto& c : prior) c = static_cast<int32_t>(r.below(3));
    expectResumeBitForBit(sub, &prior, 29, 50, "subtract with a prior");

    expectResumeBitForBit(base, nullptr, 1, 20, "stopped after the first observation");

    // Growing topics: the open set is derived from n_k on resume; with
    // subtract eviction topics also close as steps leave.
    EngineConfig grow = sub;
    grow.model.grow = true;
    grow.model.gamma = 0.5;
    grow.model.threads = 2;
    expectResumeBitForBit(grow, nullptr, 27, 60, "growing topics, subtract, 2 threads");
}

// What a resumed engine reports of the steps still in its window is what
// the engine that saved it reported: each step's cells' surprise, the
// labels and the surprise of its observations (none of it is computed
// again on resume, so a field the checkpoint left out would read 0).
TEST(CheckpointResume, TheWindowsMeasurementsComeBackAsSaved) {
    const EngineConfig cfg = baseConfig();
    const fs::path dir = tempDir("measures");
    const std::string path = (dir / "m.ckpt").string();
    const auto frames = stream(cfg, 20, 4);
    Engine a(cfg);
    for (const Frame& f : frames) a.processNow(f.view());
    ASSERT_TRUE(saveCheckpoint(a, path).ok());
    Status st;
    auto b = resumeEngine(path, st);
    ASSERT_TRUE(b) << st.message();
    const Model &ma = a.model(), &mb = b->model();
    ASSERT_EQ(ma.oldestStep(), mb.oldestStep());
    ASSERT_EQ(ma.steps(), mb.steps());
    bool anySurprise = false;
    for (int64_t step = ma.oldestStep(); step < ma.oldestStep() + ma.steps(); ++step) {
        const auto sa = ma.cellSurprise(step), sb = mb.cellSurprise(step);
        ASSERT_EQ(sa.size(), sb.size());
        for (std::size_t c = 0; c < sa.size(); ++c) {
            EXPECT_EQ(bits(sa[c]), bits(sb[c])) << "step " << step << ", cell " << c;
            anySurprise = anySurprise || sa[c] > 0.0f;
        }
    }
    EXPECT_TRUE(anySurprise) << "the test's premise: cells with surprise in the window";
    for (uint64_t frame = 0; frame < frames.size(); ++frame)
        EXPECT_EQ(bits(ma.observationSurprise(frame)), bits(mb.observationSurprise(frame))) << "observation " << frame;
    fs::remove_all(dir);
}

TEST(CheckpointResume, ResumingTwiceFromTheSameFileGivesTheSameRun) {
    const EngineConfig cfg = baseConfig();
    const fs::path dir = tempDir("twice");
    const std::string path = (dir / "c.ckpt").string();
    const auto frames = stream(cfg, 40, 3);
    Engine a(cfg);
    for (int f = 0; f < 20; ++f) a.processNow(frames[static_cast<std::size_t>(f)].view());
    ASSERT_TRUE(saveCheckpoint(a, path).ok());
    std::vector<uint8_t> finals[2];
    for (auto& fin : finals) {
        Status st;
        auto e = resumeEngine(path, st);
        ASSERT_TRUE(e) << st.message();
        for (int f = 20; f < 40; ++f) e->processNow(frames[static_cast<std::size_t>(f)].view());
        fin = stateOf(*e);
    }
    EXPECT_EQ(finals[0], finals[1]);
    fs::remove_all(dir);
}

// Observations the queue dropped before a checkpoint, of either kind, are
// counted apart and come back as they were: the resumed engine's counters go
// on from the saved ones, and its next observation has the next sequence number.
TEST(CheckpointResume, DropsOfEachKindComeBackCountedApart) {
    const fs::path dir = tempDir("drops");
    for (const DropPolicy policy : {DropPolicy::DropNewest, DropPolicy::DropOldest}) {
        SCOPED_TRACE(toString(policy));
        EngineConfig cfg = baseConfig();  // four queue slots
        cfg.drop = policy;
        const auto frames = stream(cfg, 12, 4);
        Engine a(cfg);
        for (int f = 0; f < 7; ++f) (void)a.tryPush(frames[static_cast<std::size_t>(f)].view());  // 4 queued, 3 dropped
        EXPECT_EQ(a.processPending(), 4u);
        for (int f = 7; f < 10; ++f) a.processNow(frames[static_cast<std::size_t>(f)].view());
        const EngineCounters saved = a.counters();
        const bool newest = policy == DropPolicy::DropNewest;
        EXPECT_EQ(saved.dropped_newest, newest ? 3u : 0u);
        EXPECT_EQ(saved.dropped_oldest, newest ? 0u : 3u);
        EXPECT_EQ(saved.ingested, 7u);
        const std::string path = (dir / (std::string(toString(policy)) + ".ckpt")).string();
        ASSERT_TRUE(saveCheckpoint(a, path).ok());

        Status st;
        CheckpointInfo info;
        auto b = resumeEngine(path, st, &info);
        ASSERT_TRUE(b) << st.message();
        EXPECT_EQ(info.next_sequence, 10u);
        const EngineCounters back = b->counters();
        EXPECT_EQ(back.dropped_newest, saved.dropped_newest);
        EXPECT_EQ(back.dropped_oldest, saved.dropped_oldest);
        EXPECT_EQ(back.pushed, saved.pushed);
        EXPECT_EQ(back.ingested, saved.ingested);
        const ObservationResult r = b->processNow(frames[10].view());
        EXPECT_EQ(r.sequence, 10u);
        EXPECT_EQ(r.observation, 7u);
        EXPECT_EQ(b->counters().dropped_newest + b->counters().dropped_oldest, 3u);
    }
    fs::remove_all(dir);
}

TEST(CheckpointResume, PeriodicWriterOnARunningEngineResumesBitForBit) {
    // The refiner thread captures every 7th observation in its hook; the
    // writer thread writes the files. Whichever checkpoint is on disk at
    // the end, resuming from it with the rest of the stream gives the
    // uninterrupted run's final state.
    const EngineConfig cfg = baseConfig();
    const fs::path dir = tempDir("periodic");
    const std::string path = (dir / "run.ckpt").string();
    const auto frames = stream(cfg, 120, 9);

    Engine reference(cfg);
    for (const Frame& f : frames) reference.processNow(f.view());

    Engine live(cfg);
    Status st;
    auto writer = CheckpointWriter::create(live, path, st);
    ASSERT_TRUE(writer) << st.message();
    live.setObservationHook([&](const ObservationResult& r, const Model&) { writer->captureEvery(7, r); });
    ASSERT_TRUE(live.start().ok());
    for (const Frame& f : frames) ASSERT_TRUE(live.pushWait(f.view()));
    live.stop();
    ASSERT_TRUE(writer->flush().ok());
    const CheckpointWriter::Stats s = writer->stats();
    EXPECT_GE(s.captured, 1u);
    EXPECT_EQ(s.captured, s.written);
    EXPECT_EQ(s.captured + s.skipped, 120u / 7u);
    EXPECT_EQ(s.failed, 0u);
    EXPECT_GT(s.max_capture_ns, 0);
    EXPECT_EQ(writer->imageBytes(), stateOf(live).size());

    CheckpointInfo info;
    auto resumed = resumeEngine(path, st, &info);
    ASSERT_TRUE(resumed) << st.message();
    EXPECT_EQ(info.next_sequence % 7, 0u);
    EXPECT_EQ(info.observations, info.next_sequence);
    for (auto f = info.next_sequence; f < frames.size(); ++f) resumed->processNow(frames[f].view());
    const auto sr = stateOf(*resumed), sref = stateOf(reference);
    EXPECT_TRUE(sr == sref) << "sections differ: " << differingSections(sr, sref);

    // The final state, captured after stop(), is the reference's too.
    ASSERT_TRUE(writer->capture());
    ASSERT_TRUE(writer->flush().ok());
    std::string data;
    ASSERT_TRUE(readFile(path, data).ok());
    const std::vector<uint8_t> file(data.begin(), data.end());
    EXPECT_TRUE(file == sref) << "sections differ: " << differingSections(file, sref);
    writer.reset();
    fs::remove_all(dir);
}

// A state restored into an engine that had flushed its window: the
// restored window's observations go through the eviction hook as they
// leave the ring, though the engine's earlier flush had covered their
// numbers.
TEST(CheckpointLoad, ARestoredWindowGoesThroughTheEvictionHookAfterAFlush) {
    const EngineConfig cfg = baseConfig();  // ring of 6 steps, cell.time 1
    const auto frames = stream(cfg, 15, 23);
    Engine e(cfg);
    std::vector<uint64_t> seen;
    e.setEvictionHook([&](const WindowObservation& w, const Model&) { seen.push_back(w.observation); });
    for (int f = 0; f < 8; ++f) e.processNow(frames[static_cast<std::size_t>(f)].view());
    std::vector<uint8_t> at8;
    ASSERT_TRUE(encodeCheckpoint(e, at8).ok());
    for (int f = 8; f < 12; ++f) e.processNow(frames[static_cast<std::size_t>(f)].view());
    e.flushWindowToEvictionHook();
    ASSERT_EQ(seen.size(), 12u);  // 0..11, each once
    ASSERT_TRUE(loadCheckpoint(at8, "at8.ckpt", e).ok());
    seen.clear();
    for (int f = 8; f < 11; ++f) e.processNow(frames[static_cast<std::size_t>(f)].view());
    EXPECT_EQ(seen, (std::vector<uint64_t>{2, 3, 4})) << "the restored window's oldest left the ring unseen";
}

// Each test's engine and its periodic writer (open()) in a directory of the
// test's own, which goes when the test ends (the writer first: it may hold a
// temporary file).
class CheckpointWriterImage : public ::testing::Test {
protected:
    void open(const EngineConfig& c) {
        cfg = c;
        e = std::make_unique<Engine>(cfg);
        Status st;
        w = CheckpointWriter::create(*e, path, st);
        ASSERT_TRUE(w) << st.message();
    }
    void TearDown() override {
        w.reset();
        e.reset();
        fs::remove_all(dir);
    }
    fs::path dir = tempDir(::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::string path = (dir / "run.ckpt").string();
    EngineConfig cfg;
    std::unique_ptr<Engine> e;
    std::unique_ptr<CheckpointWriter> w;
};

// The end of a mission: a periodic image may still be being written when the
// engine stops (its fsync takes milliseconds), and a capture() then is
// skipped; finish() waits it out, so the file holds the state at the end.
TEST_F(CheckpointWriterImage, FinishWritesTheFinalStateEvenWhileAPeriodicWriteIsInProgress) {
    ASSERT_NO_FATAL_FAILURE(open(baseConfig()));
    e->captureCheckpoints(w.get(), 40);
    for (const Frame& f : stream(cfg, 40, 21)) e->processNow(f.view());  // the 40th captures and wakes the writer
    // At once, while that image is (most likely) still being checksummed,
    // written and fsync'ed: a capture() here would be skipped.
    ASSERT_TRUE(w->finish().ok());
    std::string data;
    ASSERT_TRUE(readFile(path, data).ok());
    const std::vector<uint8_t> file(data.begin(), data.end()), now = stateOf(*e);
    EXPECT_TRUE(file == now) << "sections differ: " << differingSections(file, now);
    EXPECT_EQ(w->stats().written, 2u) << "finish() wrote no image of its own";
    EXPECT_EQ(w->stats().skipped, 0u);
    // And when the state moved on after the last image: the file follows it.
    e->finalPass(1);
    ASSERT_TRUE(w->finish().ok());
    ASSERT_TRUE(readFile(path, data).ok());
    const std::vector<uint8_t> after(data.begin(), data.end()), moved = stateOf(*e);
    EXPECT_FALSE(moved == now) << "the final pass changed nothing";
    EXPECT_TRUE(after == moved) << "sections differ: " << differingSections(after, moved);
}

// A running engine's state read from another thread would be torn (a file
// that does not load): encodeCheckpoint and capture() refuse it there, and
// take it on the refiner thread (an observation hook) and once stopped.
TEST_F(CheckpointWriterImage, ARunningEngineIsSavedOnlyFromItsRefinerThread) {
    ASSERT_NO_FATAL_FAILURE(open(baseConfig()));
    std::atomic<int> inHook{0};
    e->setObservationHook([&](const ObservationResult&, const Model&) {
        std::vector<uint8_t> bytes;  // the hook may allocate: its own choice
        if (encodeCheckpoint(*e, bytes).ok() && e->onRefinerThread()) inHook.fetch_add(1);
    });
    ASSERT_TRUE(e->start().ok());
    EXPECT_FALSE(e->onRefinerThread());
    std::vector<uint8_t> bytes;
    const Status refused = encodeCheckpoint(*e, bytes);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("cannot save a running engine"), std::string::npos) << refused.message();
    const Status refusedSave = saveCheckpoint(*e, path);
    EXPECT_TRUE(refusedSave.message().starts_with(path + ": checkpoint: cannot save a running engine"))
        << refusedSave.message();
    EXPECT_FALSE(fs::exists(path));
    EXPECT_FALSE(w->capture());
    EXPECT_EQ(w->stats().failed, 1u);
    EXPECT_EQ(w->stats().captured, 0u);
    EXPECT_FALSE(w->finish().ok());
    for (const Frame& f : stream(cfg, 6, 22)) ASSERT_TRUE(e->pushWait(f.view()));
    e->stop();
    EXPECT_EQ(inHook.load(), 6);
    ASSERT_TRUE(encodeCheckpoint(*e, bytes).ok());
    ASSERT_TRUE(w->finish().ok());
    CheckpointInfo info;
    ASSERT_TRUE(readCheckpointInfo(path, info).ok());
    EXPECT_EQ(info.observations, 6u);
}

// The writer refreshes its image incrementally (steps already captured keep
// their words); after every capture the file must be exactly what a fresh
// encoding of the engine gives, across ring wraps, partially filled steps
// (cell.time 3) and frames that fill cells past capacity.
TEST_F(CheckpointWriterImage, IncrementalCapturesEqualAFreshEncodingEveryTime) {
    EngineConfig c = baseConfig();
    c.model.cell_time = 3;
    c.model.cell_capacity = 8;
    ASSERT_NO_FATAL_FAILURE(open(c));
    const auto frames = stream(cfg, 80, 12);
    Rng r(4);
    int captures = 0;
    for (const Frame& f : frames) {
        e->processNow(f.view());
        if (r.below(3) != 0) continue;
        ASSERT_TRUE(w->capture());
        ASSERT_TRUE(w->flush().ok());
        ++captures;
        std::string data;
        ASSERT_TRUE(readFile(path, data).ok());
        const std::vector<uint8_t> file(data.begin(), data.end()), fresh = stateOf(*e);
        ASSERT_TRUE(file == fresh) << "after observation " << e->model().observations() << ": "
                                   << differingSections(file, fresh);
    }
    EXPECT_GT(captures, 15);
}

// ---- the documented format ----------------------------------------------------

// Recomputes every checksum after a deliberate edit, as a forger would.
void reseal(std::vector<uint8_t>& b) {
    for (const SectionAt& s : sectionsOf(b)) {
        put32(b, s.header + 48, crc32c({b.data() + s.payload, s.bytes}));
        put32(b, s.header + 52, crc32c({b.data() + s.header, 52}));
    }
    put32(b, 28, crc32c({b.data(), 28}));
}

TEST(CheckpointFormat, IsTheDocumentedLittleEndianLayout) {
    const EngineConfig cfg = baseConfig();
    Engine e(cfg);
    for (const Frame& f : stream(cfg, 10, 1)) e.processNow(f.view());
    const std::vector<uint8_t> b = stateOf(e);
    ASSERT_GE(b.size(), 32u);
    EXPECT_EQ(std::string(b.begin(), b.begin() + 8), "ROSTCKPT");
    EXPECT_EQ(le32(b, 8), kCheckpointVersion);
    EXPECT_EQ(le64(b, 16), b.size());
    EXPECT_EQ(le32(b, 24), 0u);
    EXPECT_EQ(le32(b, 28), crc32c({b.data(), 28}));
    const auto secs = sectionsOf(b);
    ASSERT_EQ(secs.size(), le32(b, 12));
    const std::vector<std::string> expected = {
        "config", "counters.frames", "counters.steps", "counters.tokens_refined", "counters.words_in_model",
        "counters.nkv_is_window", "rng", "n_kv", "n_k", "inv", "inv_dec", "inv_inc", "ring.slot_step", "ring.cell_n",
        "ring.cell_words", "ring.cell_z", "ring.n_ck", "ring.cell_surprise", "ring.in_word", "ring.in_pos",
        "ring.in_slot", "ring.in_n", "ring.obs_surprise", "engine.counters", "engine.predictors",
        "engine.window.timestamp", "engine.window.sequence"};
    ASSERT_EQ(secs.size(), expected.size());
    for (std::size_t i = 0; i < secs.size(); ++i) {
        EXPECT_EQ(secs[i].name, expected[i]);
        EXPECT_EQ(le32(b, secs[i].header + 48), crc32c({b.data() + secs[i].payload, secs[i].bytes})) << secs[i].name;
        EXPECT_EQ(secs[i].bytes % secs[i].width, 0u);
    }
    EXPECT_EQ(secs.back().payload + secs.back().bytes, b.size());
    // Section 0 is the configuration as config-file text.
    const std::string text(reinterpret_cast<const char*>(&b[secs[0].payload]), secs[0].bytes);
    // Section 0 leaves out `threads` (the machine's), refine.window = 1 and,
    // without growth, topics.grow and gamma, and topicmodel.fixed = false
    // (what their absence means: checkpoints written before them stay valid).
    std::string expectedText;
    std::istringstream lines(formatConfig(cfg));
    for (std::string line; std::getline(lines, line);)
        if (!line.starts_with("threads = ") && line != "refine.window = 1" && line != "topics.grow = false" &&
            !line.starts_with("gamma = ") && line != "topicmodel.fixed = false")
            expectedText += line + "\n";
    EXPECT_NE(text.find("refine.window = "), std::string::npos);
    EXPECT_EQ(text.find("threads = "), std::string::npos);
    EXPECT_EQ(text.find("gamma = "), std::string::npos);
    EXPECT_EQ(text, expectedText);
    // counters.frames is a little-endian uint64.
    EXPECT_EQ(le64(b, secs[1].payload), 10u);
}

// ---- bad files: the engine is untouched, the message says what and where ------

struct Loaded {
    Status status;
    bool untouched = true;
};

// Loads `bytes` into an engine that already has a state of its own, and
// checks that a refused file left that state unchanged.
Loaded tryLoad(const std::vector<uint8_t>& bytes, const EngineConfig& cfg, const CheckpointLoadOptions& o = {}) {
    Engine e(cfg);
    for (const Frame& f : stream(cfg, 5, 99)) e.processNow(f.view());
    const std::vector<uint8_t> before = stateOf(e);
    Loaded l;
    l.status = loadCheckpoint(bytes, "run.ckpt", e, o);
    if (!l.status.ok()) l.untouched = stateOf(e) == before;
    return l;
}

std::vector<uint8_t> goodFile(const EngineConfig& cfg) {
    Engine e(cfg);
    for (const Frame& f : stream(cfg, 14, 4)) e.processNow(f.view());
    return stateOf(e);
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(CheckpointErrors, TruncationAtEverySectionBoundaryIsNamed) {
    const EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    ASSERT_TRUE(tryLoad(good, cfg).status.ok());
    const auto secs = sectionsOf(good);
    std::vector<std::size_t> cuts = {0, 5, 8, 31};
    for (const SectionAt& s : secs) {
        cuts.push_back(s.header);
        cuts.push_back(s.header + 20);
        cuts.push_back(s.payload);
        if (s.bytes > 1) cuts.push_back(s.payload + s.bytes / 2);
        if (s.bytes > 0) cuts.push_back(s.payload + s.bytes - 1);
    }
    for (std::size_t cut : cuts) {
        if (cut >= good.size()) continue;
        const std::vector<uint8_t> bad(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(cut));
        const Loaded l = tryLoad(bad, cfg);
        ASSERT_FALSE(l.status.ok()) << "cut at " << cut;
        EXPECT_TRUE(l.untouched) << "cut at " << cut;
        const std::string& m = l.status.message();
        EXPECT_TRUE(contains(m, "run.ckpt: ")) << m;
        if (cut == 0) {
            EXPECT_EQ(m, "run.ckpt: empty file, not a rost checkpoint");
        } else if (cut < 32) {
            EXPECT_TRUE(contains(m, "not a rost checkpoint") || contains(m, "truncated")) << m;
        } else {
            EXPECT_TRUE(contains(m, "truncated: the file ends at byte " + std::to_string(cut))) << m;
            // Named: the section whose header or payload the file ends in.
            bool named = false;
            for (std::size_t i = 0; i < secs.size(); ++i)
                if (cut >= secs[i].header && cut < secs[i].payload + secs[i].bytes)
                    named = cut < secs[i].payload ? contains(m, "header of section " + std::to_string(i))
                                                  : contains(m, "inside section '" + secs[i].name + "'");
            EXPECT_TRUE(named) << m;
        }
    }
    // One section boundary spelled out in full.
    const SectionAt& z = secs[15];
    ASSERT_EQ(z.name, "ring.cell_z");
    const std::vector<uint8_t> bad(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(z.payload + 2));
    EXPECT_EQ(tryLoad(bad, cfg).status.message(),
              "run.ckpt: truncated: the file ends at byte " + std::to_string(z.payload + 2) +
                  ", inside section 'ring.cell_z' (payload bytes " + std::to_string(z.payload) + ".." +
                  std::to_string(z.payload + z.bytes - 1) + "); the header says the file has " +
                  std::to_string(good.size()) + " bytes");
}

TEST(CheckpointErrors, AFlippedByteAnywhereIsCaughtAndItsSectionNamed) {
    const EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    const auto secs = sectionsOf(good);
    Rng r(11);
    int tried = 0;
    for (std::size_t i = 0; i < secs.size(); ++i) {
        const SectionAt& s = secs[i];
        std::vector<std::size_t> where = {s.header + r.below(56)};
        for (int j = 0; j < 3 && s.bytes > 0; ++j) where.push_back(s.payload + r.below(static_cast<uint32_t>(s.bytes)));
        for (std::size_t at : where) {
            std::vector<uint8_t> bad = good;
            bad[at] ^= static_cast<uint8_t>(1u << r.below(8));
            const Loaded l = tryLoad(bad, cfg);
            ++tried;
            ASSERT_FALSE(l.status.ok()) << "byte " << at;
            EXPECT_TRUE(l.untouched);
            const std::string& m = l.status.message();
            if (at >= s.payload) {
                EXPECT_TRUE(contains(m, "section '" + s.name + "' (payload bytes " + std::to_string(s.payload)) &&
                            contains(m, "is corrupt: checksum"))
                    << m;
            } else {
                EXPECT_TRUE(contains(m, "header of section " + std::to_string(i))) << m;
            }
        }
    }
    EXPECT_GT(tried, 80);
    for (std::size_t at : {0u, 9u, 13u, 20u, 29u}) {
        std::vector<uint8_t> bad = good;
        bad[at] ^= 0x10;
        const std::string m = tryLoad(bad, cfg).status.message();
        EXPECT_TRUE(at < 8 ? contains(m, "not a rost checkpoint") : contains(m, "file header (bytes 0..31) is corrupt"))
            << m;
    }
}

TEST(CheckpointErrors, WrongVersionMagicAndTrailingBytesAreNamed) {
    const EngineConfig cfg = baseConfig();
    std::vector<uint8_t> v2 = goodFile(cfg);
    put32(v2, 8, 2);
    reseal(v2);
    EXPECT_EQ(tryLoad(v2, cfg).status.message(),
              "run.ckpt: checkpoint format version 2 is not supported (this build reads version 1)");

    std::vector<uint8_t> other = goodFile(cfg);
    other[0] = 'X';
    EXPECT_EQ(tryLoad(other, cfg).status.message(), "run.ckpt: not a rost checkpoint (no \"ROSTCKPT\" magic at byte 0)");
    const std::string voc = std::string("ROSTVOC") + std::string(40, '\0');
    EXPECT_EQ(tryLoad(std::vector<uint8_t>(voc.begin(), voc.end()), cfg).status.message(),
              "run.ckpt: this is a rost vocabulary file, not a checkpoint");
    const std::string text = "K = 16\n";
    EXPECT_EQ(tryLoad(std::vector<uint8_t>(text.begin(), text.end()), cfg).status.message(),
              "run.ckpt: not a rost checkpoint (only 7 bytes)");

    // A header of no sections (or too many), its checksum valid: refused by the
    // header, before any section is looked for.
    for (const uint32_t count : {0u, 257u}) {
        std::vector<uint8_t> bare(other.begin(), other.begin() + 32);
        bare[0] = 'R';
        put32(bare, 12, count);
        put32(bare, 16, 32);
        put32(bare, 20, 0);
        put32(bare, 28, crc32c({bare.data(), 28}));  // the header's checksum (no sections to reseal)
        const Loaded l = tryLoad(bare, cfg);
        EXPECT_EQ(l.status.message(), "run.ckpt: file header: " + std::to_string(count) + " sections (expected 1..256)");
        EXPECT_TRUE(l.untouched);
    }

    std::vector<uint8_t> longer = goodFile(cfg);
    const std::size_t n = longer.size();
    longer.push_back(0);
    EXPECT_EQ(tryLoad(longer, cfg).status.message(),
              "run.ckpt: 1 unexpected bytes after the last section (from byte " + std::to_string(n) + ")");
}

TEST(CheckpointErrors, WrongConfigurationIsNamedKeyByKey) {
    const EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    EngineConfig k = cfg;
    k.model.K = 6;
    k.model.alpha = 0.25;
    Loaded l = tryLoad(good, k);
    EXPECT_EQ(l.status.message(),
              "run.ckpt: checkpoint was made with a different configuration: K = 8 in the checkpoint, 6 in this run; "
              "alpha = 0.1 in the checkpoint, 0.25 in this run");
    EXPECT_TRUE(l.untouched);

    EngineConfig budget = cfg;
    budget.budget = Budget::time(40);
    l = tryLoad(good, budget);
    EXPECT_EQ(l.status.message(),
              "run.ckpt: checkpoint was made with a different configuration: budget.refines = 3 in the checkpoint, "
              "(unset) in this run; budget.ms = (unset) in the checkpoint, 40 in this run");
    CheckpointLoadOptions allow;
    allow.allow_refinement_change = true;
    EXPECT_TRUE(tryLoad(good, budget, allow).status.ok());

    EngineConfig runtime = cfg;  // how this process runs does not matter
    runtime.queue_slots = 16;
    runtime.thread.cpu = 1;
    runtime.flags.snapshot_labels = false;
    EXPECT_TRUE(tryLoad(good, runtime).status.ok());

    EngineConfig seed = cfg;
    seed.model.seed = 8;
    EXPECT_TRUE(contains(tryLoad(good, seed).status.message(), "seed = 7 in the checkpoint, 8 in this run"));
}

TEST(CheckpointErrors, HostileContentsWithValidChecksumsAreRefusedNamingSectionAndElement) {
    const EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    const auto secs = sectionsOf(good);
    auto section = [&](const std::string& name) {
        for (const auto& s : secs)
            if (s.name == name) return s;
        ADD_FAILURE() << name;
        return secs[0];
    };
    struct Case {
        std::string section;
        std::size_t element;
        uint64_t value;
        std::string expect;
    };
    // The first cell of the ring that holds words, and its first word.
    const std::size_t cells = static_cast<std::size_t>(cfg.model.cellsPerStep());
    const SectionAt cellN = section("ring.cell_n");
    std::size_t ci = 0;
    while (le32(good, cellN.payload + 4 * ci) == 0) ++ci;
    const std::size_t firstWord = ci * static_cast<std::size_t>(cfg.model.cell_capacity);
    const std::vector<Case> cases = {
        {"ring.cell_z", firstWord, 8, "topic label 8 out of range [0, 8)"},
        {"ring.cell_words", firstWord, 400, "word id 400 out of range [0, 400)"},
        {"ring.cell_n", ci, 65,
         "65 words in cell " + std::to_string(ci % cells) + " of slot " + std::to_string(ci / cells) + ", capacity 64"},
        {"counters.nkv_is_window", 0, 2, "flag value 2 (expected 0 or 1)"},
        {"counters.steps", 0, 99, "step count 99 does not follow from 14 observations"},
        {"ring.slot_step", 0, 5, "slot 0 holds step 5, expected 12"},
        {"ring.in_n", 0, 41, "41 words in an observation, at most 40"},
        // A dropped word's cell (the flag 0x80000000 and its cell), one past the grid.
        {"ring.in_slot", 0, 0x80000000u | cells, "cell " + std::to_string(cells) + " out of range"},
        {"engine.predictors", 0, 0x7FF8000000000000ull, "cost estimate nan ns is out of range"},
        {"engine.predictors", 0, 0xBFF0000000000000ull, "cost estimate -1 ns is out of range [0, 1e12)"},
        {"engine.predictors", 0, 0x7E37E43C8800759Cull, "cost estimate 1e+300 ns is out of range [0, 1e12)"},
        {"n_k", 0, 12345, "the model state is inconsistent: n_k[0] = 12345 but sum_v n_k^v"},
        {"ring.n_ck", 16, 1000, "the model state is inconsistent: n_c^k mismatch"},
    };
    for (const Case& c : cases) {
        std::vector<uint8_t> bad = good;
        const SectionAt s = section(c.section);
        const std::size_t at = s.payload + c.element * s.width;
        ASSERT_LE(at + s.width, s.payload + s.bytes) << c.section;
        for (uint32_t i = 0; i < s.width; ++i) bad[at + i] = static_cast<uint8_t>(c.value >> (8 * i));
        reseal(bad);
        const Loaded l = tryLoad(bad, cfg);
        ASSERT_FALSE(l.status.ok()) << c.section;
        EXPECT_TRUE(l.untouched) << c.section;
        EXPECT_TRUE(contains(l.status.message(), c.expect)) << l.status.message();
        if (!contains(c.expect, "inconsistent")) {
            EXPECT_TRUE(contains(l.status.message(), "section '" + c.section + "', element " + std::to_string(c.element) +
                                                         " (byte " + std::to_string(at) + "): "))
                << l.status.message();
        }
    }
    // A generator stuck at zero.
    std::vector<uint8_t> bad = good;
    const SectionAt rng = section("rng");
    std::fill(bad.begin() + static_cast<std::ptrdiff_t>(rng.payload),
              bad.begin() + static_cast<std::ptrdiff_t>(rng.payload + rng.bytes), 0);
    reseal(bad);
    EXPECT_TRUE(contains(tryLoad(bad, cfg).status.message(), "generator state is all zero")) << tryLoad(bad, cfg).status.message();
    // A config section that is not a configuration.
    std::vector<uint8_t> conf = good;
    conf[section("config").payload] = '!';
    reseal(conf);
    EXPECT_TRUE(contains(tryLoad(conf, cfg).status.message(), "run.ckpt [config section at byte 88]:1: "))
        << tryLoad(conf, cfg).status.message();
}

// Rebuilds a checkpoint with one section's payload replaced (sizes, file
// size and every checksum updated): a well-formed file with other contents.
std::vector<uint8_t> withSection(const std::vector<uint8_t>& b, const std::string& name, const std::string& payload) {
    std::vector<uint8_t> out(b.begin(), b.begin() + 32);
    for (const SectionAt& s : sectionsOf(b)) {
        const std::size_t h = out.size();
        out.insert(out.end(), b.begin() + static_cast<std::ptrdiff_t>(s.header),
                   b.begin() + static_cast<std::ptrdiff_t>(s.payload));
        if (s.name == name) {
            for (int i = 0; i < 8; ++i) out[h + 40 + static_cast<std::size_t>(i)] = static_cast<uint8_t>(payload.size() >> (8 * i));
            out.insert(out.end(), payload.begin(), payload.end());
        } else {
            out.insert(out.end(), b.begin() + static_cast<std::ptrdiff_t>(s.payload),
                       b.begin() + static_cast<std::ptrdiff_t>(s.payload + s.bytes));
        }
    }
    for (int i = 0; i < 8; ++i) out[16 + static_cast<std::size_t>(i)] = static_cast<uint8_t>(out.size() >> (8 * i));
    reseal(out);
    return out;
}

TEST(CheckpointErrors, ASmallFileClaimingAHugeConfigurationIsRefusedBeforeAllocating) {
    // Valid checksums, a configuration asking for gigabytes of ring, and the
    // small sections of the original: refused by size, before an engine of
    // the claimed size is built.
    EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    EngineConfig huge = cfg;
    huge.model.ring_steps = 1 << 20;
    const std::string text = formatConfig(huge);
    const std::vector<uint8_t> bad = withSection(good, "config", text);
    const fs::path dir = tempDir("huge");
    const std::string path = (dir / "huge.ckpt").string();
    ASSERT_TRUE(writeFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bad.data()), bad.size())).ok());
    CheckpointInfo info;
    ASSERT_TRUE(readCheckpointInfo(path, info).ok());
    EXPECT_EQ(info.config.model.ring_steps, 1 << 20);
    Status st;
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_FALSE(resumeEngine(path, st));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
    EXPECT_TRUE(contains(st.message(), path + ": section 'ring.slot_step' has 48 bytes")) << st.message();
    EXPECT_TRUE(contains(st.message(), "the configuration in the file implies 8388608")) << st.message();
    // The same file against an engine of the original size: the configuration differs.
    EXPECT_TRUE(contains(tryLoad(bad, cfg).status.message(), "ring.steps = 1048576 in the checkpoint, 6 in this run"));
    fs::remove_all(dir);
}

TEST(CheckpointErrors, EveryTableThatGrowsWithTheConfigurationIsCheckedBeforeAnEngineIsBuilt) {
    // Each claim grows other tables (the vocabulary n_kv; the cells' n_ck
    // alone, with a vocabulary and ring that keep their sizes; the inputs;
    // the words a cell holds). Each is refused by readers that would build
    // an engine of the claimed size: resumeEngine (rost merge) and
    // planMission (--resume of every face), in moments, naming the section.
    const EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    std::size_t nkvBytes = 0;
    for (const SectionAt& at : sectionsOf(good))
        if (at.name == "n_kv") nkvBytes = at.bytes;
    const int Kp = static_cast<int>(nkvBytes / (static_cast<std::size_t>(cfg.model.V) * 4));  // K as the tables pad it
    ASSERT_GE(Kp, cfg.model.K);
    struct Claim {
        const char* what;
        std::function<void(Config&)> apply;
        const char* section;
    };
    const Claim claims[] = {
        {"K four times, V a quarter: n_kv keeps its size", [Kp](Config& m) { m.K = 4 * Kp; m.V /= 4; }, "ring.n_ck"},
        {"V", [](Config& m) { m.V = 1 << 24; }, "n_kv"},
        {"a frame of many cells", [](Config& m) { m.frame_width = m.frame_height = 4096; }, "ring.cell_n"},
        {"cell.time", [](Config& m) { m.cell_time = 1024; }, "ring.in_word"},
        {"max.words", [](Config& m) { m.max_words_per_frame = 1 << 20; }, "ring.in_word"},
        {"cell.capacity", [](Config& m) { m.cell_capacity = 1 << 20; }, "ring.cell_words"},
    };
    const fs::path dir = tempDir("claims");
    for (const Claim& c : claims) {
        SCOPED_TRACE(c.what);
        EngineConfig huge = cfg;
        c.apply(huge.model);
        const std::vector<uint8_t> bad = withSection(good, "config", formatConfig(huge));
        const std::string path = (dir / "claim.ckpt").string();
        ASSERT_TRUE(writeFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bad.data()), bad.size())).ok());
        CheckpointInfo info;
        ASSERT_TRUE(readCheckpointInfo(path, info).ok());
        EXPECT_TRUE(contains(info.sizes_problem, std::string("section '") + c.section + "'")) << info.sizes_problem;
        const auto t0 = std::chrono::steady_clock::now();
        Status st;
        EXPECT_FALSE(resumeEngine(path, st));
        EXPECT_EQ(st.message(), path + ": " + info.sizes_problem);
        MissionOptions m;
        m.resume = path;
        MissionPlan plan;
        const Status planned = planMission(m, MissionInput{}, plan);
        EXPECT_EQ(planned.message(), m.names.resume + ": " + path + ": " + info.sizes_problem);
        EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
    }
    // The file as written passes the same check.
    CheckpointInfo info;
    ASSERT_TRUE(inspectCheckpoint(good, "good.ckpt", info).ok());
    EXPECT_EQ(info.sizes_problem, "");
    fs::remove_all(dir);
}

TEST(CheckpointErrors, LoadIsRefusedWhileRunningOrWithQueuedObservations) {
    const EngineConfig cfg = baseConfig();
    const std::vector<uint8_t> good = goodFile(cfg);
    Engine e(cfg);
    const auto frames = stream(cfg, 2, 1);
    ASSERT_TRUE(e.tryPush(frames[0].view()));
    EXPECT_EQ(loadCheckpoint(good, "run.ckpt", e).message(),
              "run.ckpt: cannot load a checkpoint while 1 observation is queued");
    e.processPending();
    ASSERT_TRUE(e.start().ok());
    EXPECT_EQ(loadCheckpoint(good, "run.ckpt", e).message(),
              "run.ckpt: cannot load a checkpoint into a running engine (stop it first)");
    e.stop();
    EXPECT_TRUE(loadCheckpoint(good, "run.ckpt", e).ok());
}

TEST(CheckpointFiles, MissingFileMissingDirectoryAndARunningEngineAreNamed) {
    const EngineConfig cfg = baseConfig();
    Engine e(cfg);
    Status st = loadCheckpoint(std::string("/nonexistent/run.ckpt"), e);
    EXPECT_EQ(st.message(), "/nonexistent/run.ckpt: cannot open: No such file or directory");
    std::unique_ptr<Engine> r = resumeEngine("/nonexistent/run.ckpt", st);
    EXPECT_FALSE(r);
    EXPECT_EQ(st.message(), "/nonexistent/run.ckpt: cannot open: No such file or directory");
    st = saveCheckpoint(e, "/nonexistent/run.ckpt");
    EXPECT_TRUE(contains(st.message(), "/nonexistent/run.ckpt: cannot create a temporary file in /nonexistent"))
        << st.message();
    auto w = CheckpointWriter::create(e, "/nonexistent/run.ckpt", st);
    EXPECT_FALSE(w);
    EXPECT_EQ(st.message(), "/nonexistent/run.ckpt: directory /nonexistent does not exist");
    ASSERT_TRUE(e.start().ok());
    w = CheckpointWriter::create(e, "run.ckpt", st);
    EXPECT_FALSE(w);
    EXPECT_EQ(st.message(), "run.ckpt: create the checkpoint writer before the engine starts");
    e.stop();
}

TEST(CheckpointFiles, AFailedWriteIsReportedAndThePreviousFileStays) {
    const EngineConfig cfg = baseConfig();
    const fs::path dir = tempDir("failed");
    const std::string path = (dir / "run.ckpt").string();
    Engine e(cfg);
    for (const Frame& f : stream(cfg, 6, 2)) e.processNow(f.view());
    Status st;
    auto w = CheckpointWriter::create(e, path, st);
    ASSERT_TRUE(w) << st.message();
    ASSERT_TRUE(w->capture());
    ASSERT_TRUE(w->flush().ok());
    const std::vector<uint8_t> first = stateOf(e);
    // The target becomes a non-empty directory: rename fails.
    const fs::path blocker = dir / "blocked.ckpt";
    fs::create_directories(blocker / "x");
    auto w2 = CheckpointWriter::create(e, blocker.string(), st);
    ASSERT_TRUE(w2) << st.message();
    ASSERT_TRUE(w2->capture());
    st = w2->flush();
    EXPECT_TRUE(contains(st.message(), blocker.string() + ": rename failed")) << st.message();
    EXPECT_EQ(w2->stats().failed, 1u);
    std::string data;
    ASSERT_TRUE(readFile(path, data).ok());
    EXPECT_EQ(std::vector<uint8_t>(data.begin(), data.end()), first);
    w.reset();
    w2.reset();
    fs::remove_all(dir);
}

TEST(CheckpointFiles, WriterRemovesTemporaryFilesOfInterruptedSaves) {
    const fs::path dir = tempDir("stale");
    const std::string path = (dir / "run.ckpt").string();
    std::ofstream(dir / ".run.ckpt.tmpAbC123") << "half a checkpoint";
    std::ofstream(dir / ".other.ckpt.tmpAbC123") << "someone else's";
    Engine e(baseConfig());
    Status st;
    auto w = CheckpointWriter::create(e, path, st);
    ASSERT_TRUE(w) << st.message();
    EXPECT_FALSE(fs::exists(dir / ".run.ckpt.tmpAbC123"));
    EXPECT_TRUE(fs::exists(dir / ".other.ckpt.tmpAbC123"));
    w.reset();
    // Through a link into a store, the writes (and what a kill leaves) are
    // beside the store's file: that is where the writer cleans up.
    fs::create_directory(dir / "store");
    fs::create_directory(dir / "d");
    fs::create_symlink("../store/m.ckpt", dir / "d" / "m.ckpt");
    std::ofstream(dir / "store" / ".m.ckpt.tmpAbC123") << "half a checkpoint";
    auto linked = CheckpointWriter::create(e, (dir / "d" / "m.ckpt").string(), st);
    ASSERT_TRUE(linked) << st.message();
    EXPECT_FALSE(fs::exists(dir / "store" / ".m.ckpt.tmpAbC123"));
    linked.reset();
    fs::remove_all(dir);
}

// ---- topic model CSV ----------------------------------------------------------

TEST(TopicModelCsv, ExportImportRoundTripsTheCounts) {
    const EngineConfig cfg = baseConfig();
    Engine e(cfg);
    for (const Frame& f : stream(cfg, 20, 6)) e.processNow(f.view());
    const fs::path dir = tempDir("topics");
    const std::string path = (dir / "topicmodel.csv").string();
    ASSERT_TRUE(writeTopicModelCsv(e.model(), path).ok());
    Model fresh(cfg.model);
    const Status st = loadTopicModelCsv(path, fresh);
    ASSERT_TRUE(st.ok()) << st.message();
    for (int k = 0; k < cfg.model.K; ++k) {
        EXPECT_EQ(fresh.topicCount(k), e.model().topicCount(k));
        for (int v = 0; v < cfg.model.V; ++v) ASSERT_EQ(fresh.topicWordCount(k, v), e.model().topicWordCount(k, v));
    }
    EXPECT_EQ(fresh.wordsInModel(), e.model().wordsInModel());
    std::string why;
    EXPECT_TRUE(fresh.checkInvariants(&why)) << why;
    fs::remove_all(dir);
}

TEST(TopicModelCsv, ImportedTopicsMakeTheSameSceneLessSurprisingInANewMission) {
    // Mission 1 learns the scene; mission 2 starts with its topic model and
    // finds the first observations of the same scene less surprising than a
    // mission starting from nothing.
    EngineConfig cfg = baseConfig();
    cfg.budget = Budget::steps(10);
    const auto frames = makeStream(cfg.model, 60, 30, 21);
    Engine first(cfg);
    for (int f = 0; f < 30; ++f) first.processNow(frames[static_cast<std::size_t>(f)].view());
    const std::string csv = formatTopicModelCsv(first.model());
    std::vector<int32_t> counts;
    ASSERT_TRUE(parseTopicModelCsv(csv, cfg.model.K, cfg.model.V, counts).ok());
    double withPrior = 0.0, without = 0.0;
    for (int run = 0; run < 2; ++run) {
        Engine e(cfg);
        if (run == 0) {
            ASSERT_TRUE(e.model().addTopicCounts(counts).ok());
        }
        double s = 0.0;
        for (int f = 0; f < 5; ++f) s += e.processNow(frames[static_cast<std::size_t>(f)].view()).surprise;
        (run == 0 ? withPrior : without) = s / 5;
    }
    EXPECT_LT(withPrior, 0.8 * without) << withPrior << " vs " << without;
}

TEST(TopicModelCsv, ErrorsNameFileLineAndColumn) {
    std::vector<int32_t> c;
    auto err = [&](const std::string& text, int K = 2, int V = 3) {
        const Status st = parseTopicModelCsv(text, K, V, c);
        return st.ok() ? std::string("ok") : st.message();
    };
    EXPECT_EQ(err("1,2,3\n4,5,6\n"), "ok");
    EXPECT_EQ(c, (std::vector<int32_t>{1, 2, 3, 4, 5, 6}));
    EXPECT_EQ(err("# header\n1, 2 ,3,\r\n\n4,5,6"), "ok");
    // Fewer lines than K (a growth run's A open topics): the rest start empty.
    EXPECT_EQ(err("1,2,3\n"), "ok");
    EXPECT_EQ(c, (std::vector<int32_t>{1, 2, 3, 0, 0, 0}));
    EXPECT_EQ(err("# nothing\n\n"), "topicmodel.csv: no topic lines (expected 1 to K = 2)");
    EXPECT_EQ(err("1,2,3\n4,5,6\n7,8,9\n"), "topicmodel.csv:3:1: more than K = 2 topic lines");
    EXPECT_EQ(err("1,2,3\n4,5\n"), "topicmodel.csv:2:1: 2 counts, expected 3 as on the first line");
    // Lines shorter than V (a model of fewer words): the words past them count 0.
    EXPECT_EQ(err("1,2\n4,5\n"), "ok");
    EXPECT_EQ(c, (std::vector<int32_t>{1, 2, 0, 4, 5, 0}));
    EXPECT_EQ(err("1,2,3,4\n4,5,6\n"), "topicmodel.csv:1:7: more than V = 3 counts");
    EXPECT_EQ(err("1,2,3\n4,x5,6\n"), "topicmodel.csv:2:3: expected a count, found 'x5'");
    EXPECT_EQ(err("1,2,3\n4,-5,6\n"), "topicmodel.csv:2:3: count '-5' out of range [0, 2^31)");
    EXPECT_EQ(err("1,,3\n4,5,6\n"), "topicmodel.csv:1:3: empty field");
    EXPECT_EQ(err("1,2,99999999999999999999\n4,5,6\n"),
              "topicmodel.csv:1:5: count '99999999999999999999' out of range [0, 2^31)");
    EXPECT_EQ(err("2000000000,2000000000,0\n4,5,6\n"), "topicmodel.csv:1:12: topic 0's total count exceeds 2^31 - 1");
    // The count's own edges: 2^31 - 1 is a count, 2^31 is not.
    EXPECT_EQ(err("2147483647,0,0\n4,5,6\n"), "ok");
    EXPECT_EQ(c[0], 2147483647);
    EXPECT_EQ(err("0,2147483648,0\n4,5,6\n"), "topicmodel.csv:1:3: count '2147483648' out of range [0, 2^31)");
    EXPECT_EQ(err("1.5,2,3\n4,5,6\n"), "topicmodel.csv:1:1: expected a count, found '1.5'");

    const fs::path dir = tempDir("topics_err");
    const std::string path = (dir / "tm.csv").string();
    ASSERT_TRUE(writeFileAtomic(path, "1,2\n3\n").ok());
    Config small = smallConfig();
    Model m(small);
    EXPECT_EQ(loadTopicModelCsv(path, m).message(), path + ":2:1: 1 counts, expected 2 as on the first line");
    EXPECT_EQ(loadTopicModelCsv("/nonexistent/tm.csv", m).message(),
              "/nonexistent/tm.csv: cannot open: No such file or directory");
    fs::remove_all(dir);
}

// n_k is 32-bit. A topic model added to a model that already holds counts (a
// second --in.topicmodel, a ROS client's ~set_topic_model called twice) is
// refused where a topic's total would leave no room for the words the window
// can hold, and the model is left as it was; up to that bound it is taken.
TEST(TopicModelCsv, CountsPastTwoToThe31WithTheModelsOwnAreRefusedAndChangeNothing) {
    Config c = smallConfig();
    c.K = 2;
    c.V = 2;
    Model m(c);
    const int64_t window = static_cast<int64_t>(c.ring_steps) * c.cellsPerStep() * c.cell_capacity;
    const auto most = static_cast<int32_t>(2147483647 - window - 1);
    const std::vector<int32_t> full = {most - 1, 0, 0, 5};
    ASSERT_TRUE(m.addTopicCounts(full).ok());
    const std::vector<int32_t> one = {0, 1, 0, 0};
    ASSERT_TRUE(m.addTopicCounts(one).ok());  // exactly the bound
    EXPECT_EQ(m.topicCount(0), most);
    const std::string refused = "topic 0 would hold " + std::to_string(int64_t{most} + 1) +
                                " words with the model's own counts, more than the " + std::to_string(most) +
                                " that leave room for the window's " + std::to_string(window) + " (n_k is 32-bit)";
    const std::vector<int32_t> past = {1, 0, 0, 1};
    EXPECT_EQ(m.addTopicCounts(past).message(), refused);
    EXPECT_EQ(m.topicCount(0), most);
    EXPECT_EQ(m.topicCount(1), 5);
    EXPECT_EQ(m.topicWordCount(1, 1), 5);
    std::string why;
    EXPECT_TRUE(m.checkInvariants(&why)) << why;

    const fs::path dir = tempDir("topics_total");
    const std::string path = (dir / "tm.csv").string();
    ASSERT_TRUE(writeFileAtomic(path, "0,1\n").ok());
    EXPECT_EQ(loadTopicModelCsv(path, m).message(), path + ": " + refused);
    EXPECT_EQ(m.topicCount(0), most);
    fs::remove_all(dir);
}

} // namespace
} // namespace rost
