#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

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
    // A line of only spaces and tabs is blank, as rost-cli's commands and rost.io read it.
    const std::string words = "# comment\n10,1,2,3\n\n \t \n11\r\n12,99,\n";
    const std::string pos = "10,0,0,1,1,639,479\n  \n11\n12,5,6\n";
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
    EXPECT_EQ(parseError("1,2\n", "1,700,-3\n"),
              "positions.csv:1:7: position (700, -3) has a negative coordinate: positions are pixels from the frame's top-left corner, 0 or more");
    EXPECT_EQ(parseError("1,2\n", "1,0,-5\n"), "positions.csv:1:5: position (0, -5) has a negative coordinate: positions are pixels from the frame's top-left corner, 0 or more");
    EXPECT_EQ(parseError("1,2\n", "1,640,0\n"), "positions.csv:1:3: position (640, 0) outside the frame 640x480");
    // One side of the frame given (the other from the data): only it is named.
    rost::WordStream ws;
    rost::WordStreamLimits wide = limits();
    wide.height = 0;
    wide.width = 100;
    EXPECT_EQ(rost::parseWordStream("1,2\n", "1,150,3\n", wide, ws).message(),
              "positions.csv:1:3: position (150, 3) outside the frame (x in [0, 100))");
    // The other side given and this one the largest a model can hold: each named by its own size.
    rost::WordStreamLimits tall = limits();
    tall.width = 65536;
    tall.width_largest = true;
    EXPECT_EQ(rost::parseWordStream("1,2\n", "1,70000,3\n", tall, ws).message(),
              "positions.csv:1:3: position (70000, 3) outside the frame 480 high and at most 65536 wide");
    rost::WordStreamLimits wider = limits();
    wider.height = 65536;
    wider.height_largest = true;
    EXPECT_EQ(rost::parseWordStream("1,2\n", "1,3,70000\n", wider, ws).message(),
              "positions.csv:1:5: position (3, 70000) outside the frame 640 wide and at most 65536 high");
    EXPECT_EQ(parseError("1,2\n", "2,0,0\n"), "positions.csv:1:1: timestamp 2 differs from words.csv's 1 for observation 1");
    EXPECT_EQ(parseError("1,2\n", "1,0\n"), "positions.csv:1:1: 1 coordinate for 1 word (expected 2)");
    EXPECT_EQ(parseError("1,2\n2,3\n", "1,0,0\n"), "positions.csv: 1 observation, but words.csv has 2");
}

// Plain lines (digits and single commas, as the extractors write them) take
// a fast path; every other spelling the general one. Both give the same
// values, and an error on a plain line still names its column.
TEST(WordStreamCsv, PlainLinesAndOtherSpellingsParseAlike) {
    rost::WordStream plain, spelled;
    ASSERT_TRUE(rost::parseWordStream("5,1,2,3\n123456789012345678,7\n", "5,0,0,1,1,2,2\n123456789012345678,9,8\n",
                                      limits(), plain)
                    .ok());
    ASSERT_TRUE(rost::parseWordStream(" 5 , 1,\t2 ,003,\n0123456789012345678,7\n", "5,0, 0,1,1,2,02\n123456789012345678,9,8,\n",
                                      limits(), spelled)
                    .ok());
    ASSERT_EQ(plain.observations.size(), 2u);
    ASSERT_EQ(spelled.observations.size(), 2u);
    for (std::size_t o = 0; o < 2; ++o) {
        EXPECT_EQ(plain.observations[o].timestamp, spelled.observations[o].timestamp);
        EXPECT_EQ(plain.observations[o].words, spelled.observations[o].words);
        ASSERT_EQ(plain.observations[o].positions.size(), spelled.observations[o].positions.size());
        for (std::size_t k = 0; k < plain.observations[o].positions.size(); ++k) {
            EXPECT_EQ(plain.observations[o].positions[k].x, spelled.observations[o].positions[k].x);
            EXPECT_EQ(plain.observations[o].positions[k].y, spelled.observations[o].positions[k].y);
        }
    }
    EXPECT_EQ(plain.observations[1].timestamp, 123456789012345678);
    EXPECT_EQ(plain.observations[0].words, (std::vector<uint32_t>{1, 2, 3}));
    EXPECT_EQ(plain.observations[0].positions[2].y, 2);
    // 19 digits: past the fast path, whether int64 holds them or not.
    EXPECT_EQ(parseError("1234567890123456789,1\n"), "ok");
    EXPECT_EQ(parseError("1,9999999999999999999\n"), "words.csv:1:3: number '9999999999999999999' out of range");
    // Errors on plain lines: the field's column.
    EXPECT_EQ(parseError("7,1,2,3,4,5,100\n"), "words.csv:1:13: word id 100 out of range [0, 100)");
    // A spelled line before a plain one: the plain line's columns are its own, not the line before's.
    EXPECT_EQ(parseError("1, 2, 3\n2,4,100\n"), "words.csv:2:5: word id 100 out of range [0, 100)");
    EXPECT_EQ(parseError("1,2\n2,3\n", "1, 0, 0\n2,640,0\n"), "positions.csv:2:3: position (640, 0) outside the frame 640x480");
    EXPECT_EQ(parseError("1,2,3\n", "1,0,0,5,480\n"), "positions.csv:1:9: position (5, 480) outside the frame 640x480");
}

