#pragma once

// The one text I/O layer of the project: every text file rost reads or
// writes goes through it (word streams, topic models, rost-cli's input,
// configuration files and checkpoints' config section, the tool's tables,
// and Python's rost.io through the binding).
//
//   reading   LineReader (lines of a text, 1-based numbers), splitFields
//             (fields with 1-based columns), number parsing of a field whose
//             errors read "NAME:LINE:COL: expected ..., found '...'"
//   writing   appendInteger / appendNumber, appendRow ("timestamp,v1,v2,...")
//             and TableWriter (a header line, then rows of cells)
//   files     readFile, probeOutputFile, writeFileAtomic
//
// Each format keeps its own rules on top (which lines are skipped, what a
// value may be, how a range error is worded); the layer holds the mechanics
// so that a line number, a column or a number's text is the same everywhere.
// Set-up code: these functions may allocate (strings, vectors); none is
// meant for a realtime loop.

#include <charconv>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rost/file_target.hpp"

#include "rost/status.hpp"

namespace rost::text {

// ---- places in messages ---------------------------------------------------------

// "NAME:LINE:COL: ", the prefix of an error about a field or a character.
std::string where(std::string_view name, int line, std::size_t column);
// "NAME:LINE: ", the prefix of an error about a whole line.
std::string where(std::string_view name, int line);
// "1 cell", "0 cells", "12 cells": a count and its noun, plural unless one.
std::string counted(long long n, std::string_view noun);

// ---- lines ----------------------------------------------------------------------

// A text file's content without the UTF-8 byte order mark some editors and
// spreadsheets write before the first line: it belongs to no line. Each
// reader of a whole file takes it off its start only (one in the middle of a
// file, as `cat` of two such files leaves, stays an error in its line).
constexpr std::string_view withoutByteOrderMark(std::string_view text) noexcept {
    return text.starts_with("\xEF\xBB\xBF") ? text.substr(3) : text;
}

// Which lines a LineReader passes over (each format says which it skips).
struct LineRules {
    bool skip_empty = true;     // a line with nothing on it (once the trailing '\r' is gone)
    bool blank_is_empty = false;  // with skip_empty: a line of only spaces and tabs is skipped too
    bool skip_comments = true;  // a line whose first character is '#'
};

// Rules that skip nothing: every line is given, empty ones and '#' ones too
// (for formats that say themselves what a blank line or a comment is).
inline constexpr LineRules kEveryLine{.skip_empty = false, .blank_is_empty = false, .skip_comments = false};

// One line of a text: its characters (no '\n', no trailing '\r') and its
// 1-based number in the text (skipped lines counted).
struct Line {
    std::string_view text;
    int number = 0;
};

// The lines of a text held elsewhere (a string_view: the text must outlive
// the reader), split at '\n'; a trailing '\r' is stripped from each. A last
// line without '\n' is a line; the empty piece after a final '\n' is not.
class LineReader {
public:
    explicit LineReader(std::string_view text, std::string_view name = {}, LineRules rules = {}) noexcept
        : text_(text), name_(name), rules_(rules) {}

    // The next line the rules do not skip; false at the end of the text.
    bool next(Line& line) noexcept;
    // The number of the last line read, skipped ones included (0 before the
    // first): at the end, the text's line count.
    int lines() const noexcept { return number_; }
    // The name given for messages ("words.csv", "<stdin>").
    std::string_view name() const noexcept { return name_; }
    // "NAME:LINE:COL: " and "NAME:LINE: " with this reader's name.
    std::string at(int line, std::size_t column) const { return where(name_, line, column); }
    std::string at(int line) const { return where(name_, line); }

private:
    std::string_view text_, name_;
    LineRules rules_;
    std::size_t pos_ = 0;
    int number_ = 0;
};

// ---- fields ---------------------------------------------------------------------

// One field of a line: its text with the spaces and tabs around it trimmed,
// the 1-based column of that text's first character (for a field of only
// blanks: the column after them), and the 1-based column where the field
// starts (its leading blanks included).
struct Field {
    std::string_view text;
    std::size_t column = 1;
    std::size_t start = 1;
};

// Splits `line` at each `separator` (an empty separator: the line is one
// field) into `out` (cleared first). One separator after the last field is
// tolerated: the empty field after it is left out (some writers end every
// line with one), unless it is the only field. Allocates only when `out`
// grows.
void splitFields(std::string_view line, std::string_view separator, std::vector<Field>& out);

// ---- numbers --------------------------------------------------------------------

// How a field's text failed to be a number.
enum class NumberError : uint8_t {
    None,       // parsed
    Syntax,     // not a number of the kind asked for (empty, or characters left over)
    Overflow,   // a number, but it does not fit the type
};

// The whole of `text` as a base-10 integer ('-' allowed for the signed one,
// no '+', no blanks). Never allocates.
NumberError toInteger(std::string_view text, int64_t& out) noexcept;
NumberError toUnsigned(std::string_view text, uint64_t& out) noexcept;
// The whole of `text` as a double (decimal or exponent form, "nan", "inf",
// "-inf"): what appendNumber writes reads back to the same value. A text
// beyond double's range reads as an infinity, one below its smallest value
// as a subnormal or zero (as strtod and Python's float() read them).
NumberError toDouble(std::string_view text, double& out) noexcept;

// Text as an error quotes it: at most `cut` bytes (cut between two
// characters), control bytes and bytes of no UTF-8 character written \xNN,
// the C1 controls (U+0080..U+009F) \u0080..\u009f, a byte-order mark \ufeff:
// a message that a terminal and Python show as it is. Each face prints its
// errors and notes through it (uncut), so a file name with a newline or an
// escape in it is one line on stderr and cannot drive the terminal.
std::string printable(std::string_view text, std::size_t cut = std::string_view::npos);

// "NAME:LINE:COL: expected WHAT, found 'TEXT'" at the field's column, the
// field's text cut after `cut` characters (printable).
Status expected(std::string_view name, int line, const Field& f, std::string_view what, std::size_t cut = 32);

// A field as an integer of any size that fits int64. Errors:
//   "NAME:LINE:COL: expected WHAT, found 'TEXT'"   (not an integer)
//   "NAME:LINE:COL: number 'TEXT' out of range"    (beyond int64)
Status integerField(std::string_view name, int line, const Field& f, std::string_view what, int64_t& out);

// A field as an integer in [lo, hi). Errors:
//   "NAME:LINE:COL: expected WHAT, found 'TEXT'"      (not an integer)
//   "NAME:LINE:COL: NOUN TEXT out of range [LO, HI)"  (outside, or beyond int64)
// with TEXT cut after 32 characters.
Status integerField(std::string_view name, int line, const Field& f, std::string_view what, std::string_view noun,
                    int64_t lo, int64_t hi, int64_t& out);

// A field as a double (toDouble). Error: "NAME:LINE:COL: expected WHAT, found 'TEXT'".
Status doubleField(std::string_view name, int line, const Field& f, std::string_view what, double& out);

// ---- writing --------------------------------------------------------------------

// Appends an integer in decimal (std::to_chars: no allocation beyond `out`).
template <std::integral T>
void appendInteger(std::string& out, T v) {
    char buf[24];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, static_cast<std::size_t>(r.ptr - buf));
}

