// Vocabulary: nearest-word search, the file format (round trip and every
// kind of damage a loader must name), and k-majority training.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>

#include "rost/random.hpp"
#include "rost/vision/vocabulary.hpp"
#include "test_vision_support.hpp"

using namespace rost;
using namespace rost::vision;

namespace {

Descriptor randomDescriptor(Rng& rng) {
    Descriptor d;
    for (auto& w : d.w) w = (static_cast<uint64_t>(rng.next()) << 32) | rng.next();
    return d;
}

Descriptor flipBits(Descriptor d, int bits, Rng& rng) {
    for (int i = 0; i < bits; ++i) {
        const uint32_t b = rng.below(256);
        d.w[b >> 6] ^= 1ull << (b & 63);
    }
    return d;
}

std::vector<Descriptor> randomWords(uint32_t n, uint64_t seed) {
    Rng rng(seed);
    std::vector<Descriptor> w(n);
    for (auto& d : w) d = randomDescriptor(rng);
    return w;
}

// Reference: brute force, ties to the lowest id.
uint32_t bruteForce(const std::vector<Descriptor>& words, const Descriptor& q, int& dist) {
    dist = std::numeric_limits<int>::max();
    uint32_t id = 0;
    for (uint32_t i = 0; i < words.size(); ++i) {
        int d = 0;
        for (int k = 0; k < 4; ++k) d += __builtin_popcountll(words[i].w[k] ^ q.w[k]);
        if (d < dist) dist = d, id = i;
    }
    return id;
}

} // namespace

TEST(VisionVocabulary, Crc32MatchesTheStandardCheckValue) {
    const char* s = "123456789";
    EXPECT_EQ(crc32({reinterpret_cast<const uint8_t*>(s), 9}), 0xCBF43926u);
}

TEST(VisionVocabulary, HammingDistanceCountsDifferingBits) {
    Rng rng(3);
    const Descriptor a = randomDescriptor(rng);
    EXPECT_EQ(hammingDistance(a, a), 0);
    Descriptor b = a;
    for (int bit : {0, 63, 64, 130, 255}) b.w[bit >> 6] ^= 1ull << (bit & 63);
    EXPECT_EQ(hammingDistance(a, b), 5);
    Descriptor c;
    for (int i = 0; i < 4; ++i) c.w[i] = ~a.w[i];
    EXPECT_EQ(hammingDistance(a, c), 256);
}

TEST(VisionVocabulary, LinearSearchFindsTheNearestWordWithTiesToTheLowestId) {
    const auto words = randomWords(700, 11);
    const Vocabulary v(words);
    Rng rng(12);
    for (int i = 0; i < 500; ++i) {
        const Descriptor q = i % 2 ? randomDescriptor(rng) : flipBits(words[rng.below(700)], 20, rng);
        int want = 0, got = 0;
        const uint32_t id = bruteForce(words, q, want);
        EXPECT_EQ(v.quantize(q, got, Search{SearchMethod::Linear, 0}), id);
        EXPECT_EQ(got, want);
    }
    // A duplicate word: the lower id wins.
    auto dup = words;
    dup[3] = words[5];  // ids 3 and 5 are the same word
    const Vocabulary vd(dup);
    EXPECT_EQ(vd.quantize(words[5], Search{SearchMethod::Linear, 0}), 3u);
    EXPECT_EQ(vd.quantize(words[5], Search{SearchMethod::Tree, 1024}), 3u);
}

TEST(VisionVocabulary, TreeSearchVisitingEveryBucketIsExact) {
    const auto words = randomWords(3000, 21);
    const Vocabulary v(words);
    ASSERT_GT(v.coarseCentres(), 10u);
    Rng rng(22);
    for (int i = 0; i < 400; ++i) {
        const Descriptor q = i % 2 ? randomDescriptor(rng) : flipBits(words[rng.below(3000)], 30, rng);
        int a = 0, b = 0;
        EXPECT_EQ(v.quantize(q, a, Search{SearchMethod::Tree, v.coarseCentres()}),
                  v.quantize(q, b, Search{SearchMethod::Linear, 0}));
        EXPECT_EQ(a, b);
    }
}

