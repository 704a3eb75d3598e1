// Words and positions files as rost-cli reads them: one document per line,
// `timestamp,w,w,...` and `timestamp,x,y,x,y,...`. Errors name the file, the
// line and the column.

#include <algorithm>
#include <cmath>
#include <iostream>
#include <iterator>
#include <limits>
#include <new>

#include "rost/text_io.hpp"
#include "rostcli.hpp"

namespace rost::cli {

namespace {

using text::Field;
using text::Line;
using text::LineReader;
using text::splitFields;
using text::where;

// Lines as rost-cli reads them: lines of only spaces and tabs are skipped,
// '#' starts no comment (a line is a document whatever its timestamp).
constexpr text::LineRules kLines{.skip_empty = true, .blank_is_empty = true, .skip_comments = false};

// A non-negative integer field below `hi`; `what` names it in the message
// ("expected word id (a non-negative integer), found 'x'", "word id 40 out of range [0, 40)").
Status parseCount(const Field& f, std::string_view name, int line, std::string_view what, int64_t hi, int64_t& v) {
    if (text::toInteger(f.text, v) == text::NumberError::None && v >= 0 && v < hi) return {};
    return text::integerField(name, line, f, std::string(what) + " (a non-negative integer)", what, 0, hi, v);
}

// A coordinate: a non-negative integer, or a number with a fraction
// (rostpy's and spectrograms' positions) placed at floor(value), so positions
// with their fractions cut give the same run.
Status parseCoordinate(const Field& f, std::string_view name, int line, std::string_view what, int64_t hi, int64_t& v) {
    if (text::toInteger(f.text, v) == text::NumberError::None && v >= 0 && v < hi) return {};
    double d = 0.0;
    if (text::toDouble(f.text, d) == text::NumberError::None && d >= 0.0 && d < static_cast<double>(hi)) {
        v = static_cast<int64_t>(std::floor(d));
        return {};
    }
    return text::integerField(name, line, f, std::string(what) + " (a non-negative number)", what, 0, hi, v);
}

// A line that is one field holding spaces or tabs: its fields are separated
// by something other than the delimiter. Refused, naming the file, the line
// and the flag that sets the delimiter (reading it as one timestamp with no
// words would give empty documents and nan perplexities).
Status checkSeparated(const std::vector<Field>& fields, std::string_view line, std::string_view name, int number,
                      std::string_view delim) {
    if (fields.size() != 1 || fields[0].text.find_first_of(" \t") == std::string_view::npos) return {};
    const bool tabs = line.find('\t') != std::string_view::npos;
    std::string msg = where(name, number);
    msg += "no '";
    msg += delim;
    msg += "' between the fields, but ";
    msg += tabs ? "tabs" : "spaces";
    msg += " (--in.words.delim sets the delimiter)";
    return Status::error(msg);
}

// The next document line split at `delim` into `fields`; false at the end.
// `st`: the error when the line's fields are separated by blanks instead.
bool nextRow(LineReader& lines, std::string_view delim, Line& line, std::vector<Field>& fields, Status& st) {
    if (!lines.next(line)) return false;
    splitFields(line.text, delim, fields);
    st = checkSeparated(fields, line.text, lines.name(), line.number, delim);
    return true;
}

} // namespace

bool isStandardInput(const std::string& path) { return path.empty() || path == "-" || path == "/dev/stdin"; }

Status readInput(const std::string& path, std::string& text, std::string& name) {
    if (isStandardInput(path)) {
        name = "<stdin>";
        std::size_t have = 0;
        try {
            text.clear();
            for (;;) {  // the buffer doubles: what was read so far is known when it no longer can
                if (have == text.size()) text.resize(std::max<std::size_t>(text.size() * 2, std::size_t{1} << 16));
                std::cin.read(text.data() + have, static_cast<std::streamsize>(text.size() - have));
                have += static_cast<std::size_t>(std::cin.gcount());
                if (!std::cin) break;
            }
        } catch (const std::bad_alloc&) {
            text = std::string();
            return Status::error(StatusKind::OutOfMemory,
                                 "<stdin>: out of memory reading it whole, after " + std::to_string(have >> 20) + " MiB");
        }
        text.resize(have);
        if (std::cin.bad()) return Status::error("<stdin>: read error");
        return {};
    }
    name = path;
    return rost::text::readFile(path, text);
}

namespace {

// One document from a line split into `fields` (word ids below `hi`).
Status takeDocument(const std::vector<Field>& fields, std::string_view name, int number, int64_t hi, Document& d) {
    if (fields[0].text.empty()) return Status::error(where(name, number, fields[0].column) + "empty timestamp");
    // A byte-order mark after the file's start (`cat` of two files that each begin with one) is
    // no part of a time stamp: refused in its line, as the tool's readers refuse it.
    if (fields[0].text.starts_with("\xEF\xBB\xBF"))
        return Status::error(where(name, number, fields[0].column) + "a byte-order mark before the timestamp '" +
                             text::printable(fields[0].text.substr(3), 32) + "' (two files joined?)");
    d.timestamp = std::string(fields[0].text);
    d.line = number;
    d.words.clear();
    d.words.reserve(fields.size() - 1);
    for (std::size_t i = 1; i < fields.size(); ++i) {
        int64_t w = 0;
        if (Status st = parseCount(fields[i], name, number, "word id", hi, w); !st.ok()) return st;
        d.words.push_back(static_cast<uint32_t>(w));
    }
    return {};
}

// V given, or else the most the schema allows: a word id beyond it is an
// error naming its line and column, not a V out of range naming none.
int64_t wordLimit(uint32_t V) { return V == 0 ? settingSpec("V").hi : int64_t{V}; }

} // namespace

Status parseDocuments(std::string_view text, std::string_view name, std::string_view delim, uint32_t V,
                      Corpus& out) {
    out.docs.clear();
    out.words_name = std::string(name);
    const int64_t hi = wordLimit(V);
    std::vector<Field> fields;
    LineReader lines(text::withoutByteOrderMark(text), name, kLines);
    Line line;
    for (Status separated; nextRow(lines, delim, line, fields, separated);) {
        if (!separated.ok()) return separated;
        Document d;
        if (Status st = takeDocument(fields, name, line.number, hi, d); !st.ok()) return st;
        for (uint32_t w : d.words) out.max_word = std::max(out.max_word, w);
        out.any_word = out.any_word || !d.words.empty();
        out.longest = std::max(out.longest, d.words.size());
        out.docs.push_back(std::move(d));
    }
    // Nothing to model is an error, not empty outputs with nan perplexities.
    if (out.docs.empty()) return Status::error(std::string(name) + ": no documents (the input is empty or blank)");
    if (!out.any_word)
        return Status::error(std::string(name) + ": no words in its " + std::to_string(out.docs.size()) +
                             " documents (each line is timestamp" + std::string(delim) + "word" + std::string(delim) +
                             "word...)");
    return {};
}

Status parseDocumentLine(std::string_view text, int number, std::string_view name, std::string_view delim, uint32_t V,
                         Document& d, bool& got) {
    got = false;
    std::vector<Field> fields;
    LineReader lines(number == 1 ? text::withoutByteOrderMark(text) : text, name, kLines);  // the stream's start
    Line line;
    Status separated;
    if (!nextRow(lines, delim, line, fields, separated)) return {};  // a blank line
    if (!separated.ok()) return Status::error(where(name, number) + separated.message().substr(where(name, 1).size()));
    if (Status st = takeDocument(fields, name, number, wordLimit(V), d); !st.ok()) return st;
    got = true;
    return {};
}

// A per-document side file (positions, initial topics): a line a document,
// in order, with its words line's timestamp and `perWord` fields a word
// (`noun`: what they are, `expect`: what a line must hold, for messages).
// `take` reads a line's fields into its document.
template <typename Take>
Status readSideFile(std::string_view text, std::string_view name, std::string_view delim, const char* what,
                    std::size_t perWord, const char* noun, const char* expect, Corpus& corpus, Take take) {
    std::vector<Field> fields;
    std::size_t index = 0;
    LineReader lines(text::withoutByteOrderMark(text), name, kLines);
    Line line;
    for (Status separated; nextRow(lines, delim, line, fields, separated);) {
        if (!separated.ok()) return separated;
        const int number = line.number;
        if (index >= corpus.docs.size())
            return Status::error(where(name, number, 1) + "a " + what + " line beyond the " +
                                 std::to_string(corpus.docs.size()) + " documents of " + corpus.words_name);
        Document& d = corpus.docs[index++];
        if (fields[0].text != d.timestamp)
            return Status::error(where(name, number, fields[0].column) + "timestamp '" + std::string(fields[0].text) +
                                 "' differs from " + corpus.words_name + ":" + std::to_string(d.line) + "'s '" +
                                 d.timestamp + "'");
        const std::size_t n = fields.size() - 1, want = perWord * d.words.size();
        if (n != want) {
            const std::size_t col = n > want ? fields[1 + want].column : line.text.size() + 1;
            std::string msg = where(name, number, col) + std::to_string(n) + " " + noun + " for the " +
                              std::to_string(d.words.size()) + " words of " + corpus.words_name + ":" +
                              std::to_string(d.line);
            if (*expect) msg += std::string(" (expected ") + expect + ": " + std::to_string(want) + ")";
            return Status::error(msg);
        }
        if (Status st = take(fields, number, d); !st.ok()) return st;
    }
    if (index != corpus.docs.size())
        return Status::error(where(name, lines.lines() + 1, 1) + std::to_string(index) + " " + what +
                             " lines for the " + std::to_string(corpus.docs.size()) + " documents of " +
                             corpus.words_name);
    return {};
}

Status parseInitialTopics(std::string_view text, std::string_view name, std::string_view delim, int K, Corpus& corpus) {
    return readSideFile(text, name, delim, "topics", 1, "labels", "", corpus,
                        [&](const std::vector<Field>& fields, int number, Document& d) -> Status {
                            d.labels.resize(d.words.size());
                            for (std::size_t w = 0; w < d.words.size(); ++w) {
                                int64_t z = 0;
                                if (Status st = text::integerField(name, number, fields[1 + w], "a topic label",
                                                                   "topic label", 0, K, z);
                                    !st.ok())
                                    return st;
                                d.labels[w] = static_cast<uint16_t>(z);
                            }
                            return {};
                        });
}

Status parsePositions(std::string_view text, std::string_view name, std::string_view delim, Corpus& corpus) {
    // The frame the positions make is at most the schema's (a position beyond
    // it is an error naming its line and column).
    const int64_t hiX = settingSpec("frame.width").hi, hiY = settingSpec("frame.height").hi;
    return readSideFile(text, name, delim, "position", 2, "coordinates", "x,y per word", corpus,
                        [&](const std::vector<Field>& fields, int number, Document& d) -> Status {
                            d.positions.resize(d.words.size());
                            for (std::size_t i = 0; i < d.words.size(); ++i) {
                                int64_t x = 0, y = 0;
                                if (Status st = parseCoordinate(fields[1 + 2 * i], name, number, "x", hiX, x); !st.ok())
                                    return st;
                                if (Status st = parseCoordinate(fields[2 + 2 * i], name, number, "y", hiY, y); !st.ok())
                                    return st;
                                d.positions[i] = {static_cast<int32_t>(x), static_cast<int32_t>(y)};
                                corpus.max_x = std::max(corpus.max_x, static_cast<int32_t>(x));
                                corpus.max_y = std::max(corpus.max_y, static_cast<int32_t>(y));
                            }
                            return {};
                        });
}

} // namespace rost::cli
