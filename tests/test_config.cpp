#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "rost/config.hpp"
#include "rost/model.hpp"

namespace {

TEST(Config, DefaultsAreValid) { EXPECT_TRUE(rost::Config{}.validate().ok()); }

struct BadField {
    const char* field;
    void (*mutate)(rost::Config&);
    const char* range;
};

TEST(Config, InvalidValueNamesFieldAndRange) {
    const BadField cases[] = {
        {"K", [](rost::Config& c) { c.K = 0; }, "[1, 1024]"},
        {"V", [](rost::Config& c) { c.V = -3; }, "[1, 16777216]"},
        {"alpha", [](rost::Config& c) { c.alpha = 0.0; }, "(0, "},
        {"beta", [](rost::Config& c) { c.beta = -1.0; }, "[1e-30, "},
        {"cell.space", [](rost::Config& c) { c.cell_space = 0; }, "[1, 65536]"},
        {"cell.time", [](rost::Config& c) { c.cell_time = 0; }, "[1, 1024]"},
        {"g.space", [](rost::Config& c) { c.g_space = -1; }, "[0, 16]"},
        {"g.time", [](rost::Config& c) { c.g_time = 99; }, "[0, 64]"},
        {"ring.steps", [](rost::Config& c) { c.ring_steps = 0; }, "[1, 67108864]"},
        {"cell.capacity", [](rost::Config& c) { c.cell_capacity = 0; }, "[1, 1048576]"},
    };
    for (const auto& bad : cases) {
        rost::Config c;
        bad.mutate(c);
        const rost::Status s = c.validate();
        ASSERT_FALSE(s.ok()) << bad.field;
        EXPECT_NE(s.message().find(std::string(bad.field) + " ="), std::string::npos) << s.message();
        EXPECT_NE(s.message().find(bad.range), std::string::npos) << s.message();
    }
}

// A ring too large for memory is refused naming every setting its size comes
// from, each as "key = value" (so a Python caller sees its own keyword): by
// its cells' words, by their topic counts (many topics in small cells that
// hold few words), or by the two and the observations together (each part
// within the bound alone); each setting within its range alone.
TEST(Config, ARingTooLargeNamesEverySettingItsSizeComesFrom) {
    struct Case {
        int K, capacity, steps, fits;
        std::vector<const char*> said;
    };
    for (const Case& k : {Case{16, 4096, 4096, 6, {"ring.steps = 4096", "frame.width = ", "frame.height = ", "cell.space = 1",
                                                     "cell.capacity = 4096", "64 GiB"}},
                          Case{1024, 1, 2048, 54, {"ring.steps = 2048", "at most 54 for 307200 cells a step", "K = 1024",
                                                    "cell.space = 1", "the cells' topic counts would need more than 64 GiB"}},
                          Case{16, 8, 3000, 1745, {"ring.steps = 3000", "at most 1745", "cell.capacity = 8", "K = 16",
                                                   "cell.time = 1", "max.words = 4096", "together", "64 GiB"}}}) {
        rost::Config c;
        c.cell_space = 1;  // 640 x 480 cells a step
        c.K = k.K;
        c.cell_capacity = k.capacity;
        c.ring_steps = k.steps;
        const rost::Status s = c.validate();
        ASSERT_FALSE(s.ok()) << "K " << k.K;
        for (const char* key : k.said) EXPECT_NE(s.message().find(key), std::string::npos) << key << " in: " << s.message();
        c.ring_steps = k.fits;
        EXPECT_TRUE(c.validate().ok()) << c.validate().message();
    }
}

// The temporal neighbourhood must fit in the ring, strictly: g.time =
// ring.steps - 1 is the largest taken; ring.steps itself would reach the
// slot being written. A ring of one step has no temporal neighbours: it
// takes g.time's default of 1 and no more.
TEST(Config, TheTemporalNeighbourhoodFitsInTheRingAtItsEdge) {
    rost::Config c;
    c.ring_steps = 4;
    c.g_time = 3;
    EXPECT_TRUE(c.validate().ok()) << c.validate().message();
    c.g_time = 4;
    EXPECT_EQ(c.validate().message(), "invalid configuration: g.time = 4, allowed [0, 3]; below ring.steps = 4");
    c.ring_steps = 1;
    c.g_time = 1;
    EXPECT_TRUE(c.validate().ok()) << c.validate().message();
    // More than the default in a ring of one step: refused as in a ring of two.
    c.g_time = 5;
    EXPECT_EQ(c.validate().message(),
              "invalid configuration: g.time = 5, allowed [0, 1]; a ring of ring.steps = 1 has no temporal neighbours");
    c.ring_steps = 2;
    EXPECT_EQ(c.validate().message(), "invalid configuration: g.time = 5, allowed [0, 1]; below ring.steps = 2");
}

// What the tables' sizes come from, each setting by its key (the engine's
// out-of-memory message): a frame that is not square, so its sides are told apart.
TEST(Config, TablesTextNamesEachSizeByItsSetting) {
    rost::Config c;
    c.K = 8;
    c.V = 100;
    c.ring_steps = 16;
    c.frame_width = 640;
    c.frame_height = 480;
    c.cell_space = 32;  // 20 x 15 cells
    c.cell_capacity = 64;
    c.max_words_per_frame = 500;
    c.threads = 1;
    EXPECT_EQ(c.tablesText(), "K = 8, V = 100, ring.steps = 16, 300 cells a step (frame 640x480, cell.space = 32), "
                              "cell.capacity = 64, max.words = 500");
}

// A frame that is not a whole number of cells wide or high: the cells cut
// at its right and bottom edges count too (321 x 241 cells of 2 pixels for
// 641 x 481), in the ring's bound and in the message.
TEST(Config, ARingsSizeCountsTheCellsCutAtTheFramesEdges) {
    rost::Config c;
    c.frame_width = 641;
    c.frame_height = 481;
    c.cell_space = 2;
    c.cell_capacity = 4096;
    c.ring_steps = 28;
    const rost::Status s = c.validate();
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("ring.steps = 28, allowed at most 27 for 77361 cells a step (frame.width = 641 by "
                               "frame.height = 481 in cells of cell.space = 2)"),
              std::string::npos)
        << s.message();
    c.ring_steps = 27;
    EXPECT_TRUE(c.validate().ok()) << c.validate().message();
}

TEST(Config, NanAlphaRejected) {
    rost::Config c;
    c.alpha = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(c.validate().ok());
}

TEST(Config, ModelConstructorThrowsAndFactoryReports) {
    rost::Config c;
    c.K = 5000;
    EXPECT_THROW(rost::Model m(c), std::invalid_argument);
    rost::Status st;
    EXPECT_EQ(rost::Model::create(c, st), nullptr);
    EXPECT_NE(st.message().find("K = 5000"), std::string::npos);
}

} // namespace