// Words that differ in 16 bits only: distances are small and ties common, so
// a bucket whose bound equals the best distance so far may hold an equally
// close word of a lower id: the tree, visiting every bucket, keeps the linear
// search's lowest id.
TEST(VisionVocabulary, TreeSearchVisitingEveryBucketKeepsTiesToTheLowestId) {
    Rng rng(71);
    const Descriptor base = randomDescriptor(rng);
    auto near = [&] {
        Descriptor d = base;
        for (int b = 0; b < 16; ++b)
            if (rng.below(2)) d.w[0] ^= 1ull << b;
        return d;
    };
    std::vector<Descriptor> words(600);
    for (auto& d : words) d = near();
    const Vocabulary v(words);
    ASSERT_GT(v.coarseCentres(), 1u);
    for (int i = 0; i < 2000; ++i) {
        const Descriptor q = near();
        int a = 0, b = 0;
        ASSERT_EQ(v.quantize(q, a, Search{SearchMethod::Tree, v.coarseCentres()}),
                  v.quantize(q, b, Search{SearchMethod::Linear, 0}))
            << "query " << i;
        ASSERT_EQ(a, b);
    }
}

TEST(VisionVocabulary, TreeSearchMapsEveryWordToItselfAndComputesFewerDistances) {
    const auto words = randomWords(5000, 31);
    const Vocabulary v(words);
    for (uint32_t i = 0; i < v.size(); ++i) ASSERT_EQ(v.quantize(words[i], Search{SearchMethod::Tree, 1}), i);
    Rng rng(32);
    uint64_t visited = 0;
    for (int i = 0; i < 200; ++i) visited += v.distancesComputed(randomDescriptor(rng), Search{});
    EXPECT_LT(visited / 200, v.size() / 2) << "the default tree search should skip most words";
}

TEST(VisionVocabulary, QuantizeRowsReadsStridedDescriptorRows) {
    const auto words = randomWords(300, 41);
    const Vocabulary v(words);
    std::vector<uint8_t> rows(5 * 40, 0xEE);  // 40-byte stride, 8 bytes of padding per row
    for (int r = 0; r < 5; ++r) words[static_cast<std::size_t>(r * 7)].toBytes(rows.data() + r * 40);
    uint32_t out[5];
    v.quantizeRows(rows.data(), 40, 5, out, Search{SearchMethod::Linear, 0});
    for (int r = 0; r < 5; ++r) EXPECT_EQ(out[r], static_cast<uint32_t>(r * 7));
}

TEST(VisionVocabulary, SaveAndLoadRoundTripKeepsWordsNoteAndIds) {
    rost::testing::TempDir t;
    const auto words = randomWords(1234, 51);
    const Vocabulary v(words, "trained on nothing\nsecond line");
    ASSERT_TRUE(v.save(t / "v.rostvoc").ok());
    Vocabulary w;
    const Status st = Vocabulary::load(t / "v.rostvoc", w);
    ASSERT_TRUE(st.ok()) << st.message();
    ASSERT_EQ(w.size(), v.size());
    EXPECT_EQ(w.note(), v.note());
    for (uint32_t i = 0; i < v.size(); ++i) ASSERT_EQ(w.word(i), v.word(i));
    Rng rng(52);
    for (int i = 0; i < 100; ++i) {
        const Descriptor q = randomDescriptor(rng);
        EXPECT_EQ(w.quantize(q), v.quantize(q));
    }
    // The file is exactly header + note + words, and no temporary is left behind.
    EXPECT_EQ(std::filesystem::file_size(t / "v.rostvoc"), 32u + v.note().size() + 1234u * 32u);
    for (const auto& e : std::filesystem::directory_iterator(t.path()))  // the temporary: ".v.rostvoc.tmpXXXXXX"
        EXPECT_TRUE(e.path().filename().string().find(".tmp") == std::string::npos) << "left behind: " << e.path();
    // The longest note save() writes (and `rost vocab` cuts a note to) loads back; one byte more is refused.
    const Vocabulary longest(randomWords(3, 53), std::string(Vocabulary::kMaxNoteBytes, 'n'));
    ASSERT_TRUE(longest.save(t / "long.rostvoc").ok());
    Vocabulary back;
    const Status lst = Vocabulary::load(t / "long.rostvoc", back);
    ASSERT_TRUE(lst.ok()) << lst.message();
    EXPECT_EQ(back.note(), longest.note());
    EXPECT_FALSE(Vocabulary(randomWords(3, 53), std::string(Vocabulary::kMaxNoteBytes + 1, 'n')).save(t / "over.rostvoc").ok());
}