TEST(WordStreamCsv, EnormousObservationIsRejected) {
    rost::WordStreamLimits l = limits();
    l.max_words = 3;
    rost::WordStream s;
    const rost::Status st = rost::parseWordStream("7,1,2,3,4\n", {}, l, s);
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.message(), "words.csv:1:1: 4 words in one observation, at most 3");
    // Exactly max.words is an observation like any other, on the serial and the two-thread path.
    for (int threads : {1, 2}) {
        l.threads = threads;
        ASSERT_TRUE(rost::parseWordStream("7,1,2,3\n8,4\n", "7,0,0,1,1,2,2\n8,3,3\n", l, s).ok()) << threads;
        ASSERT_EQ(s.observations.size(), 2u);
        EXPECT_EQ(s.observations[0].words, (std::vector<uint32_t>{1, 2, 3}));
        EXPECT_EQ(rost::parseWordStream("7,1,2\n8,4,5,6,7\n", "", l, s).message(),
                  "words.csv:2:1: 4 words in one observation, at most 3");
    }
}

TEST(WordStreamCsv, MissingFileNamesThePath) {
    rost::WordStream s;
    const rost::Status st = rost::readWordStream("/nonexistent/words.csv", "", limits(), s);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.message().find("/nonexistent/words.csv: cannot open"), std::string::npos) << st.message();
    // Two threads: the words file's error first, as on one.
    rost::WordStreamLimits two = limits();
    two.threads = 2;
    const rost::Status both = rost::readWordStream("/nonexistent/words.csv", "/nonexistent/positions.csv", two, s);
    EXPECT_NE(both.message().find("/nonexistent/words.csv: cannot open"), std::string::npos) << both.message();
}

