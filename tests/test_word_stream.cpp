#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "rost/word_stream.hpp"

namespace {

rost::WordStreamLimits limits() {
    rost::WordStreamLimits l;
    l.vocabulary = 100;
    l.width = 640;
    l.height = 480;
    return l;
}

std::string parseError(std::string_view words, std::string_view positions = {}) {
    rost::WordStream s;
    const rost::Status st = rost::parseWordStream(words, positions, limits(), s);
    return st.ok() ? std::string("ok") : st.message();
}

TEST(WordStreamCsv, ParsesWordsAndPositionsInTheEarlierToolsFormat) {
    rost::WordStream s;
    const std::string words = "# comment\n10,1,2,3\n\n11\r\n12,99,\n";
    const std::string pos = "10,0,0,1,1,639,479\n11\n12,5,6\n";
    ASSERT_TRUE(rost::parseWordStream(words, pos, limits(), s).ok());
    ASSERT_EQ(s.observations.size(), 3u);
    EXPECT_EQ(s.observations[0].timestamp, 10);
    EXPECT_EQ(s.observations[0].words, (std::vector<uint32_t>{1, 2, 3}));
    EXPECT_EQ(s.observations[0].positions[2].x, 639);
    EXPECT_EQ(s.observations[0].positions[2].y, 479);
    EXPECT_TRUE(s.observations[1].words.empty());
    EXPECT_EQ(s.observations[2].words, (std::vector<uint32_t>{99}));
}

TEST(WordStreamCsv, ErrorsNameFileLineAndColumn) {
    EXPECT_EQ(parseError("1,2,3\n2,4,100\n"), "words.csv:2:5: word id 100 out of range [0, 100)");
    EXPECT_EQ(parseError("1,2,x3\n"), "words.csv:1:5: expected an integer, found 'x3'");
    EXPECT_EQ(parseError("1,2,,3\n"), "words.csv:1:5: empty field");
    EXPECT_EQ(parseError("1,-4\n"), "words.csv:1:3: word id -4 out of range [0, 100)");
    EXPECT_EQ(parseError("1,99999999999999999999\n"), "words.csv:1:3: number '99999999999999999999' out of range");
    EXPECT_EQ(parseError("1,2\n", "1,0,-5\n"), "positions.csv:1:5: position (0, -5) outside the frame 640x480");
    EXPECT_EQ(parseError("1,2\n", "1,640,0\n"), "positions.csv:1:3: position (640, 0) outside the frame 640x480");
    EXPECT_EQ(parseError("1,2\n", "2,0,0\n"), "positions.csv:1:1: timestamp 2 differs from words.csv's 1 for observation 1");
    EXPECT_EQ(parseError("1,2\n", "1,0\n"), "positions.csv:1:1: 1 coordinates for 1 words (expected 2)");
    EXPECT_EQ(parseError("1,2\n2,3\n", "1,0,0\n"), "positions.csv: 1 observations, but words.csv has 2");
}

TEST(WordStreamCsv, EnormousObservationIsRejected) {
    rost::WordStreamLimits l = limits();
    l.max_words = 3;
    rost::WordStream s;
    const rost::Status st = rost::parseWordStream("7,1,2,3,4\n", {}, l, s);
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.message(), "words.csv:1:1: 4 words in one observation, at most 3");
}

TEST(WordStreamCsv, MissingFileNamesThePath) {
    rost::WordStream s;
    const rost::Status st = rost::readWordStream("/nonexistent/words.csv", "", limits(), s);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.message().find("/nonexistent/words.csv: cannot open"), std::string::npos) << st.message();
}

TEST(WordStreamCsv, WriterOutputParsesBackAndAtomicWriteReplaces) {
    std::string words, pos;
    const uint32_t w[] = {4, 5, 6};
    const rost::Position p[] = {{1, 2}, {3, 4}, {5, 6}};
    rost::appendCsvLine(words, 42, w, 3);
    rost::appendPositionsLine(pos, 42, p, 3);
    EXPECT_EQ(words, "42,4,5,6\n");
    EXPECT_EQ(pos, "42,1,2,3,4,5,6\n");
    const auto dir = std::filesystem::temp_directory_path() / "rost_word_stream_test";
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "words.csv").string();
    ASSERT_TRUE(rost::writeFileAtomic(path, "old\n").ok());
    ASSERT_TRUE(rost::writeFileAtomic(path, words).ok());
    std::string back;
    ASSERT_TRUE(rost::readFile(path, back).ok());
    EXPECT_EQ(back, words);
    // No temporary file is left behind.
    int files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file() ? 1 : 0;
    EXPECT_EQ(files, 1);
    // A failed write (missing directory) reports the path.
    const rost::Status st = rost::writeFileAtomic((dir / "missing" / "x.csv").string(), "x");
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.message().find("missing/x.csv"), std::string::npos) << st.message();
    std::filesystem::remove_all(dir);
}

} // namespace
