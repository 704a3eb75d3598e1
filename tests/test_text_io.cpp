// The text I/O layer (rost/text_io.hpp): lines, fields, numbers and their
// errors, the writers read back, and the file functions.

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "rost/config.hpp"
#include "rost/text_io.hpp"

#include "aligned_buffer.hpp"
#include "file_bytes.hpp"

namespace fs = std::filesystem;
namespace text = rost::text;
using rost::Status;
using rost::StatusKind;

namespace {

// Every line the reader gives: "NUMBER:TEXT".
std::vector<std::string> lines(std::string_view s, text::LineRules rules = {}) {
    text::LineReader r(s, "t", rules);
    std::vector<std::string> out;
    for (text::Line l; r.next(l);) out.push_back(std::to_string(l.number) + ":" + std::string(l.text));
    return out;
}

using Strings = std::vector<std::string>;

// Each field as "COLUMN:TEXT".
Strings fields(std::string_view line, std::string_view sep = ",") {
    std::vector<text::Field> f;
    text::splitFields(line, sep, f);
    Strings out;
    for (const auto& x : f) out.push_back(std::to_string(x.column) + ":" + std::string(x.text));
    return out;
}

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// A fresh directory under the temporary one, removed at the end.
struct TempDir {
    fs::path path = fs::temp_directory_path() / ("rost-text-io-" + std::to_string(::getpid()));
    TempDir() {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() { fs::remove_all(path); }
    // The files in it, temporary ones included.
    Strings names() const {
        Strings out;
        for (const auto& e : fs::directory_iterator(path)) out.push_back(e.path().filename().string());
        std::sort(out.begin(), out.end());
        return out;
    }
};

} // namespace

// Counts in messages take their noun's plural unless they are one: "1
// model", not "1 models" (rost merge of one model), "0 frames".
TEST(TextMessages, ACountIsPluralUnlessItIsOne) {
    EXPECT_EQ(text::counted(1, "model"), "1 model");
    EXPECT_EQ(text::counted(0, "frame"), "0 frames");
    EXPECT_EQ(text::counted(2, "global topic"), "2 global topics");
    EXPECT_EQ(text::counted(-1, "step"), "-1 steps");
    rost::Config c;
    c.frame_width = c.frame_height = c.cell_space = 64;
    EXPECT_NE(c.tablesText().find(", 1 cell a step (frame 64x64"), std::string::npos) << c.tablesText();
    // The threads are named where they multiply the memory: a copy of the counts each.
    c.threads = 1;
    EXPECT_EQ(c.tablesText().find("threads"), std::string::npos) << c.tablesText();
    c.threads = 8;
    EXPECT_NE(c.tablesText().find(", threads = 8 (each a copy of the K x V counts)"), std::string::npos) << c.tablesText();
}

TEST(TextLines, NumbersCountSkippedLinesAndStripCarriageReturns) {
    EXPECT_EQ(lines("a\n\n# c\nb\r\n\r\nc"), (Strings{"1:a", "4:b", "6:c"}));
    // The empty piece after a final newline is no line; a last line without one is.
    EXPECT_EQ(lines("a\n"), (Strings{"1:a"}));
    EXPECT_EQ(lines(""), Strings{});
    // Blanks are a line unless the rules say otherwise.
    EXPECT_EQ(lines(" \t\nx"), (Strings{"1: \t", "2:x"}));
    EXPECT_EQ(lines(" \t\nx", {.skip_empty = true, .blank_is_empty = true}), (Strings{"2:x"}));
    // A comment is a '#' first; with comments kept it is a line.
    EXPECT_EQ(lines(" #x\n#y"), (Strings{"1: #x"}));
    EXPECT_EQ(lines("#y\n", {.skip_comments = false}), (Strings{"1:#y"}));
    // Nothing skipped: every line, empty ones too.
    EXPECT_EQ(lines("a\n\n#b\r\n", {.skip_empty = false, .blank_is_empty = false, .skip_comments = false}),
              (Strings{"1:a", "2:", "3:#b"}));
}

TEST(TextLines, CountsEveryLineReadForTheLineAfterTheLast) {
    text::LineReader r("a\n\nb\n\n\n", "f.csv");
    text::Line l;
    while (r.next(l)) {
    }
    EXPECT_EQ(l.number, 3);
    EXPECT_EQ(r.lines(), 5);
    EXPECT_EQ(r.at(r.lines() + 1, 1), "f.csv:6:1: ");
    EXPECT_EQ(r.at(2), "f.csv:2: ");
}

TEST(TextFields, ColumnsAreOneBasedAndBlanksAreTrimmed) {
    EXPECT_EQ(fields("10,1,22"), (Strings{"1:10", "4:1", "6:22"}));
    EXPECT_EQ(fields(" 7 ,\t8"), (Strings{"2:7", "6:8"}));
    // One trailing separator is tolerated; an empty field elsewhere is kept.
    EXPECT_EQ(fields("1,2,"), (Strings{"1:1", "3:2"}));
    EXPECT_EQ(fields("1,,2"), (Strings{"1:1", "3:", "4:2"}));
    EXPECT_EQ(fields(","), (Strings{"1:"}));
    EXPECT_EQ(fields(""), (Strings{"1:"}));
    // A separator of several characters, and none: the line is one field.
    EXPECT_EQ(fields("a::b", "::"), (Strings{"1:a", "4:b"}));
    EXPECT_EQ(fields("a b", ""), (Strings{"1:a b"}));
    // The start of a blank field is where it begins, its column after the blanks.
    std::vector<text::Field> f;
    text::splitFields("1,  ,2", ",", f);
    ASSERT_EQ(f.size(), 3u);
    EXPECT_EQ(f[1].start, 3u);
    EXPECT_EQ(f[1].column, 5u);
}

TEST(TextNumbers, ErrorsNameFileLineAndColumn) {
    std::vector<text::Field> f;
    text::splitFields("1, x3,99999999999999999999", ",", f);
    int64_t v = 0;
    EXPECT_TRUE(text::integerField("w.csv", 7, f[0], "an integer", v).ok());
    EXPECT_EQ(v, 1);
    EXPECT_EQ(text::integerField("w.csv", 7, f[1], "an integer", v).message(),
              "w.csv:7:4: expected an integer, found 'x3'");
    EXPECT_EQ(text::integerField("w.csv", 7, f[2], "an integer", v).message(),
              "w.csv:7:7: number '99999999999999999999' out of range");
    // The text found is cut after 32 characters (or as asked).
    const std::string longText(40, 'z');
    const text::Field lf{longText, 3, 3};
    EXPECT_EQ(text::expected("n", 1, lf, "a count").message(), "n:1:3: expected a count, found '" + std::string(32, 'z') + "'");
    EXPECT_EQ(text::expected("n", 1, lf, "a count", 5).message(), "n:1:3: expected a count, found 'zzzzz'");
    // Control bytes are written \xNN (a NUL would cut the line where it is printed, an escape
    // drive the terminal) and a byte-order mark \ufeff (it would look like nothing at all).
    const std::string odd = std::string("1\0", 2) + "\x1b[2J\x7f\xEF\xBB\xBF" + "0";
    const text::Field of{odd, 1, 1};
    EXPECT_EQ(text::expected("n", 2, of, "an integer").message(),
              "n:2:1: expected an integer, found '1\\x00\\x1b[2J\\x7f\\ufeff0'");
    // UTF-8 characters stay; a byte of none (stray, cut short, overlong, a surrogate) is \xNN, so
    // the message is text a terminal and Python can show.
    const std::string utf = "\xC3\xA9\xE2\x82\xAC\xF0\x9F\x8C\x8A|\xFF|\xC3|\xC0\xAF|\xED\xA0\x80|\xE2\x82";
    const text::Field uf{utf, 1, 1};
    EXPECT_EQ(text::expected("n", 2, uf, "an integer").message(),
              "n:2:1: expected an integer, found '\xC3\xA9\xE2\x82\xAC\xF0\x9F\x8C\x8A|\\xff|\\xc3|\\xc0\\xaf|"
              "\\xed\\xa0\\x80|\\xe2\\x82'");
    // The cut falls between two characters, not inside one (which would read as a broken file).
    const std::string accent = std::string(31, 'a') + "\xC3\xA9z";
    EXPECT_EQ(text::expected("n", 1, text::Field{accent, 1, 1}, "x").message(),
              "n:1:1: expected x, found '" + std::string(31, 'a') + "'");
    const std::string wave = std::string(30, 'a') + "\xF0\x9F\x8C\x8A";
    EXPECT_EQ(text::printable(wave, 32), std::string(30, 'a'));
    // Uncut, as the faces print their errors: the C1 controls (U+009B is a terminal's control
    // sequence introducer) are written \u0080..\u009f, the characters after them kept.
    EXPECT_EQ(text::printable("a\nb\x1b[31m\xC2\x9B\xC2\x80\xC2\x9F\xC2\xA0\xC3\xA9\\z"),
              "a\\x0ab\\x1b[31m\\u009b\\u0080\\u009f\xC2\xA0\xC3\xA9\\z");
    EXPECT_EQ(text::printable(std::string(5000, 'p')), std::string(5000, 'p'));
    // A number out of range is quoted the same way.
    const std::string big = std::string(25, '9') + "\xFF\x1b";
    int64_t bigValue = 0;
    EXPECT_EQ(text::integerField("n", 3, text::Field{big, 4, 4}, "a count", bigValue).message(),
              "n:3:4: number '" + std::string(25, '9') + "\\xff\\x1b' out of range");
}

TEST(TextNumbers, RangesAreHalfOpenAndNamed) {
    const auto at = [](std::string_view s) { return text::Field{s, 2, 2}; };
    int64_t v = -1;
    EXPECT_TRUE(text::integerField("f", 1, at("39"), "word id", "word id", 0, 40, v).ok());
    EXPECT_EQ(v, 39);
    EXPECT_EQ(text::integerField("f", 1, at("40"), "word id", "word id", 0, 40, v).message(),
              "f:1:2: word id 40 out of range [0, 40)");
    EXPECT_EQ(text::integerField("f", 1, at("-1"), "word id", "word id", 0, 40, v).message(),
              "f:1:2: word id -1 out of range [0, 40)");
    EXPECT_EQ(v, 39);  // untouched by a failure
    EXPECT_EQ(text::integerField("f", 1, at("99999999999999999999"), "x", "x", 0, 40, v).message(),
              "f:1:2: x 99999999999999999999 out of range [0, 40)");
    EXPECT_EQ(text::integerField("f", 1, at(""), "an x", "x", 0, 40, v).message(), "f:1:2: expected an x, found ''");
    EXPECT_EQ(text::integerField("f", 1, at("+3"), "an x", "x", 0, 40, v).message(), "f:1:2: expected an x, found '+3'");
}

TEST(TextNumbers, WholeFieldsOnlyAndTheKindsOfFailure) {
    int64_t i = 0;
    uint64_t u = 0;
    double d = 0;
    EXPECT_EQ(text::toInteger("-9223372036854775808", i), text::NumberError::None);
    EXPECT_EQ(i, std::numeric_limits<int64_t>::min());
    EXPECT_EQ(text::toInteger("9223372036854775808", i), text::NumberError::Overflow);
    EXPECT_EQ(text::toInteger("12x", i), text::NumberError::Syntax);
    EXPECT_EQ(text::toInteger("1.0", i), text::NumberError::Syntax);
    EXPECT_EQ(text::toInteger(" 1", i), text::NumberError::Syntax);
    EXPECT_EQ(text::toUnsigned("18446744073709551615", u), text::NumberError::None);
    EXPECT_EQ(u, std::numeric_limits<uint64_t>::max());
    EXPECT_EQ(text::toUnsigned("-1", u), text::NumberError::Syntax);
    EXPECT_EQ(text::toDouble("2.5e-3", d), text::NumberError::None);
    EXPECT_EQ(d, 2.5e-3);
    EXPECT_EQ(text::toDouble("nan", d), text::NumberError::None);
    EXPECT_TRUE(std::isnan(d));
    EXPECT_EQ(text::toDouble("1e999", d), text::NumberError::None);
    EXPECT_EQ(d, std::numeric_limits<double>::infinity());
    EXPECT_EQ(text::toDouble("1e-400", d), text::NumberError::None);
    EXPECT_EQ(d, 0.0);
    EXPECT_EQ(text::toDouble("1.5.2", d), text::NumberError::Syntax);
    // Out of double's range, the text goes to strtod through a 64-byte buffer:
    // up to 63 characters it is read (an infinity), from 64 it is refused
    // whole, never copied past the buffer (AddressSanitizer's CI step).
    const std::string huge = "1e999", pad63(63 - huge.size(), '0'), pad64(64 - huge.size(), '0');
    d = 0.0;
    EXPECT_EQ(text::toDouble(pad63 + huge, d), text::NumberError::None);
    EXPECT_EQ(d, std::numeric_limits<double>::infinity());
    d = 0.0;
    EXPECT_EQ(text::toDouble(pad64 + huge, d), text::NumberError::Syntax);
    EXPECT_EQ(d, 0.0);
    const text::Field f{"1,5", 4, 4};
    EXPECT_EQ(text::doubleField("p.csv", 3, f, "a number", d).message(), "p.csv:3:4: expected a number, found '1,5'");
}

TEST(TextWriters, RowsAndTablesAsTheToolWritesThem) {
    std::string s;
    const uint16_t labels[] = {3, 0, 65535};
    text::appendRow(s, -4, std::span<const uint16_t>(labels));
    text::appendRow(s, 5, std::span<const uint16_t>());
    EXPECT_EQ(s, "-4,3,0,65535\n5\n");
    s.clear();
    text::TableWriter t(s);
    t.header({"frame", "surprise", "cell"});
    t.cell(int64_t{7}).cell(0.1).cell(1.5f).end();
    t.cell(uint32_t{8}).cell(std::nan("")).cell(-std::numeric_limits<float>::infinity()).end();
    t.cell("a").cell(1e300).cell(2).end();
    EXPECT_EQ(s, "frame,surprise,cell\n7,0.1,1.5\n8,nan,-inf\na,1e+300,2\n");
}

TEST(TextWriters, WhatIsWrittenReadsBackExactly) {
    // Doubles written shortest read back to the same bits; integers at their limits too.
    const double values[] = {0.1, 1.0 / 3.0, -2.5e-310, 6.02214076e23, std::numeric_limits<double>::max(),
                             std::numeric_limits<double>::denorm_min(), -0.0};
    const int64_t ints[] = {std::numeric_limits<int64_t>::min(), -1, 0, std::numeric_limits<int64_t>::max()};
    std::string s;
    text::TableWriter t(s);
    for (double v : values) t.cell(v);
    t.end();
    text::appendRow(s, 42, std::span<const int64_t>(ints));
    text::LineReader r(s, "rt");
    std::vector<text::Field> f;
    text::Line line;
    ASSERT_TRUE(r.next(line));
    text::splitFields(line.text, ",", f);
    ASSERT_EQ(f.size(), std::size(values));
    for (std::size_t i = 0; i < f.size(); ++i) {
        double d = 1;
        ASSERT_TRUE(text::doubleField(r.name(), line.number, f[i], "a number", d).ok()) << f[i].text;
        EXPECT_EQ(std::signbit(d), std::signbit(values[i]));
        EXPECT_EQ(d, values[i]) << f[i].text;
    }
    ASSERT_TRUE(r.next(line));
    EXPECT_EQ(line.number, 2);
    text::splitFields(line.text, ",", f);
    ASSERT_EQ(f.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i) {
        int64_t v = 0;
        ASSERT_TRUE(text::integerField(r.name(), line.number, f[i], "an integer", v).ok());
        EXPECT_EQ(v, i == 0 ? 42 : ints[i - 1]);
    }
    EXPECT_FALSE(r.next(line));
}

TEST(TextFiles, ReadWriteAndADirectoryRefusedByName) {
    TempDir d;
    const std::string path = (d.path / "a.csv").string();
    ASSERT_TRUE(text::writeFileAtomic(path, "1,2\n").ok());
    std::string got;
    ASSERT_TRUE(text::readFile(path, got).ok());
    EXPECT_EQ(got, "1,2\n");
    EXPECT_EQ(d.names(), Strings{"a.csv"});  // no temporary file left
    EXPECT_EQ(text::readFile(d.path.string(), got).message(), d.path.string() + ": is a directory, not a file");
    EXPECT_EQ(text::probeOutputFile(d.path.string()).message(),
              d.path.string() + ": is a directory, not a file that can be written");
    EXPECT_TRUE(text::probeOutputFile(path).ok());
    const std::string missing = (d.path / "no" / "b.csv").string();
    EXPECT_EQ(text::readFile(missing, got).message(), missing + ": cannot open: No such file or directory");
    EXPECT_NE(text::probeOutputFile(missing).message().find(missing + ": cannot write in "), std::string::npos);
    EXPECT_EQ(d.names(), Strings{"a.csv"});
}

// What a failed open is about travels with its message (StatusKind), through
// a caller's prefix, so that a face says it in its own terms (Python's
// FileNotFoundError) without looking at the file again.
TEST(TextFiles, AFailedOpenSaysWhatItIsAboutThroughEveryPrefix) {
    TempDir d;
    const std::string path = (d.path / "a.csv").string(), missing = (d.path / "no" / "b.csv").string();
    ASSERT_TRUE(text::writeFileAtomic(path, "1,2\n").ok());
    std::string got;
    const Status gone = text::readFile(missing, got);
    EXPECT_EQ(gone.kind(), StatusKind::NotFound);
    const Status named = gone.prefixed("--resume: ");
    EXPECT_EQ(named.kind(), StatusKind::NotFound);
    EXPECT_EQ(named.message(), "--resume: " + missing + ": cannot open: No such file or directory");
    EXPECT_TRUE(Status().prefixed("--resume: ").ok()) << "an ok Status prefixed became an error";
    EXPECT_EQ(text::readFile(d.path.string(), got).kind(), StatusKind::IsADirectory);
    EXPECT_EQ(text::probeOutputFile(d.path.string()).kind(), StatusKind::IsADirectory);
    EXPECT_EQ(text::probeOutputFile(missing).kind(), StatusKind::NotFound);
    EXPECT_EQ(text::writeFileAtomic(missing, "x").kind(), StatusKind::NotFound);
    EXPECT_EQ(text::readFile(path + "/x", got).kind(), StatusKind::NotADirectory) << "ENOTDIR: a file on the way";
    const std::string loop = (d.path / "loop").string();
    ASSERT_EQ(::symlink(loop.c_str(), loop.c_str()), 0);
    EXPECT_EQ(text::readFile(loop, got).kind(), StatusKind::OsError) << "ELOOP: refused by the system otherwise";
    EXPECT_EQ(Status::fromErrno(EACCES, "x").kind(), StatusKind::PermissionDenied);
    EXPECT_EQ(Status::fromErrno(EPERM, "x").kind(), StatusKind::PermissionDenied);
    EXPECT_EQ(Status::error("bad").kind(), StatusKind::Invalid);
    if (::geteuid() != 0) {  // root reads a mode-000 file
        ASSERT_EQ(::chmod(path.c_str(), 0), 0);
        EXPECT_EQ(text::readFile(path, got).kind(), StatusKind::PermissionDenied);
    }
}

// The word stream's reader: a large file lands whole in a mapping of its
// own (huge pages where the kernel has them: no zeros written first, one
// fault per 2 MiB), a small one on the heap; both read exactly what
// readFile(std::string) reads, and fail with its messages.
TEST(TextFiles, ALargeFileIsReadWholeIntoAMappingOfItsOwn) {
    TempDir d;
    std::string big(5'000'003, '\0');
    for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>('0' + (i * 7919 + i / 4096) % 75);
    const std::string path = (d.path / "words.csv").string(), small = (d.path / "small.csv").string();
    ASSERT_TRUE(text::writeFileAtomic(path, big).ok());
    ASSERT_TRUE(text::writeFileAtomic(small, "1,2\n").ok());
    const std::size_t before = rost::mappedBytes();
    {
        text::FileBytes got;
        ASSERT_TRUE(text::readFile(path, got).ok());
        EXPECT_TRUE(got.view() == big) << "the bytes read differ from the file's";
        EXPECT_GE(rost::mappedBytes(), before + big.size()) << "a 5 MB file was read into heap memory";
        std::string asString;
        ASSERT_TRUE(text::readFile(path, asString).ok());
        EXPECT_TRUE(asString == got.view());
        ASSERT_TRUE(text::readFile(small, got).ok());  // the buffer is reused: only the new bytes count
        EXPECT_EQ(got.view(), "1,2\n");
    }
    EXPECT_EQ(rost::mappedBytes(), before) << "the mapping outlived its FileBytes";
    text::FileBytes got;
    EXPECT_EQ(text::readFile(d.path.string(), got).message(), d.path.string() + ": is a directory, not a file");
    const std::string missing = (d.path / "no" / "b.csv").string();
    EXPECT_EQ(text::readFile(missing, got).message(), missing + ": cannot open: No such file or directory");
    EXPECT_TRUE(got.empty());
}

// A pipe has no length: the buffer grows as it is read, from the heap into
// a mapping past 2 MiB, and keeps every byte read before each growth.
TEST(TextFiles, APipeIsReadWholeAsTheBufferGrows) {
    TempDir d;
    const std::string fifo = (d.path / "pipe").string();
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::string sent(3'500'000, '\0');
    for (std::size_t i = 0; i < sent.size(); ++i) sent[i] = static_cast<char>('a' + (i * 31 + i / 65536) % 26);
    // A reader that stopped early must fail the test, not kill it with SIGPIPE.
    struct IgnorePipe {
        void (*old)(int) = std::signal(SIGPIPE, SIG_IGN);
        ~IgnorePipe() { std::signal(SIGPIPE, old); }
    } ignore;
    std::jthread writer([&] {
        const int fd = ::open(fifo.c_str(), O_WRONLY);
        if (fd < 0) return;
        for (std::size_t at = 0; at < sent.size();) {
            const ssize_t n = ::write(fd, sent.data() + at, std::min<std::size_t>(sent.size() - at, 100'000));
            if (n <= 0) break;
            at += static_cast<std::size_t>(n);
        }
        ::close(fd);
    });
    text::FileBytes got;
    ASSERT_TRUE(text::readFile(fifo, got).ok());
    writer.join();
    ASSERT_EQ(got.view().size(), sent.size());
    EXPECT_TRUE(got.view() == sent) << "bytes read before the buffer grew were lost";
}

TEST(TextFiles, AFailedRenameLeavesTheOldContentAndNoTemporary) {
    TempDir d;
    // The target is a directory holding a file: the rename over it fails.
    fs::create_directories(d.path / "out.csv");
    std::ofstream(d.path / "out.csv" / "old") << "old";
    const rost::Status st = text::writeFileAtomic((d.path / "out.csv").string(), "new\n");
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.message().find("out.csv: rename failed: "), std::string::npos) << st.message();
    EXPECT_EQ(slurp(d.path / "out.csv" / "old"), "old");
    EXPECT_EQ(d.names(), Strings{"out.csv"});
}

// An output that is a device or a FIFO (`--logfile /dev/null`) is written
// in place: renaming a temporary file over it would replace the node with a
// regular file (as root, /dev/null itself). A FIFO stands in for the device.
TEST(TextFiles, ADeviceOrFifoIsWrittenInPlaceNotReplaced) {
    TempDir d;
    const std::string fifo = (d.path / "pipe").string();
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // A reader first (non-blocking), so the writer's open does not wait.
    const int rd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(rd, 0);
    EXPECT_TRUE(text::probeOutputFile(fifo).ok());
    ASSERT_TRUE(text::writeFileAtomic(fifo, "1,2\n").ok());
    char buf[16] = {};
    const ssize_t n = ::read(rd, buf, sizeof buf);
    ::close(rd);
    EXPECT_EQ(std::string(buf, n > 0 ? static_cast<std::size_t>(n) : 0), "1,2\n");
    struct stat st {};
    ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the FIFO was replaced by a file";
    EXPECT_EQ(d.names(), Strings{"pipe"});  // no temporary file left
    // A FIFO no process reads is an error at once, not a wait for a reader that may never come
    // (alone, and among other files: those are not written either).
    const auto started = std::chrono::steady_clock::now();
    ::alarm(20);  // a wait for a reader ends the test binary (SIGALRM), not the suite's time
    const Status alone = text::writeFileAtomic(fifo, "1,2\n");
    EXPECT_EQ(alone.message(), fifo + ": cannot open for writing: a FIFO that no process reads (start its reader first)");
    EXPECT_EQ(alone.kind(), rost::StatusKind::OsError);
    const std::string other = (d.path / "other.csv").string();
    const std::vector<text::FileToWrite> both{{other, "x\n"}, {fifo, "1,2\n"}};
    EXPECT_FALSE(text::writeFilesAtomic(both).ok());
    ::alarm(0);
    EXPECT_FALSE(std::filesystem::exists(other)) << "a file renamed before the FIFO failed";
    EXPECT_EQ(d.names(), Strings{"pipe"});
    EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(20));
}

// What `write` returns when run in a forked child whose files may not grow
// past 1 KiB (a full disk, as the process sees it): the child passes the
// status back through a pipe. An ok status when the child died otherwise is
// never returned: that is a test failure here.
namespace {

rost::Status underFileSizeLimit(const std::function<rost::Status()>& write) {
    int fds[2];
    if (::pipe(fds) != 0) return rost::Status::error("pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0) return rost::Status::error("fork failed");
    if (pid == 0) {
        ::close(fds[0]);
        std::signal(SIGXFSZ, SIG_IGN);
        const rlimit lim{1024, 1024};
        ::setrlimit(RLIMIT_FSIZE, &lim);
        const rost::Status st = write();
        const std::string text = st.ok() ? std::string("ok") : "error:" + st.message();
        const bool sent = ::write(fds[1], text.data(), text.size()) == static_cast<ssize_t>(text.size());
        ::_exit(sent ? 0 : 1);
    }
    ::close(fds[1]);
    std::string text;
    char buf[512];
    for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) text.append(buf, static_cast<std::size_t>(n));
    ::close(fds[0]);
    int status = 0;
    const bool exited = ::waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
    EXPECT_TRUE(exited) << "the child under the file size limit did not finish";
    EXPECT_NE(text, "ok") << "a write past the file size limit succeeded";
    if (text.rfind("error:", 0) == 0) return rost::Status::error(text.substr(6));
    return rost::Status::error("no status from the child (" + text + ")");
}

} // namespace

// A run's outputs are written all or none: a write that fails (a full disk:
// here a child limited to 1 KiB files) on the second of three leaves all
// three as an earlier run left them, no file of the new run among them.
TEST(TextFiles, FilesWrittenTogetherAreAllOrNone) {
    TempDir d;
    const std::string a = (d.path / "a.csv").string(), b = (d.path / "b.csv").string(), c = (d.path / "c.csv").string();
    for (const std::string& p : {a, b, c}) ASSERT_TRUE(text::writeFileAtomic(p, "old\n").ok());
    const std::string big(1 << 16, 'x');
    const rost::Status st = underFileSizeLimit([&] {
        const text::FileToWrite files[] = {{a, "new\n"}, {b, big}, {c, "new\n"}};
        return text::writeFilesAtomic(files);
    });
    EXPECT_EQ(st.message().rfind(b + ": write failed: ", 0), 0u) << st.message();
    for (const std::string& p : {a, b, c}) EXPECT_EQ(slurp(p), "old\n") << p;
    EXPECT_EQ(d.names(), (Strings{"a.csv", "b.csv", "c.csv"}));
    // Written whole when nothing fails, a device in place among them.
    const text::FileToWrite files[] = {{a, "new a\n"}, {"/dev/null", "x"}, {c, "new c\n"}};
    ASSERT_TRUE(text::writeFilesAtomic(files).ok());
    EXPECT_EQ(slurp(a), "new a\n");
    EXPECT_EQ(slurp(b), "old\n");
    EXPECT_EQ(slurp(c), "new c\n");
    EXPECT_EQ(d.names(), (Strings{"a.csv", "b.csv", "c.csv"}));
}

std::string a(const TempDir& d) { return (d.path / "a.csv").string(); }

TEST(TextFiles, AWriteThroughALinkReplacesWhatItLeadsToAndKeepsTheLink) {
    TempDir d;
    fs::create_directory(d.path / "store");
    const fs::path real = d.path / "store" / "m.ckpt", link = d.path / "m.ckpt", relative = d.path / "rel.ckpt";
    ASSERT_TRUE(text::writeFileAtomic(real.string(), "old\n").ok());
    fs::create_symlink(real, link);
    fs::create_symlink("store/m.ckpt", relative);  // relative to the link's directory
    ASSERT_TRUE(text::writeFileAtomic(link.string(), "new\n").ok());
    EXPECT_TRUE(fs::is_symlink(link));
    EXPECT_EQ(slurp(real), "new\n");
    const text::FileToWrite files[] = {{relative.string(), "newer\n"}};
    ASSERT_TRUE(text::writeFilesAtomic(files).ok());
    EXPECT_TRUE(fs::is_symlink(relative));
    EXPECT_EQ(slurp(real), "newer\n");
    // A link to a file not made yet: the file is made where it leads.
    const fs::path dangling = d.path / "next.ckpt";
    fs::create_symlink(d.path / "store" / "next.ckpt", dangling);
    ASSERT_TRUE(text::writeFileAtomic(dangling.string(), "first\n").ok());
    EXPECT_TRUE(fs::is_symlink(dangling));
    EXPECT_EQ(slurp(d.path / "store" / "next.ckpt"), "first\n");
    EXPECT_EQ(d.names(), (Strings{"m.ckpt", "next.ckpt", "rel.ckpt", "store"}));
    // A loop of links is an error, as the kernel's lookups give, and stays a loop.
    fs::create_symlink("loopb", d.path / "loopa");
    fs::create_symlink("loopa", d.path / "loopb");
    const std::string loop = (d.path / "loopa").string();
    EXPECT_EQ(text::writeFileAtomic(loop, "x\n").message(), loop + ": too many levels of symbolic links");
    const text::FileToWrite looped[] = {{a(d), "x\n"}, {loop, "x\n"}};
    EXPECT_EQ(text::writeFilesAtomic(looped).message(), loop + ": too many levels of symbolic links");
    EXPECT_TRUE(fs::is_symlink(d.path / "loopa"));
    EXPECT_FALSE(fs::exists(a(d))) << "all or none";
}

TEST(TextFiles, AWrittenFileHasTheModeOfTheOneItReplacesElseTheUmasks) {
    TempDir d;
    const fs::path fresh = d.path / "fresh.csv", kept = d.path / "kept.csv";
    const mode_t before = ::umask(077);
    const rost::Status st = text::writeFileAtomic(fresh.string(), "x\n");
    ::umask(before);
    ASSERT_TRUE(st.ok()) << st.message();
    struct stat sb {};
    ASSERT_EQ(::stat(fresh.c_str(), &sb), 0);
    EXPECT_EQ(sb.st_mode & 0777, 0600u) << "a new file under umask 077";
    ASSERT_TRUE(text::writeFileAtomic(kept.string(), "x\n").ok());
    ASSERT_EQ(::chmod(kept.c_str(), 0640), 0);
    ASSERT_TRUE(text::writeFileAtomic(kept.string(), "y\n").ok());
    ASSERT_EQ(::stat(kept.c_str(), &sb), 0);
    EXPECT_EQ(sb.st_mode & 0777, 0640u) << "replacing a file keeps its mode";
    ASSERT_EQ(::chmod(kept.c_str(), 04750), 0);  // but not a setuid bit
    ASSERT_TRUE(text::writeFileAtomic(kept.string(), "z\n").ok());
    ASSERT_EQ(::stat(kept.c_str(), &sb), 0);
    EXPECT_EQ(sb.st_mode & 07777, 0750u);
}

TEST(TextFiles, AFailedWriteLeavesTheOldFile) {
    TempDir d;
    const fs::path path = d.path / "words.csv";
    ASSERT_TRUE(text::writeFileAtomic(path.string(), "old\n").ok());
    // In a child limited to 1 KiB files, a 64 KiB write fails part-way.
    const rost::Status st =
        underFileSizeLimit([&] { return text::writeFileAtomic(path.string(), std::string(1 << 16, 'x')); });
    EXPECT_NE(st.message().find("words.csv: write failed: "), std::string::npos) << st.message();
    EXPECT_EQ(slurp(path), "old\n");
    EXPECT_EQ(d.names(), Strings{"words.csv"});
}