class VocabularyFileErrors : public ::testing::Test {
protected:
    void SetUp() override { bytes_ = Vocabulary(randomWords(100, 61), "note").serialize(); }
    std::string loadError(const std::vector<uint8_t>& b) {
        rost::testing::writeText(t_ / "bad.rostvoc", std::string(b.begin(), b.end()));
        Vocabulary v;
        const Status st = Vocabulary::load(t_ / "bad.rostvoc", v);
        EXPECT_FALSE(st.ok());
        EXPECT_NE(st.message().find(t_ / "bad.rostvoc"), std::string::npos) << "names the file: " << st.message();
        EXPECT_EQ(st.message().find('\n'), std::string::npos) << "one line: " << st.message();
        return st.message();
    }
    void put32(std::vector<uint8_t>& b, std::size_t at, uint32_t v) {
        for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (8 * i));
    }
    rost::testing::TempDir t_;
    std::vector<uint8_t> bytes_;
};

TEST_F(VocabularyFileErrors, WrongMagicSaysNotAVocabulary) {
    auto b = bytes_;
    b[0] = 'X';
    EXPECT_NE(loadError(b).find("not a rost vocabulary"), std::string::npos);
    EXPECT_NE(loadError({}).find("not a rost vocabulary"), std::string::npos);
}

TEST_F(VocabularyFileErrors, TruncatedHeaderOrWordsSaysTruncated) {
    EXPECT_NE(loadError({bytes_.begin(), bytes_.begin() + 20}).find("truncated header"), std::string::npos);
    EXPECT_NE(loadError({bytes_.begin(), bytes_.end() - 1}).find("truncated"), std::string::npos);
    EXPECT_NE(loadError({bytes_.begin(), bytes_.begin() + 40}).find("truncated"), std::string::npos);
}

TEST_F(VocabularyFileErrors, OtherVersionIsRefusedWithBothVersionNumbers) {
    auto b = bytes_;
    put32(b, 8, 2);
    const std::string m = loadError(b);
    EXPECT_NE(m.find("version 2"), std::string::npos) << m;
    EXPECT_NE(m.find("version 1"), std::string::npos) << m;
}

TEST_F(VocabularyFileErrors, BadSizesAreNamedWithTheirOffsets) {
    auto b = bytes_;
    put32(b, 16, 64);
    EXPECT_NE(loadError(b).find("descriptor size 64"), std::string::npos);
    b = bytes_;
    put32(b, 12, 0);
    EXPECT_NE(loadError(b).find("word count 0"), std::string::npos);
    b = bytes_;
    put32(b, 20, 1u << 20);
    EXPECT_NE(loadError(b).find("note length"), std::string::npos);
}

TEST_F(VocabularyFileErrors, FlippedBitIsCaughtByTheChecksum) {
    for (std::size_t at : {std::size_t{33}, bytes_.size() / 2, bytes_.size() - 1}) {
        auto b = bytes_;
        b[at] ^= 0x10;
        EXPECT_NE(loadError(b).find("checksum mismatch"), std::string::npos) << "byte " << at;
    }
}

TEST_F(VocabularyFileErrors, TrailingBytesAreRefused) {
    auto b = bytes_;
    b.push_back(0);
    EXPECT_NE(loadError(b).find("unexpected bytes"), std::string::npos);
}

