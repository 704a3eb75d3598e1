#include "rost/word_stream.hpp"

#include "file_bytes.hpp"

#include <algorithm>
#include <atomic>
#include <functional>
#include <iterator>
#include <latch>
#include <limits>
#include <new>
#include <span>
#include <system_error>
#include <thread>
#include <sys/stat.h>

namespace rost {
namespace {

// The frame a position must lie in, as a position error names it: "frame
// 640x480"; "largest frame a model can hold, 65536x65536" when nothing set
// it; "frame 640 wide and at most 65536 high" when one side was set;
// "frame (x in [0, 640))" when only one side is checked.
std::string frameText(const WordStreamLimits& limits) {
    const std::string w = std::to_string(limits.width), h = std::to_string(limits.height);
    if (limits.width > 0 && limits.height > 0) {
        if (limits.width_largest && limits.height_largest) return "largest frame a model can hold, " + w + "x" + h;
        if (limits.width_largest) return "frame " + h + " high and at most " + w + " wide";
        if (limits.height_largest) return "frame " + w + " wide and at most " + h + " high";
        return "frame " + w + "x" + h;
    }
    if (limits.width > 0) return "frame (x in [0, " + w + "))";
    if (limits.height > 0) return "frame (y in [0, " + h + "))";
    return "frame";
}

using text::Field;
using text::Line;
using text::LineReader;

// Empty lines, lines of only spaces and tabs, and '#' lines are skipped (as
// rost-cli's commands and Python's rost.io skip them).
constexpr text::LineRules kStreamLines{.skip_empty = true, .blank_is_empty = true, .skip_comments = true};
using text::where;

// The common line, as the extractors and appendCsvLine write it: numbers of
// at most 18 digits (below 2^63) joined by single commas, nothing else.
// Fills `values` and returns true; false for any other line (spaces, a sign,
// an empty field, a trailing comma, a longer number), which the general
// path reads and, where it is wrong, words the error of. One pass, no field
// list: the general path's splitting and from_chars took most of the
// parsing of the diver stream (bench/RESULTS.md, "Item 1, twelfth session").
bool plainIntegers(std::string_view text, std::vector<int64_t>& values) {
    values.clear();
    const char* p = text.data();
    const char* const end = p + text.size();
    for (;;) {
        const char* const first = p;
        uint64_t v = 0;
        while (p != end && static_cast<unsigned>(*p - '0') < 10) v = v * 10 + static_cast<unsigned>(*p++ - '0');
        const auto digits = static_cast<std::size_t>(p - first);
        if (digits == 0 || digits > 18) return false;
        values.push_back(static_cast<int64_t>(v));
        if (p == end) return true;
        if (*p != ',' || ++p == end) return false;
    }
}

// Splits a line at commas and parses each field as a signed 64-bit integer.
// A plain line (plainIntegers) leaves `fields` empty: fieldsOf() makes them
// when an error needs a column.
Status parseFields(const Line& line, std::string_view name, std::vector<Field>& fields, std::vector<int64_t>& values) {
    fields.clear();
    if (plainIntegers(line.text, values)) return {};
    text::splitFields(line.text, ",", fields);
    values.clear();
    for (const Field& f : fields) {
        if (f.text.empty()) return Status::error(where(name, line.number, f.start) + "empty field");
        int64_t v = 0;
        if (Status st = text::integerField(name, line.number, f, "an integer", v); !st.ok()) return st;
        values.push_back(v);
    }
    return {};
}

// The fields of a line parseFields read (each value's column, for an error).
const std::vector<Field>& fieldsOf(const Line& line, std::vector<Field>& fields) {
    if (fields.empty()) text::splitFields(line.text, ",", fields);
    return fields;
}

} // namespace

namespace {

// The words file's pass: one observation per data line, positions empty.
Status parseWords(std::string_view wordsText, const WordStreamLimits& limits, WordStream& out,
                  std::string_view wordsName) {
    std::vector<int64_t> values;
    std::vector<Field> fields;
    LineReader lines(text::withoutByteOrderMark(wordsText), {}, kStreamLines);
    Line line;
    while (lines.next(line)) {
        const int number = line.number;
        Status st = parseFields(line, wordsName, fields, values);
        if (!st.ok()) return st;
        if (values.size() - 1 > limits.max_words)
            return Status::error(where(wordsName, number, 1) + std::to_string(values.size() - 1) +
                                 " words in one observation, at most " + std::to_string(limits.max_words));
        StreamObservation obs;
        obs.timestamp = values[0];
        obs.words.reserve(values.size() - 1);
        for (std::size_t i = 1; i < values.size(); ++i) {
            const int64_t w = values[i];
            if (w < 0 || w > std::numeric_limits<uint32_t>::max() ||
                (limits.vocabulary != 0 && w >= static_cast<int64_t>(limits.vocabulary)))
                return Status::error(where(wordsName, number, fieldsOf(line, fields)[i].column) + "word id " + std::to_string(w) +
                                     " out of range [0, " +
                                     (limits.vocabulary ? std::to_string(limits.vocabulary) : std::string("2^32")) +
                                     ")");
            obs.words.push_back(static_cast<uint32_t>(w));
        }
        out.observations.push_back(std::move(obs));
    }
    return {};
}

// The positions file's pass over the observations parseWords made: the
// checks every line gets, in order; the first that fails is the error.
Status parsePositions(std::string_view positionsText, const WordStreamLimits& limits, WordStream& out,
                      std::string_view positionsName, std::string_view wordsName) {
    std::vector<int64_t> values;
    std::vector<Field> fields;
    LineReader plines(text::withoutByteOrderMark(positionsText), {}, kStreamLines);
    Line line;
    std::size_t index = 0;
    while (plines.next(line)) {
        const int number = line.number;
        Status st = parseFields(line, positionsName, fields, values);
        if (!st.ok()) return st;
        if (index >= out.observations.size())
            return Status::error(where(positionsName, number, 1) + "more observations than " + std::string(wordsName) +
                                 " has (" + std::to_string(out.observations.size()) + ")");
        StreamObservation& obs = out.observations[index];
        if (values[0] != obs.timestamp)
            return Status::error(where(positionsName, number, 1) + "timestamp " + std::to_string(values[0]) +
                                 " differs from " + std::string(wordsName) + "'s " + std::to_string(obs.timestamp) +
                                 " for observation " + std::to_string(index + 1));
        if (values.size() - 1 != 2 * obs.words.size())
            return Status::error(where(positionsName, number, 1) +
                                 text::counted(static_cast<long long>(values.size() - 1), "coordinate") + " for " +
                                 text::counted(static_cast<long long>(obs.words.size()), "word") + " (expected " +
                                 std::to_string(2 * obs.words.size()) + ")");
        obs.positions.resize(obs.words.size());
        for (std::size_t i = 0; i < obs.words.size(); ++i) {
            const int64_t x = values[1 + 2 * i], y = values[2 + 2 * i];
            const bool badX = x < 0 || x > std::numeric_limits<int32_t>::max() || (limits.width > 0 && x >= limits.width);
            const bool badY = y < 0 || y > std::numeric_limits<int32_t>::max() || (limits.height > 0 && y >= limits.height);
            if (badX || badY) {
                // The column of the coordinate the message is about: a negative one first.
                const bool atX = x < 0 || (y >= 0 && badX);
                const std::size_t col = fieldsOf(line, fields)[atX ? 1 + 2 * i : 2 + 2 * i].column;
                std::string msg = where(positionsName, number, col);
                msg += "position (";
                msg += std::to_string(x);
                msg += ", ";
                msg += std::to_string(y);
                if (x < 0 || y < 0) {
                    msg += ") has a negative coordinate: positions are pixels from the frame's top-left corner, 0 or more";
                } else {
                    msg += ") outside the ";
                    msg += frameText(limits);
                }
                return Status::error(msg);
            }
            obs.positions[i] = {static_cast<int32_t>(x), static_cast<int32_t>(y)};
        }
        ++index;
    }
    if (index != out.observations.size())
        return Status::error(std::string(positionsName) + ": " + text::counted(static_cast<long long>(index), "observation") + ", but " +
                             std::string(wordsName) + " has " + std::to_string(out.observations.size()));
    return {};
}

// A positions line parsed apart from the words (on another thread): its
// time stamp and coordinates, checked later against its observation.
struct PositionsLine {
    int64_t timestamp = 0;
    std::vector<Position> xy;
};

// Parses every positions line without the checks that need the words;
// false at the first line parseFields rejects, with an odd count, or with a
// coordinate outside int32 (the serial pass then finds and words the error).
bool parsePositionLines(std::string_view text, std::vector<PositionsLine>& out) {
    std::vector<int64_t> values;
    std::vector<Field> fields;
    LineReader lines(text, {}, kStreamLines);
    Line line;
    while (lines.next(line)) {
        if (!parseFields(line, "", fields, values).ok() || values.size() % 2 != 1) return false;
        PositionsLine& p = out.emplace_back();
        p.timestamp = values[0];
        p.xy.resize(values.size() / 2);
        for (std::size_t i = 0; i < p.xy.size(); ++i) {
            const int64_t x = values[1 + 2 * i], y = values[2 + 2 * i];
            if (x < 0 || y < 0 || x > std::numeric_limits<int32_t>::max() || y > std::numeric_limits<int32_t>::max())
                return false;
            p.xy[i] = {static_cast<int32_t>(x), static_cast<int32_t>(y)};
        }
    }
    return true;
}

// Gives each observation its parsed positions when every check of
// parsePositions passes; false (nothing given) otherwise.
bool attachPositions(std::vector<PositionsLine>& lines, const WordStreamLimits& limits, WordStream& out) {
    if (lines.size() != out.observations.size()) return false;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const StreamObservation& obs = out.observations[i];
        if (lines[i].timestamp != obs.timestamp || lines[i].xy.size() != obs.words.size()) return false;
        for (const Position& p : lines[i].xy)
            if ((limits.width > 0 && p.x >= limits.width) || (limits.height > 0 && p.y >= limits.height)) return false;
    }
    for (std::size_t i = 0; i < lines.size(); ++i) out.observations[i].positions = std::move(lines[i].xy);
    return true;
}

} // namespace

