#pragma once

// Word streams on disk in the formats earlier ROST tools used, so their users
// can bring data across:
//   words.csv      timestamp,w1,w2,...   one observation per line
//   positions.csv  timestamp,x1,y1,x2,y2,...   the same observations, same order
//   topics.csv     timestamp,z1,z2,...
// Blank lines and lines starting with '#' are skipped. A line with only a
// timestamp is an observation with no words. Set-up code: allocates.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rost/model.hpp"
#include "rost/status.hpp"

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

// Reads the files (positionsPath may be empty) and parses them.
Status readWordStream(const std::string& wordsPath, const std::string& positionsPath,
                      const WordStreamLimits& limits, WordStream& out);

// Reads a whole file; the error names the path and the system's reason
// ("PATH: is a directory, not a file").
Status readFile(const std::string& path, std::string& out);

// Checks, before any work, that writeFileAtomic(path, ...) can succeed: the
// path is not a directory, and its directory exists and takes a new file
// (one is created there and removed). The error names the path and why, so
// a command refuses an unwritable output at once instead of after its work.
Status probeOutputFile(const std::string& path);

// Writes `content` to `path` atomically: a temporary file in the same
// directory, flushed and fsync'ed, then renamed over `path`. A crash leaves
// either the old file or the new one, never a torn one.
Status writeFileAtomic(const std::string& path, std::string_view content);

// Appends one "timestamp,v1,v2,..." line.
void appendCsvLine(std::string& out, int64_t timestamp, const uint32_t* values, std::size_t n);
void appendCsvLine(std::string& out, int64_t timestamp, const uint16_t* values, std::size_t n);
void appendPositionsLine(std::string& out, int64_t timestamp, const Position* p, std::size_t n);

} // namespace rost
