// Words and positions files as rost-cli reads them: one document per line,
// `timestamp,w,w,...` and `timestamp,x,y,x,y,...`. Errors name the file, the
// line and the column.

#include <charconv>
#include <iostream>
#include <iterator>
#include <limits>

#include "rost/word_stream.hpp"
#include "rostcli.hpp"

namespace rost::cli {

namespace {

std::string where(std::string_view name, int line, std::size_t column) {
    std::string s(name);
    s += ':';
    s += std::to_string(line);
    s += ':';
    s += std::to_string(column);
    s += ": ";
    return s;
}

// One field of a line: its text (spaces and tabs trimmed) and 1-based column.
struct Field {
    std::string_view text;
    std::size_t column = 1;
};

// Splits a line at `delim`. A trailing delimiter after the last field is
// tolerated (some writers end every line with one).
void splitLine(std::string_view line, std::string_view delim, std::vector<Field>& out) {
    out.clear();
    std::size_t pos = 0;
    while (true) {
        std::size_t end = delim.empty() ? std::string_view::npos : line.find(delim, pos);
        if (end == std::string_view::npos) end = line.size();
        std::string_view f = line.substr(pos, end - pos);
        std::size_t lead = 0;
        while (lead < f.size() && (f[lead] == ' ' || f[lead] == '\t')) ++lead;
        std::size_t trail = f.size();
        while (trail > lead && (f[trail - 1] == ' ' || f[trail - 1] == '\t')) --trail;
        const bool last = end == line.size();
        if (!(last && trail == lead && !out.empty() && pos > 0)) out.push_back({f.substr(lead, trail - lead), pos + lead + 1});
        if (last) break;
        pos = end + delim.size();
    }
}

// The next non-blank line (a trailing '\r' removed); false at the end.
bool nextLine(std::string_view text, std::size_t& pos, int& number, std::string_view& line) {
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        line = text.substr(pos, end - pos);
        pos = end + 1;
        ++number;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.find_first_not_of(" \t") != std::string_view::npos) return true;
    }
    return false;
}

// A non-negative integer field; `what` names it in the message.
Status parseCount(const Field& f, std::string_view name, int line, const char* what, int64_t hi, int64_t& v) {
    const char* b = f.text.data();
    const char* e = b + f.text.size();
    const auto [ptr, ec] = std::from_chars(b, e, v);
    if (f.text.empty() || ec == std::errc::invalid_argument || ptr != e) {
        std::string msg = where(name, line, f.column);
        msg += "expected ";
        msg += what;
        msg += " (a non-negative integer), found '";
        msg += f.text.substr(0, 32);
        msg += "'";
        return Status::error(msg);
    }
    if (ec == std::errc::result_out_of_range || v < 0 || v >= hi) {
        std::string msg = where(name, line, f.column);
        msg += what;
        msg += ' ';
        msg += f.text.substr(0, 32);
        msg += " out of range [0, ";
        msg += std::to_string(hi);
        msg += ')';
        return Status::error(msg);
    }
    return {};
}

// A line that is one field holding spaces or tabs: its fields are separated
// by something other than the delimiter. Refused, naming the file, the line
// and the flag that sets the delimiter (reading it as one timestamp with no
// words would give empty documents and nan perplexities).
Status checkSeparated(const std::vector<Field>& fields, std::string_view line, std::string_view name, int number,
                      std::string_view delim) {
    if (fields.size() != 1 || fields[0].text.find_first_of(" \t") == std::string_view::npos) return {};
    const bool tabs = line.find('\t') != std::string_view::npos;
    std::string msg(name);
    msg += ':' + std::to_string(number) + ": no '" + std::string(delim) + "' between the fields, but " +
           (tabs ? "tabs" : "spaces") + " (--in.words.delim sets the delimiter)";
    return Status::error(msg);
}

} // namespace