Status parseWordStream(std::string_view wordsText, std::string_view positionsText, const WordStreamLimits& limits,
                       WordStream& out, std::string_view wordsName, std::string_view positionsName) {
    out.observations.clear();
    out.has_positions = !positionsText.empty();
    if (Status st = parseWords(wordsText, limits, out, wordsName); !st.ok()) return st;
    if (!out.has_positions) {
        for (auto& obs : out.observations) obs.positions.assign(obs.words.size(), Position{0, 0});
        return {};
    }
    return parsePositions(positionsText, limits, out, positionsName, wordsName);
}

namespace {

// The positions text cut at line ends into pieces that the two threads
// claim: this thread from the front once it has parsed the words, the
// other from the back once it has read the file. Which thread parses a
// piece changes nothing in the result, and neither waits for the other
// while a piece is left (a fixed cut left one thread idle whenever the
// other was slower: a longer file to read, a core the host took away).
constexpr std::size_t kPositionPieces = 32;

struct PositionPieces {
    std::size_t begin[kPositionPieces + 1] = {};  // piece i is text[begin[i], begin[i + 1])
    std::vector<PositionsLine> lines[kPositionPieces];
    bool ok[kPositionPieces] = {};
    // front (low 32 bits): the next piece from the front; back: one past
    // the next piece from the back. A piece is claimed once, by a CAS.
    std::atomic<uint64_t> ends{0};

