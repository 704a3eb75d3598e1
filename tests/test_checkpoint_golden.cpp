// Checkpoints written by an earlier build still load and continue bit for
// bit. tests/data/checkpoint-v1.ckpt was written by format version 1 as it
// was before the state layout was moved into Model/Engine (commit 4a96891);
// tests/data/checkpoint-v1-continued.ckpt is the same engine after the rest
// of the stream, and checkpoint-v1-continuation.txt a digest of every later
// observation's results. Regenerate (only when the format changes on
// purpose, with a new version) by running this test with
// ROST_WRITE_GOLDEN_CHECKPOINTS=1.

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/config_file.hpp"
#include "rost/random.hpp"
#include "rost/word_stream.hpp"

#ifndef ROST_TEST_DATA_DIR
#error "ROST_TEST_DATA_DIR must name tests/data"
#endif

namespace rost {
namespace {

const std::string kDir = ROST_TEST_DATA_DIR;
const std::string kFirst = kDir + "/checkpoint-v1.ckpt";
const std::string kContinued = kDir + "/checkpoint-v1-continued.ckpt";
const std::string kDigest = kDir + "/checkpoint-v1-continuation.txt";
constexpr int kStopAt = 17;  // mid-step (cell.time 2), after the ring has wrapped
constexpr int kTotal = 40;

// Every key given explicitly, so changed defaults cannot change the file.
EngineConfig goldenConfig() {
    EngineConfig e;
    Config& c = e.model;
    c.K = 8;
    c.V = 60;
    c.alpha = 0.1;
    c.beta = 0.5;
    c.cell_space = 32;  // 4 x 3 cells
    c.cell_time = 2;
    c.g_space = 1;
    c.g_time = 1;
    c.frame_width = 128;
    c.frame_height = 96;
    c.ring_steps = 4;
    c.cell_capacity = 16;  // crowded cells are subsampled
    c.max_words_per_frame = 24;  // long frames are subsampled at push
    c.eviction = EvictionPolicy::Keep;
    c.seed = 11;
    e.strategy.kind = StrategyKind::UniformNow;
    e.strategy.eta = 0.5;
    e.strategy.q = 0.5;
    e.budget = Budget::steps(3);
    e.queue_slots = 4;
    e.drop = DropPolicy::DropOldest;
    return e;
}

struct Obs {
    int64_t timestamp = 0;
    std::vector<uint32_t> words;
    std::vector<Position> positions;
};

// Self-contained (rost::Rng only): empty frames, frames longer than
// max.words, words crowded into one corner, and one word out of range.
std::vector<Obs> goldenStream(const Config& c) {
    Rng r(2024);
    std::vector<Obs> out(kTotal);
    for (int f = 0; f < kTotal; ++f) {
        Obs& o = out[static_cast<std::size_t>(f)];
        o.timestamp = 500 + 33 * f;
        const uint32_t n = f % 7 == 3 ? 0u : 5u + r.below(40);
        const bool corner = f % 5 == 1;
        for (uint32_t i = 0; i < n; ++i) {
            const auto x = static_cast<int32_t>(r.below(corner ? 30u : static_cast<uint32_t>(c.frame_width)));
            const auto y = static_cast<int32_t>(r.below(corner ? 30u : static_cast<uint32_t>(c.frame_height)));
            const uint32_t block = (x < c.frame_width / 2 ? 0u : 1u) + (f < kTotal / 2 ? 0u : 2u);
            o.words.push_back(r.below(8) == 0 ? r.below(static_cast<uint32_t>(c.V)) : block * 15u + r.below(15));
            o.positions.push_back({x, y});
        }
        if (f == 6 || f == 29) o.words.back() = static_cast<uint32_t>(c.V);  // rejected
    }
    return out;
}

ObservationView viewOf(const Obs& o) { return {o.timestamp, o.words, o.positions}; }

// CRC-32C over every later observation's results (labels, samples, step,
// tokens, surprise and perplexity bits), as hex.
struct Digest {
    uint32_t crc = 0;
    template <typename T>
    void add(const T* p, std::size_t n) {
        crc = crc32c({reinterpret_cast<const uint8_t*>(p), n * sizeof(T)}, crc);
    }
};

void digestInto(Engine& e, Digest& d) {
    e.setObservationHook([&d](const ObservationResult& r, const Model& m) {
        const int64_t head[3] = {r.step, static_cast<int64_t>(r.tokens), static_cast<int64_t>(r.sequence)};
        d.add(head, 3);
        double f[2] = {r.surprise, r.perplexity};
        d.add(f, 2);
        if (r.step < 0) return;
        const uint32_t n = m.observationSize(r.observation);
        std::vector<uint16_t> labels(n), samples(n);
        m.observationLabels(r.observation, labels);
        m.observationSamples(r.observation, samples);
        d.add(labels.data(), n);
        d.add(samples.data(), n);
    });
}

std::vector<uint8_t> readBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string hex(uint32_t v) {
    std::ostringstream s;
    s << std::hex << v;
    return s.str();
}

void writeGolden() {
    const EngineConfig cfg = goldenConfig();
    const auto frames = goldenStream(cfg.model);
    Engine e(cfg);
    for (int f = 0; f < kStopAt; ++f) e.processNow(viewOf(frames[static_cast<std::size_t>(f)]));
    ASSERT_TRUE(saveCheckpoint(e, kFirst).ok());
    Digest d;
    digestInto(e, d);
    for (int f = kStopAt; f < kTotal; ++f) e.processNow(viewOf(frames[static_cast<std::size_t>(f)]));
    ASSERT_TRUE(saveCheckpoint(e, kContinued).ok());
    ASSERT_TRUE(writeFileAtomic(kDigest, hex(d.crc) + "\n").ok());
}

TEST(CheckpointGolden, AFileWrittenBeforeTheStateLayoutLoadsAndContinuesBitForBit) {
    if (const char* w = std::getenv("ROST_WRITE_GOLDEN_CHECKPOINTS"); w && std::string(w) == "1") writeGolden();

    const std::vector<uint8_t> first = readBytes(kFirst), continued = readBytes(kContinued);
    ASSERT_FALSE(first.empty()) << kFirst;
    ASSERT_FALSE(continued.empty()) << kContinued;

    // The file's own configuration, as --resume builds it.
    Status st;
    CheckpointInfo info;
    auto e = resumeEngine(kFirst, st, &info);
    ASSERT_TRUE(e) << st.message();
    EXPECT_EQ(info.version, 1u);
    EXPECT_EQ(info.observations, static_cast<uint64_t>(kStopAt - 1));  // observation 6 was rejected
    EXPECT_EQ(info.next_sequence, static_cast<uint64_t>(kStopAt));
    const auto frames = goldenStream(info.config.model);
    EXPECT_EQ(info.last_timestamp, frames[kStopAt - 1].timestamp);

    // Loaded and encoded again: the same bytes.
    std::vector<uint8_t> again;
    ASSERT_TRUE(encodeCheckpoint(*e, again).ok());
    EXPECT_TRUE(again == first) << "re-encoding the loaded checkpoint changed it";

    // The rest of the stream: the same results and the same final state.
    Digest d;
    digestInto(*e, d);
    for (auto f = static_cast<int>(info.next_sequence); f < kTotal; ++f)
        e->processNow(viewOf(frames[static_cast<std::size_t>(f)]));
    std::vector<uint8_t> after;
    ASSERT_TRUE(encodeCheckpoint(*e, after).ok());
    EXPECT_TRUE(after == continued) << "the continued run's state differs from the one the earlier build saved";
    std::ifstream in(kDigest);
    std::string expected;
    in >> expected;
    EXPECT_EQ(hex(d.crc), expected) << "the continued run's per-observation results differ";
    std::string why;
    EXPECT_TRUE(e->model().checkInvariants(&why)) << why;
}

// A section of another version (a later layout of its contents) is refused
// naming the version found and the version this build reads; so is another
// format version.
TEST(CheckpointGolden, AnotherSectionOrFormatVersionIsRefusedNamingBothVersions) {
    std::vector<uint8_t> b = readBytes(kFirst);
    ASSERT_GT(b.size(), 32u);
    auto put32 = [](std::vector<uint8_t>& f, std::size_t at, uint32_t v) {
        for (int i = 0; i < 4; ++i) f[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
    };
    auto get = [&b](std::size_t at, int n) {
        uint64_t v = 0;
        for (int i = 0; i < n; ++i) v |= uint64_t{b[at + static_cast<std::size_t>(i)]} << (8 * i);
        return v;
    };
    // Find "n_kv" and give it version 3, with a valid header checksum.
    std::size_t at = 32, nkv = 0;
    for (uint64_t i = 0; i < get(12, 4); ++i) {
        if (std::string(reinterpret_cast<const char*>(&b[at])) == "n_kv") nkv = at;
        at += 56 + get(at + 40, 8);
    }
    ASSERT_NE(nkv, 0u);
    std::vector<uint8_t> v3 = b;
    put32(v3, nkv + 36, 3);
    put32(v3, nkv + 52, crc32c({&v3[nkv], 52}));
    Status st;
    auto e = resumeEngine(kFirst, st);
    ASSERT_TRUE(e) << st.message();
    std::vector<uint8_t> before;
    ASSERT_TRUE(encodeCheckpoint(*e, before).ok());
    st = loadCheckpoint(v3, "v3.ckpt", *e);
    EXPECT_EQ(st.message(), "v3.ckpt: section 'n_kv' (header at byte " + std::to_string(nkv) +
                                ") is version 3, this build reads version 0");
    std::vector<uint8_t> after;
    ASSERT_TRUE(encodeCheckpoint(*e, after).ok());
    EXPECT_TRUE(before == after) << "a refused file changed the engine";

    // Format version 2 in the file header.
    put32(b, 8, 2);
    put32(b, 28, crc32c({b.data(), 28}));
    st = loadCheckpoint(b, "v2.ckpt", *e);
    EXPECT_EQ(st.message(), "v2.ckpt: checkpoint format version 2 is not supported (this build reads version 1)");
}

} // namespace
} // namespace rost