Status readInput(const std::string& path, std::string& text, std::string& name) {
    if (path.empty() || path == "-" || path == "/dev/stdin") {
        name = "<stdin>";
        text.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
        if (std::cin.bad()) return Status::error("<stdin>: read error");
        return {};
    }
    name = path;
    return readFile(path, text);
}

Status parseDocuments(std::string_view text, std::string_view name, std::string_view delim, uint32_t V,
                      Corpus& out) {
    out.docs.clear();
    out.words_name = std::string(name);
    const int64_t hi = V == 0 ? int64_t{std::numeric_limits<uint32_t>::max()} : int64_t{V};
    std::vector<Field> fields;
    std::size_t pos = 0;
    int number = 0;
    std::string_view line;
    while (nextLine(text, pos, number, line)) {
        splitLine(line, delim, fields);
        if (Status st = checkSeparated(fields, line, name, number, delim); !st.ok()) return st;
        if (fields[0].text.empty()) return Status::error(where(name, number, fields[0].column) + "empty timestamp");
        Document d;
        d.timestamp = std::string(fields[0].text);
        d.line = number;
        d.words.reserve(fields.size() - 1);
        for (std::size_t i = 1; i < fields.size(); ++i) {
            int64_t w = 0;
            if (Status st = parseCount(fields[i], name, number, "word id", hi, w); !st.ok()) return st;
            d.words.push_back(static_cast<uint32_t>(w));
            out.max_word = std::max(out.max_word, static_cast<uint32_t>(w));
            out.any_word = true;
        }
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

Status parsePositions(std::string_view text, std::string_view name, std::string_view delim, Corpus& corpus) {
    std::vector<Field> fields;
    std::size_t pos = 0, index = 0;
    int number = 0;
    std::string_view line;
    const int64_t hi = std::numeric_limits<int32_t>::max();
    while (nextLine(text, pos, number, line)) {
        splitLine(line, delim, fields);
        if (Status st = checkSeparated(fields, line, name, number, delim); !st.ok()) return st;
        if (index >= corpus.docs.size())
            return Status::error(where(name, number, 1) + "a position line beyond the " +
                                 std::to_string(corpus.docs.size()) + " documents of " + corpus.words_name);
        Document& d = corpus.docs[index++];
        if (fields[0].text != d.timestamp)
            return Status::error(where(name, number, fields[0].column) + "timestamp '" + std::string(fields[0].text) +
                                 "' differs from " + corpus.words_name + ":" + std::to_string(d.line) + "'s '" +
                                 d.timestamp + "'");
        const std::size_t coords = fields.size() - 1;
        if (coords != 2 * d.words.size()) {
            const std::size_t col = coords > 2 * d.words.size() ? fields[1 + 2 * d.words.size()].column : line.size() + 1;
            return Status::error(where(name, number, col) + std::to_string(coords) + " coordinates for the " +
                                 std::to_string(d.words.size()) + " words of " + corpus.words_name + ":" +
                                 std::to_string(d.line) + " (expected x,y per word: " +
                                 std::to_string(2 * d.words.size()) + ")");
        }
        d.positions.resize(d.words.size());
        for (std::size_t i = 0; i < d.words.size(); ++i) {
            int64_t x = 0, y = 0;
            if (Status st = parseCount(fields[1 + 2 * i], name, number, "x", hi, x); !st.ok()) return st;
            if (Status st = parseCount(fields[2 + 2 * i], name, number, "y", hi, y); !st.ok()) return st;
            d.positions[i] = {static_cast<int32_t>(x), static_cast<int32_t>(y)};
            corpus.max_x = std::max(corpus.max_x, static_cast<int32_t>(x));
            corpus.max_y = std::max(corpus.max_y, static_cast<int32_t>(y));
        }
    }
    if (index != corpus.docs.size())
        return Status::error(where(name, number + 1, 1) + std::to_string(index) + " position lines for the " +
                             std::to_string(corpus.docs.size()) + " documents of " + corpus.words_name);
    return {};
}

} // namespace rost::cli