    void cut(std::string_view text) {
        begin[0] = 0;
        for (std::size_t i = 1; i < kPositionPieces; ++i) {
            const std::size_t at = std::max(begin[i - 1], text.size() * i / kPositionPieces);
            const std::size_t nl = at == 0 ? 0 : text.find('\n', at - 1);
            begin[i] = nl == std::string_view::npos ? text.size() : (at == 0 ? 0 : nl + 1);
        }
        begin[kPositionPieces] = text.size();
        ends.store(uint64_t{kPositionPieces} << 32, std::memory_order_release);
    }
    // No piece left to claim (after cut(): an error found elsewhere makes the pieces useless).
    void abandon() noexcept { ends.store(0, std::memory_order_release); }
    // Parses pieces from the front (or the back) until none is left.
    // Exceptions (out of memory) propagate; the other thread parses the
    // pieces not yet claimed (the result is then not used).
    void parse(std::string_view text, bool fromFront) {
        uint64_t e = ends.load(std::memory_order_acquire);
        for (;;) {
            const auto front = static_cast<uint32_t>(e), back = static_cast<uint32_t>(e >> 32);
            if (front >= back) return;
            const uint64_t claimed = fromFront ? e + 1 : e - (uint64_t{1} << 32);
            if (!ends.compare_exchange_weak(e, claimed, std::memory_order_acq_rel, std::memory_order_acquire)) continue;
            const std::size_t i = fromFront ? front : back - 1;
            ok[i] = parsePositionLines(text.substr(begin[i], begin[i + 1] - begin[i]), lines[i]);
            e = ends.load(std::memory_order_acquire);
        }
    }
};

// The positions file read, and pieces of it parsed from the back, on a thread of its own.
struct PositionsTail {
    const std::string* path = nullptr;
    Status read;
    text::FileBytes text;
    PositionPieces pieces;
    std::latch readDone{1};  // `read`, `text` and the pieces' bounds are set
    bool readFailed = false;  // an exception while reading (out of memory): before readDone
    bool parseFailed = false;  // an exception while parsing: read after the join