TEST_F(VocabularyFileErrors, MissingFileAndDirectoryAreNamed) {
    Vocabulary v;
    Status st = Vocabulary::load(t_ / "nope.rostvoc", v);
    EXPECT_EQ(st.message(), "vocabulary " + (t_ / "nope.rostvoc") + ": cannot open: No such file or directory");
    EXPECT_EQ(st.kind(), StatusKind::NotFound);
    st = Vocabulary::load(t_.path(), v);
    EXPECT_EQ(st.message(), "vocabulary " + t_.path() + ": is a directory, not a file");
    EXPECT_EQ(st.kind(), StatusKind::IsADirectory);
}

TEST(VisionKMajority, RecoversPlantedClustersDeterministicallyForAnyThreadCount) {
    // 12 planted centres, 60 members each within 12 flipped bits: k-majority
    // with k = 12 must put a learned centre within a few bits of each, and
    // the result must not depend on the thread count.
    Rng rng(71);
    std::vector<Descriptor> centres(12), data;
    for (auto& c : centres) c = randomDescriptor(rng);
    for (int m = 0; m < 60; ++m)
        for (const auto& c : centres) data.push_back(flipBits(c, 1 + static_cast<int>(rng.below(12)), rng));
    KMajorityOptions o;
    o.words = 12;
    o.seed = 5;
    o.max_iterations = 50;
    std::vector<Descriptor> one, two;
    KMajorityReport rep;
    o.threads = 1;
    ASSERT_TRUE(trainKMajority(data, o, one, &rep).ok());
    o.threads = 3;
    ASSERT_TRUE(trainKMajority(data, o, two).ok());
    EXPECT_EQ(one, two);
    EXPECT_EQ(rep.changed_last, 0u) << "converged";
    for (const auto& c : centres) {
        int best = 256;
        for (const auto& l : one) best = std::min(best, hammingDistance(c, l));
        EXPECT_LE(best, 3) << "a planted centre was not recovered";
    }
    EXPECT_LT(rep.mean_distance, 8.0);
    // Another seed still converges to the same structure, through different initial centres.
    o.seed = 6;
    std::vector<Descriptor> three;
    ASSERT_TRUE(trainKMajority(data, o, three).ok());
    for (const auto& c : centres) {
        int best = 256;
        for (const auto& l : three) best = std::min(best, hammingDistance(c, l));
        EXPECT_LE(best, 3);
    }
}

// A tied vote keeps the centre's bit: one centre over a descriptor and its
// complement (every bit one vote against one) stays the descriptor it was
// seeded with, not all ones (a tie setting the bit) nor all zeros.
TEST(VisionKMajority, ATiedVoteKeepsTheCentresBit) {
    Rng rng(17);
    const Descriptor a = randomDescriptor(rng);
    Descriptor b;
    for (int w = 0; w < 4; ++w) b.w[w] = ~a.w[w];
    for (const uint64_t seed : {1u, 2u, 3u}) {
        SCOPED_TRACE(seed);
        KMajorityOptions o;
        o.words = 1;
        o.seed = seed;
        std::vector<Descriptor> c;
        const std::vector<Descriptor> data{a, b};
        ASSERT_TRUE(trainKMajority(data, o, c).ok());
        ASSERT_EQ(c.size(), 1u);
        EXPECT_TRUE(c[0] == a || c[0] == b) << "a tied bit changed: the centre is neither member";
    }
}

TEST(VisionKMajority, RefusesTooFewDescriptorsWithAClearMessage) {
    const auto data = randomWords(10, 81);
    KMajorityOptions o;
    o.words = 20;
    std::vector<Descriptor> c;
    const Status st = trainKMajority(data, o, c);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.message().find("10 descriptors cannot make 20 words"), std::string::npos) << st.message();
    std::vector<Descriptor> same(50, data[0]);
    o.words = 2;
    EXPECT_NE(trainKMajority(same, o, c).message().find("distinct"), std::string::npos);
}