// `unread` says which file could not be read, on one thread and on two, so
// that a face names it by its option; a bad line of a file read is None.
TEST(WordStreamCsv, AFailedReadSaysWhichFileItWas) {
    const auto dir = std::filesystem::temp_directory_path() / ("rost_word_stream_unread_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string wp = (dir / "w.csv").string(), bad = (dir / "bad.csv").string();
    const std::string missing = (dir / "nope.csv").string(), pp = (dir / "p.csv").string();
    ASSERT_TRUE(rost::writeFileAtomic(wp, "1,2,3\n").ok());
    ASSERT_TRUE(rost::writeFileAtomic(pp, "1,0,0,1,1\n").ok());
    ASSERT_TRUE(rost::writeFileAtomic(bad, "1,0,0,x,1\n").ok());
    for (const int threads : {1, 2}) {
        rost::WordStreamLimits l = limits();
        l.threads = threads;
        struct Case {
            std::string words, positions;
            rost::WordStreamFile unread;
        };
        const Case cases[] = {{missing, pp, rost::WordStreamFile::Words},
                              {wp, missing, rost::WordStreamFile::Positions},
                              {wp, dir.string(), rost::WordStreamFile::Positions},  // a directory
                              {wp, bad, rost::WordStreamFile::None},                // read, then refused
                              {wp, pp, rost::WordStreamFile::None}};
        for (const Case& c : cases) {
            rost::WordStream s;
            auto unread = rost::WordStreamFile::Words;  // overwritten on every call
            const rost::Status st = rost::readWordStream(c.words, c.positions, l, s, &unread);
            EXPECT_EQ(unread, c.unread) << threads << " threads: " << c.words << " " << c.positions << ": " << st.message();
            EXPECT_EQ(st.ok(), c.words == wp && c.positions == pp) << st.message();
        }
    }
    std::filesystem::remove_all(dir);
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

// Reads files of `words` and `positions` (an empty `positions` string is a
// missing --positions) with `threads`; "ok" or the error, and the stream.
std::string readWith(int threads, const std::string& words, const std::string& positions, rost::WordStream& s) {
    const auto dir = std::filesystem::temp_directory_path() / ("rost_word_stream_threads_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string wp = (dir / "w.csv").string(), pp = (dir / "p.csv").string();
    EXPECT_TRUE(rost::writeFileAtomic(wp, words).ok());
    EXPECT_TRUE(rost::writeFileAtomic(pp, positions).ok());
    rost::WordStreamLimits l = limits();
    l.threads = threads;
    const rost::Status st = rost::readWordStream(wp, positions == "<missing>" ? dir.string() + "/nope.csv" : pp, l, s);
    std::filesystem::remove_all(dir);
    return st.ok() ? std::string("ok") : st.message();
}

// `text` with the first `from` replaced by `to`.
std::string wrongAt(std::string text, const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

// Pieces of the positions file parsed on both threads (the words first here,
// the positions' read there): the serial result, and the serial pass's first
// error, for valid files and for each kind of error, wherever it lies.
TEST(WordStreamCsv, TwoThreadsGiveTheSerialStreamAndErrors) {
    std::string bigWords, bigPositions;
    uint64_t x = 12345;
    for (int t = 0; t < 300; ++t) {
        std::vector<uint32_t> w;
        std::vector<rost::Position> p;
        for (int i = 0; i < t % 37; ++i) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            w.push_back(static_cast<uint32_t>(x >> 33) % 100);
            p.push_back({static_cast<int32_t>((x >> 20) % 640), static_cast<int32_t>((x >> 40) % 480)});
        }
        rost::appendCsvLine(bigWords, t, w.data(), w.size());
        rost::appendPositionsLine(bigPositions, t, p.data(), p.size());
    }
    const std::pair<std::string, std::string> cases[] = {
        {bigWords, bigPositions},
        {"# c\n10,1,2,3\n\n11\r\n12,99,\n", "10,0,0,1,1,639,479\n11\n12,5,6\n"},
        {"1,2\n", "1,0,-5\n"},
        {"1,2\n", "1,640,0\n"},
        {"1,2\n", "1,0,480\n"},
        {"1,2\n", "2,0,0\n"},
        {"1,2\n", "1,0\n"},
        {"1,2\n", "1,0,0,1,1\n"},
        {"1,2\n2,3\n", "1,0,0\n"},
        {"1,2\n", "1,0,0\n2,0,0\n"},
        {"1,2\n", "1,x,0\n"},
        {"1,2\n", "1,99999999999,0\n"},
        {"1,2\n", "1,,0\n"},
        {"1,2\n", " \n"},
        {"1,2\n", "<missing>"},
        {"1,200\n", "1,x\n"},  // both wrong: the words' error first
        {"1,x\n", " \n"},      // the words wrong, the positions empty: the positions' error first
        {"1,x\n", "<missing>"},  // the words wrong, the positions missing: the positions' error first
        {bigWords + "300,1\n", bigPositions + "300,3,4\n"},
        {bigWords, bigPositions + "300,3,4\n"},
        {bigWords, "# head\n\n" + bigPositions},
        {bigWords, wrongAt(bigPositions, "\n20,", "\n21,")},    // in an early piece
        {bigWords, wrongAt(bigPositions, "\n250,", "\n251,")},  // in a late piece
        {bigWords, wrongAt(bigPositions, "\n260,", "\n260,700,")},
        {"", ""},
        {"", " \n"},
        {"# only a comment\n", ""},
        {"# only a comment\n", "# and here\n"},
    };
    int i = 0;
    for (const auto& [words, positions] : cases) {
        rost::WordStream serial, parallel;
        const std::string a = readWith(1, words, positions, serial);
        const std::string b = readWith(2, words, positions, parallel);
        EXPECT_EQ(a, b) << "case " << i;
        // What is left in the stream is the serial path's too, after an error as after success.
        EXPECT_EQ(serial.has_positions, parallel.has_positions) << "case " << i;
        ASSERT_EQ(serial.observations.size(), parallel.observations.size()) << "case " << i;
        if (a == "ok" && b == "ok") {
            for (std::size_t o = 0; o < serial.observations.size(); ++o) {
                EXPECT_EQ(serial.observations[o].timestamp, parallel.observations[o].timestamp);
                EXPECT_EQ(serial.observations[o].words, parallel.observations[o].words);
                const auto& ps = serial.observations[o].positions;
                const auto& pp = parallel.observations[o].positions;
                ASSERT_EQ(ps.size(), pp.size());
                for (std::size_t k = 0; k < ps.size(); ++k) EXPECT_TRUE(ps[k].x == pp[k].x && ps[k].y == pp[k].y);
            }
        }
        ++i;
    }
    rost::WordStream s;
    EXPECT_EQ(readWith(2, bigWords, bigPositions, s), "ok");
    EXPECT_EQ(s.observations.size(), 300u);
}

// A positions "file" that is not a regular file (here /dev/null, empty,
// beside non-empty words) asked for on two threads gives the serial error.
// (It does not show which path read it: both would give this message.)
TEST(WordStreamCsv, ADeviceAsPositionsOnTwoThreadsGivesTheSerialError) {
    const auto dir = std::filesystem::temp_directory_path() / ("rost_word_stream_pipe_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string wp = (dir / "w.csv").string();
    ASSERT_TRUE(rost::writeFileAtomic(wp, "1,2\n").ok());
    rost::WordStreamLimits l = limits();
    l.threads = 2;
    rost::WordStream s;
    const rost::Status st = rost::readWordStream(wp, "/dev/null", l, s);
    std::filesystem::remove_all(dir);
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.message(), "/dev/null: empty, but " + wp + " is not");
}

} // namespace

// A directory is not a file to read (fopen opens it, and reading it failed
// with std::length_error), nor a file to write over.
TEST(TextFiles, ADirectoryIsNamedWhereAFileIsExpected) {
    const std::string dir = std::filesystem::temp_directory_path() / ("rost-probe-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir + "/taken");
    std::string text;
    EXPECT_EQ(rost::readFile(dir, text).message(), dir + ": is a directory, not a file");
    EXPECT_EQ(rost::probeOutputFile(dir + "/taken").message(), dir + "/taken: is a directory, not a file that can be written");
    EXPECT_EQ(rost::probeOutputFile("/nonexistent-rost/x.csv").message(),
              "/nonexistent-rost/x.csv: cannot write in /nonexistent-rost: No such file or directory");
    // A writable path: probed without a trace, and writeFileAtomic then succeeds there.
    EXPECT_TRUE(rost::probeOutputFile(dir + "/out.csv").ok());
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 1)
        << "only 'taken': the probe leaves nothing";
    EXPECT_TRUE(rost::writeFileAtomic(dir + "/out.csv", "1,2\n").ok());
    std::filesystem::remove_all(dir);
}