    void operator()() noexcept {
        try {
            read = readFile(*path, text);
            if (read.ok()) pieces.cut(text::withoutByteOrderMark(text.view()));
        } catch (...) {
            readFailed = true;
        }
        readDone.count_down();
        if (readFailed || !read.ok()) return;
        try {
            pieces.parse(text::withoutByteOrderMark(text.view()), false);
        } catch (...) {
            parseFailed = true;
        }
    }
};

// Both paths name regular files: a pipe or a device is read by one thread,
// in order, as before (two readers of one pipe would share its bytes).
bool regularFiles(const std::string& a, const std::string& b) {
    struct stat sa {}, sb {};
    return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && S_ISREG(sa.st_mode) && S_ISREG(sb.st_mode);
}

// A failed read of `file`, told to the caller when it asked (`unread`).
Status unreadFile(Status st, WordStreamFile file, WordStreamFile* unread) {
    if (unread != nullptr) *unread = file;
    return st;
}

Status readSerially(const std::string& wordsPath, const std::string& positionsPath, const WordStreamLimits& limits,
                    WordStream& out, WordStreamFile* unread) {
    text::FileBytes words, positions;
    Status st = readFile(wordsPath, words);
    if (!st.ok()) return unreadFile(st, WordStreamFile::Words, unread);
    if (!positionsPath.empty()) {
        st = readFile(positionsPath, positions);
        if (!st.ok()) return unreadFile(st, WordStreamFile::Positions, unread);
        if (positions.view().find_first_not_of(" \t\r\n") == std::string_view::npos && !words.empty())
            return Status::error(positionsPath + ": empty, but " + wordsPath + " is not");
    }
    return parseWordStream(words.view(), positions.view(), limits, out, wordsPath, positionsPath);
}

} // namespace

Status readWordStream(const std::string& wordsPath, const std::string& positionsPath,
                      const WordStreamLimits& limits, WordStream& out, WordStreamFile* unread) {
    if (unread != nullptr) *unread = WordStreamFile::None;
    if (positionsPath.empty() || limits.threads < 2 || !regularFiles(wordsPath, positionsPath))
        return readSerially(wordsPath, positionsPath, limits, out, unread);
    // Two threads: beside this one the positions file is read; here the
    // words file is read and its words parsed; then both parse pieces of the
    // positions until none is left (PositionPieces). The result and the
    // first error are the serial path's: positions that do not fit the
    // words as parsed go through the serial pass, which names the first
    // error exactly.
    PositionsTail tail;
    tail.path = &positionsPath;
    std::jthread thread;  // joined on every way out
    try {
        thread = std::jthread(std::ref(tail));
    } catch (const std::system_error&) {  // no thread to be had
        return readSerially(wordsPath, positionsPath, limits, out, unread);
    }
    text::FileBytes words;
    Status st = readFile(wordsPath, words);
    if (!st.ok()) return unreadFile(st, WordStreamFile::Words, unread);
    // Parsed before the positions are known, aside: `out` and the errors are
    // then as the serial path leaves and reports them (its read and
    // emptiness errors before the words' error, `out` untouched by them).
    WordStream parsed;
    const Status wordsParsed = parseWords(words.view(), limits, parsed, wordsPath);
    tail.readDone.wait();
    if (tail.readFailed) throw std::bad_alloc();
    if (!tail.read.ok()) return unreadFile(tail.read, WordStreamFile::Positions, unread);
    const std::string_view text = text::withoutByteOrderMark(tail.text.view());
    if (text.find_first_not_of(" \t\r\n") == std::string::npos && !words.empty()) {
        tail.pieces.abandon();
        return Status::error(positionsPath + ": empty, but " + wordsPath + " is not");
    }
    out.observations = std::move(parsed.observations);
    out.has_positions = !text.empty();
    if (!wordsParsed.ok()) {
        tail.pieces.abandon();
        return wordsParsed;
    }
    tail.pieces.parse(text, true);
    thread.join();
    if (tail.parseFailed) throw std::bad_alloc();
    if (!out.has_positions) return {};  // both files empty: no observations
    if (std::all_of(std::begin(tail.pieces.ok), std::end(tail.pieces.ok), [](bool ok) { return ok; })) {
        std::vector<PositionsLine> lines;
        std::size_t n = 0;
        for (const auto& piece : tail.pieces.lines) n += piece.size();
        lines.reserve(n);
        for (auto& piece : tail.pieces.lines) std::move(piece.begin(), piece.end(), std::back_inserter(lines));
        if (attachPositions(lines, limits, out)) return {};
    }
    return parsePositions(text, limits, out, positionsPath, wordsPath);
}

void appendCsvLine(std::string& out, int64_t timestamp, const uint32_t* values, std::size_t n) {
    text::appendRow(out, timestamp, std::span<const uint32_t>(values, n));
}
void appendCsvLine(std::string& out, int64_t timestamp, const uint16_t* values, std::size_t n) {
    text::appendRow(out, timestamp, std::span<const uint16_t>(values, n));
}
void appendPositionsLine(std::string& out, int64_t timestamp, const Position* p, std::size_t n) {
    text::appendInteger(out, timestamp);
    for (std::size_t i = 0; i < n; ++i) {
        out.push_back(',');
        text::appendInteger(out, p[i].x);
        out.push_back(',');
        text::appendInteger(out, p[i].y);
    }
    out.push_back('\n');
}

} // namespace rost