// Appends the shortest decimal text that reads back to exactly `v`
// (std::to_chars), "nan" for every NaN, "inf" and "-inf" for infinities.
void appendNumber(std::string& out, double v);
void appendNumber(std::string& out, float v);

// Appends one row "timestamp,v1,v2,...\n" (just "timestamp\n" with no values).
template <std::integral T>
void appendRow(std::string& out, int64_t timestamp, std::span<const T> values) {
    appendInteger(out, timestamp);
    for (const T v : values) {
        out.push_back(',');
        appendInteger(out, v);
    }
    out.push_back('\n');
}

// A table as text: cells separated by ',' and rows ended by '\n', written
// into a string the caller owns. Integers and numbers are written as
// appendInteger and appendNumber write them.
//   std::string s;
//   TableWriter t(s);
//   t.header({"frame", "surprise"});
//   t.cell(frame).cell(surprise).end();
class TableWriter {
public:
    explicit TableWriter(std::string& out) noexcept : out_(out) {}
    // One row of names: "a,b,c\n".
    TableWriter& header(std::initializer_list<std::string_view> names);
    template <std::integral T>
    TableWriter& cell(T v) {
        separate();
        appendInteger(out_, v);
        return *this;
    }
    TableWriter& cell(double v);
    TableWriter& cell(float v);
    TableWriter& cell(std::string_view v);
    TableWriter& cell(const char* v) { return cell(std::string_view(v)); }
    // Ends the row ('\n').
    TableWriter& end();

private:
    void separate() {
        if (open_) out_.push_back(',');
        open_ = true;
    }
    std::string& out_;
    bool open_ = false;  // a cell is on the current row
};

// ---- files ----------------------------------------------------------------------

// Reads a whole file into `out`; the error names the path and the system's
// reason ("PATH: cannot open: No such file or directory", "PATH: is a
// directory, not a file").
Status readFile(const std::string& path, std::string& out);

// Checks, before any work, that writeFileAtomic(path, ...) can succeed: the
// path is not a directory, and its directory exists and takes a new file
// (one is created there and removed). The error names the path and why, so
// a command refuses an unwritable output at once instead of after its work.
// A device or a FIFO (/dev/null, /dev/stdout) is probed for write permission.
Status probeOutputFile(const std::string& path);

// Writes `content` to `path` atomically: a temporary file in the same
// directory ("DIR/.NAME.tmpXXXXXX"), flushed and fsync'ed, then renamed over
// `path`. A crash or a failure leaves either the old file or the new one,
// never a torn one, and no temporary file behind. A path that is a device
// or a FIFO (`--logfile /dev/null`) is written in place: a rename would
// replace the device node with a regular file.
Status writeFileAtomic(const std::string& path, std::string_view content);

// linkTarget and fileModeFor (where a write lands, with what mode): rost/file_target.hpp.

// Several files that belong together (a run's outputs): each is written to
// its temporary file first, and only when every one is written and flushed
// are they renamed into place. A failure while writing (a full disk) leaves
// every path as it was, the old files of an earlier run included, so a
// directory never mixes two runs' files. (A rename that fails after others
// succeeded, which needs the directory to change under the run, cannot be
// undone; its error names the path.) Devices and FIFOs are written in place
// before the renames (one that fails leaves every file as it was) and closed
// after them.
struct FileToWrite {
    std::string path;
    std::string_view content;
};
Status writeFilesAtomic(std::span<const FileToWrite> files);

} // namespace rost::text
