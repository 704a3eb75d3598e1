#pragma once

// Word streams on disk in the formats earlier ROST tools used, so their users
// can bring data across:
//   words.csv      timestamp,w1,w2,...   one observation per line
//   positions.csv  timestamp,x1,y1,x2,y2,...   the same observations, same order
//   topics.csv     timestamp,z1,z2,...
// Empty lines, lines of only spaces and tabs, and lines starting with '#'
// are skipped (as rost-cli's commands and Python's rost.io skip them). A line with only a timestamp is an observation with no
// words. Set-up code: allocates.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rost/model.hpp"
#include "rost/status.hpp"
#include "rost/text_io.hpp"

namespace rost {

struct StreamObservation {
    int64_t timestamp = 0;
    std::vector<uint32_t> words;
    std::vector<Position> positions;
};

struct WordStream {
    std::vector<StreamObservation> observations;
    bool has_positions = false;
};

struct WordStreamLimits {
    uint32_t vocabulary = 0;        // V: word ids must be < V (0: no check)
    int32_t width = 0, height = 0;  // positions must lie in [0, width) x [0, height) (0: no check)
    // The side is the largest the schema allows, not one the user or a
    // checkpoint set (the data decide the frame within it): errors say so.
    bool width_largest = false, height_largest = false;
    uint32_t max_words = 1u << 22;  // per observation
    // readWordStream: with 2 or more, a second thread parses part of the
    // positions file while this one parses the words (same result, same errors).
    int threads = 1;
};

// Parses words (and, when `positionsText` is non-empty, positions) from text.
// Errors name the file, line and column: "words.csv:12:7: word id 6000 out of
// range [0, 5436)". `wordsName`/`positionsName` are used in messages.
Status parseWordStream(std::string_view wordsText, std::string_view positionsText, const WordStreamLimits& limits,
                       WordStream& out, std::string_view wordsName = "words.csv",
                       std::string_view positionsName = "positions.csv");

// Which file a failed readWordStream could not read (open, read, or hold in
// memory), so that a caller can name it by the option that gave it; None
// when both were read (a parse error names its own file, line and column).
enum class WordStreamFile : uint8_t { None, Words, Positions };

// Reads the files (positionsPath may be empty) and parses them. `unread`,
// when given, says which file could not be read.
Status readWordStream(const std::string& wordsPath, const std::string& positionsPath,
                      const WordStreamLimits& limits, WordStream& out, WordStreamFile* unread = nullptr);

// The file functions moved to the text I/O layer (rost/text_io.hpp); named
// here too for the callers that know them from this header.
using text::probeOutputFile;
using text::readFile;
using text::writeFileAtomic;

// Appends one "timestamp,v1,v2,..." line (text::appendRow).
void appendCsvLine(std::string& out, int64_t timestamp, const uint32_t* values, std::size_t n);
void appendCsvLine(std::string& out, int64_t timestamp, const uint16_t* values, std::size_t n);
void appendPositionsLine(std::string& out, int64_t timestamp, const Position* p, std::size_t n);

} // namespace rost
