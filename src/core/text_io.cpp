// The text I/O layer (rost/text_io.hpp): lines, fields, numbers, writers, files.

#include "rost/text_io.hpp"

#include "file_bytes.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <limits>
#include <new>
#include <sys/stat.h>
#include <unistd.h>

namespace rost::text {

// ---- places -------------------------------------------------------------------------

std::string where(std::string_view name, int line, std::size_t column) {
    std::string s(name);
    s += ':';
    s += std::to_string(line);
    s += ':';
    s += std::to_string(column);
    s += ": ";
    return s;
}

std::string counted(long long n, std::string_view noun) {
    std::string s = std::to_string(n);
    s += ' ';
    s += noun;
    if (n != 1) s += 's';
    return s;
}

std::string where(std::string_view name, int line) {
    std::string s(name);
    s += ':';
    s += std::to_string(line);
    s += ": ";
    return s;
}

// ---- lines --------------------------------------------------------------------------

bool LineReader::next(Line& line) noexcept {
    while (pos_ < text_.size()) {
        std::size_t end = text_.find('\n', pos_);
        if (end == std::string_view::npos) end = text_.size();
        std::string_view s = text_.substr(pos_, end - pos_);
        pos_ = end + 1;
        ++number_;
        if (!s.empty() && s.back() == '\r') s.remove_suffix(1);
        if (rules_.skip_empty &&
            (s.empty() || (rules_.blank_is_empty && s.find_first_not_of(" \t") == std::string_view::npos)))
            continue;
        if (rules_.skip_comments && !s.empty() && s.front() == '#') continue;
        line = {s, number_};
        return true;
    }
    return false;
}

// ---- fields -------------------------------------------------------------------------

void splitFields(std::string_view line, std::string_view separator, std::vector<Field>& out) {
    out.clear();
    std::size_t pos = 0;
    while (true) {
        // One character (a comma): a memchr, not a memcmp at every one found.
        std::size_t end = separator.empty()       ? std::string_view::npos
                          : separator.size() == 1 ? line.find(separator[0], pos)
                                                  : line.find(separator, pos);
        if (end == std::string_view::npos) end = line.size();
        const std::string_view f = line.substr(pos, end - pos);
        std::size_t lead = 0;
        while (lead < f.size() && (f[lead] == ' ' || f[lead] == '\t')) ++lead;
        std::size_t trail = f.size();
        while (trail > lead && (f[trail - 1] == ' ' || f[trail - 1] == '\t')) --trail;
        const bool last = end == line.size();
        if (!(last && trail == lead && !out.empty())) out.push_back({f.substr(lead, trail - lead), pos + lead + 1, pos + 1});
        if (last) break;
        pos = end + separator.size();
    }
}

// ---- numbers ------------------------------------------------------------------------

namespace {
template <typename T>
NumberError parseWhole(std::string_view text, T& out) noexcept {
    const char* b = text.data();
    const char* e = b + text.size();
    T v{};
    const auto [ptr, ec] = std::from_chars(b, e, v);
    if (text.empty() || ec == std::errc::invalid_argument) return NumberError::Syntax;
    if (ec == std::errc::result_out_of_range) return NumberError::Overflow;
    if (ptr != e) return NumberError::Syntax;
    out = v;
    return NumberError::None;
}

// The length of the well-formed UTF-8 sequence at s[i] (lead byte >= 0x80),
// or 0: a stray byte, a sequence cut short, an overlong form, a surrogate.
std::size_t utf8Sequence(std::string_view s, std::size_t i) {
    const auto at = [&](std::size_t k) { return static_cast<unsigned char>(s[i + k]); };
    const unsigned char c = at(0);
    const std::size_t n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
    if (n == 0 || i + n > s.size()) return 0;
    for (std::size_t k = 1; k < n; ++k)
        if ((at(k) & 0xC0) != 0x80) return 0;
    // The second byte's range where the first allows less (Unicode's table 3-7).
    if ((c == 0xE0 && at(1) < 0xA0) || (c == 0xED && at(1) > 0x9F) || (c == 0xF0 && at(1) < 0x90) ||
        (c == 0xF4 && at(1) > 0x8F))
        return 0;
    return n;
}

// A field as an error quotes it: at most `cut` bytes, control bytes written
// \xNN (a NUL would end the line on a terminal, an escape would drive it) and
// a byte-order mark \ufeff (it would look like nothing: '0' that is not 0);
// a byte of no UTF-8 character \xNN too (Python could not make it text,
// and a terminal would show it as a box); a C1 control \u0080..\u009f (U+009B
// is a terminal's control sequence introducer, as ESC [ is).
std::string cutText(std::string_view s, std::size_t cut) {
    static constexpr char kHex[] = "0123456789abcdef";
    // Between two characters: not inside a multi-byte one (at most 3 bytes back).
    for (std::size_t back = 0; cut < s.size() && back < 3 && (static_cast<unsigned char>(s[cut]) & 0xC0) == 0x80; ++back)
        --cut;
    s = s.substr(0, cut);
    std::string out;
    out.reserve(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
        const auto c = static_cast<unsigned char>(s[i]);
        const std::size_t seq = c >= 0x80 ? utf8Sequence(s, i) : 1;
        if (c == 0xEF && s.substr(i, 3) == "\xEF\xBB\xBF") {
            out += "\\ufeff";
            i += 2;
        } else if (c == 0xC2 && seq == 2 && static_cast<unsigned char>(s[i + 1]) < 0xA0) {  // C1: \u0080..\u009f
            const auto d = static_cast<unsigned char>(s[i + 1]);
            out += "\\u00";
            out += kHex[d >> 4];
            out += kHex[d & 15];
            ++i;
        } else if (seq > 1) {  // a character, whole
            out.append(s.substr(i, seq));
            i += seq - 1;
        } else if (c < 0x20 || c == 0x7F || seq == 0) {  // a control byte, or a byte of no character: \xNN
            out += "\\x";
            out += kHex[c >> 4];
            out += kHex[c & 15];
        } else {
            out += static_cast<char>(c);
        }
    }
    return out;
}
} // namespace

std::string printable(std::string_view text, std::size_t cut) { return cutText(text, cut); }

NumberError toInteger(std::string_view text, int64_t& out) noexcept { return parseWhole(text, out); }
NumberError toUnsigned(std::string_view text, uint64_t& out) noexcept { return parseWhole(text, out); }
NumberError toDouble(std::string_view text, double& out) noexcept {
    const NumberError e = parseWhole(text, out);
    if (e != NumberError::Overflow) return e;
    // Beyond double's range or below its smallest normal: strtod's value
    // (an infinity, a subnormal, zero), as other readers of such text take it.
    char buf[64];
    if (text.size() >= sizeof buf) return NumberError::Syntax;
    std::memcpy(buf, text.data(), text.size());
    buf[text.size()] = '\0';
    char* end = nullptr;
    const double v = std::strtod(buf, &end);
    if (end != buf + text.size()) return NumberError::Syntax;
    out = v;
    return NumberError::None;
}

Status expected(std::string_view name, int line, const Field& f, std::string_view what, std::size_t cut) {
    std::string msg = where(name, line, f.column);
    msg += "expected ";
    msg += what;
    msg += ", found '";
    msg += cutText(f.text, cut);
    msg += '\'';
    return Status::error(std::move(msg));
}

Status integerField(std::string_view name, int line, const Field& f, std::string_view what, int64_t& out) {
    const NumberError e = toInteger(f.text, out);
    if (e == NumberError::Syntax) return expected(name, line, f, what);
    if (e == NumberError::Overflow) {
        std::string msg = where(name, line, f.column);
        msg += "number '";
        msg += cutText(f.text, 32);
        msg += "' out of range";
        return Status::error(std::move(msg));
    }
    return {};
}

Status integerField(std::string_view name, int line, const Field& f, std::string_view what, std::string_view noun,
                    int64_t lo, int64_t hi, int64_t& out) {
    int64_t v = 0;
    const NumberError e = toInteger(f.text, v);
    if (e == NumberError::Syntax) return expected(name, line, f, what);
    if (e == NumberError::Overflow || v < lo || v >= hi) {
        std::string msg = where(name, line, f.column);
        msg += noun;
        msg += ' ';
        msg += cutText(f.text, 32);
        msg += " out of range [";
        msg += std::to_string(lo);
        msg += ", ";
        msg += std::to_string(hi);
        msg += ')';
        return Status::error(std::move(msg));
    }
    out = v;
    return {};
}

Status doubleField(std::string_view name, int line, const Field& f, std::string_view what, double& out) {
    if (toDouble(f.text, out) != NumberError::None) return expected(name, line, f, what);
    return {};
}

// ---- writing ------------------------------------------------------------------------

namespace {
template <typename F>
void appendFloating(std::string& out, F v) {
    if (std::isnan(v)) {
        out += "nan";
        return;
    }
    char buf[32];
    const auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, ec == std::errc() ? p : buf);
}
} // namespace

void appendNumber(std::string& out, double v) { appendFloating(out, v); }
void appendNumber(std::string& out, float v) { appendFloating(out, v); }

TableWriter& TableWriter::header(std::initializer_list<std::string_view> names) {
    for (std::string_view n : names) cell(n);
    return end();
}

TableWriter& TableWriter::cell(double v) {
    separate();
    appendNumber(out_, v);
    return *this;
}

TableWriter& TableWriter::cell(float v) {
    separate();
    appendNumber(out_, v);
    return *this;
}

TableWriter& TableWriter::cell(std::string_view v) {
    separate();
    out_ += v;
    return *this;
}

TableWriter& TableWriter::end() {
    out_.push_back('\n');
    open_ = false;
    return *this;
}

// ---- files --------------------------------------------------------------------------

namespace {
// Reads the whole file at `path` into a buffer that `grow(n, have)` makes
// at least n bytes long, keeping its first `have` bytes, and returns the
// bytes read in `have`. The buffer is sized once from the file's length
// when it has one (a pipe grows it): read into place, not copied through a
// buffer and a doubling string.
template <typename Grow>
Status readWhole(const std::string& path, Grow&& grow, std::size_t& have) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (f == nullptr) {
        const int err = errno;
        return Status::fromErrno(err, path + ": cannot open: " + std::strerror(err));
    }
    struct stat st {};
    if (::fstat(::fileno(f), &st) == 0 && S_ISDIR(st.st_mode)) {  // fopen opens a directory; reading it fails oddly
        std::fclose(f);
        return Status::error(StatusKind::IsADirectory, path + ": is a directory, not a file");
    }
    have = 0;
    std::size_t size = 0;
    char* data = nullptr;
    try {
        if (std::fseek(f, 0, SEEK_END) == 0) {
            const long len = std::ftell(f);
            // One byte more than the file: a full buffer then means it grew.
            if (len > 0) data = grow(size = static_cast<std::size_t>(len) + 1, have);
            std::rewind(f);
        }
        for (;;) {
            if (have == size) data = grow(size = std::max<std::size_t>(size * 2, std::size_t{1} << 16), have);
            const std::size_t n = std::fread(data + have, 1, size - have, f);
            have += n;
            // An error ends the read even with bytes in hand: a signal that
            // interrupts a read of a pipe returns what came before it, and
            // reading on would wait for the writer again.
            if (n == 0 || std::ferror(f)) break;
        }
    } catch (const std::bad_alloc&) {  // a file larger than this machine can hold (or /dev/zero)
        std::fclose(f);
        return Status::error(StatusKind::OutOfMemory, path + ": out of memory reading it whole, after " +
                                                          std::to_string(have >> 20) + " MiB");
    }
    const bool failed = std::ferror(f) != 0;
    std::fclose(f);
    if (failed) return Status::error(path + ": read error");
    return {};
}
} // namespace

Status readFile(const std::string& path, std::string& out) {
    out.clear();
    std::size_t have = 0;
    const Status st = readWhole(
        path,
        [&](std::size_t n, std::size_t) {
            out.resize(n);
            return out.data();
        },
        have);
    out.resize(have);
    return st;
}

Status readFile(const std::string& path, FileBytes& out) {
    out.size_ = 0;
    std::size_t have = 0;
    const Status st = readWhole(
        path,
        [&](std::size_t n, std::size_t keep) {
            if (n > out.buf_.size()) {
                AlignedBuffer<char> bigger(n);
                if (keep != 0) std::memcpy(bigger.data(), out.buf_.data(), keep);
                out.buf_ = std::move(bigger);
            }
            return out.buf_.data();
        },
        have);
    out.size_ = have;
    return st;
}

namespace {
// Writes all of `content` to `fd`; false (errno set) on failure.
bool writeAll(int fd, std::string_view content) {
    const char* p = content.data();
    std::size_t left = content.size();
    while (left > 0) {
        const ssize_t n = ::write(fd, p, left);
        if (n < 0) {
            if (errno == EINTR) continue;
            return false;
        }
        p += n;
        left -= static_cast<std::size_t>(n);
    }
    return true;
}
} // namespace

namespace {

// An existing path that is neither a regular file nor a directory: a device
// (/dev/null, /dev/stdout) or a FIFO. Such an output is written in place: a
// temporary file renamed over it would replace the device node itself (as
// root, `--logfile /dev/null` would leave a regular file at /dev/null).
bool isDeviceOrFifo(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

// A FIFO is opened without waiting: one no process reads is an error now,
// not a wait for a reader that may never come (an open blocked there is
// restarted after Ctrl-C, so the tool could not be stopped); once open, its
// writes wait for the reader as a pipe's do.
Status openInPlace(const std::string& path, int& fd) {
    fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
        const int err = errno;
        if (err == ENXIO)
            return Status::fromErrno(err, path + ": cannot open for writing: a FIFO that no process reads (start its "
                                              "reader first)");
        return Status::fromErrno(err, path + ": cannot open for writing: " + std::strerror(err));
    }
    const int flags = ::fcntl(fd, F_GETFL);
    if (flags >= 0) (void)::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);  // blocking writes, as a pipe's
    return {};
}

// Writes `content` through `fd` (openInPlace's), left open.
Status writeThrough(int fd, const std::string& path, std::string_view content) {
    if (!writeAll(fd, content)) {
        const int err = errno;
        return Status::fromErrno(err, path + ": write failed: " + std::strerror(err));
    }
    return {};
}

} // namespace

Status probeOutputFile(const std::string& path) {
    if (path.empty()) return Status::error("an output path is empty");
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
        return Status::error(StatusKind::IsADirectory, path + ": is a directory, not a file that can be written");
    if (isDeviceOrFifo(path)) {
        if (::access(path.c_str(), W_OK) != 0) {
            const int err = errno;
            return Status::fromErrno(err, path + ": cannot write: " + std::strerror(err));
        }
        return {};
    }
    std::string dir, tmp;
    const int fd = makeTemporaryBeside(path, dir, tmp);
    if (fd < 0) {
        const int err = errno;
        return Status::fromErrno(err, path + ": cannot write in " + dir + ": " + std::strerror(err));
    }
    ::close(fd);
    ::unlink(tmp.c_str());
    return {};
}

namespace {

// `content` in a new temporary file beside `path` (its name in `tmp`, its
// directory in `dir`), flushed; on failure nothing is left behind.
Status writeTemporary(const std::string& path, std::string_view content, std::string& dir, std::string& tmp) {
    const int fd = makeTemporaryBeside(path, dir, tmp);
    if (fd < 0) {
        const int err = errno;
        return Status::fromErrno(err, path + ": cannot create a temporary file in " + dir + ": " + std::strerror(err));
    }
    if (!writeAll(fd, content)) {
        const int err = errno;  // a full disk, a file size limit: the system's refusal (OSError in Python)
        ::close(fd);
        ::unlink(tmp.c_str());
        return Status::fromErrno(err, path + ": write failed: " + std::strerror(err));
    }
    const int synced = ::fsync(fd) == 0 ? 0 : errno;
    const int closed = ::close(fd) == 0 ? 0 : errno;  // closed whether or not fsync failed
    if (synced != 0 || closed != 0) {
        const int err = synced != 0 ? synced : closed;
        ::unlink(tmp.c_str());
        return Status::fromErrno(err, path + ": flush failed: " + std::strerror(err));
    }
    return {};
}

// The temporary file renamed over `path`, and the rename made durable.
Status renameInto(const std::string& tmp, const std::string& path, const std::string& dir) {
    if (::rename(tmp.c_str(), path.c_str()) != 0) {
        const int err = errno;
        ::unlink(tmp.c_str());
        return Status::fromErrno(err, path + ": rename failed: " + std::strerror(err));
    }
    const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
    if (dfd >= 0) {
        ::fsync(dfd);
        ::close(dfd);
    }
    return {};
}

} // namespace

unsigned fileModeFor(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) return st.st_mode & 0777;  // not setuid, setgid, sticky
    // The umask, read without changing it (umask(2) sets it, a race with
    // other threads creating files): /proc/self/status's "Umask:" line.
    std::ifstream f("/proc/self/status");
    for (std::string line; std::getline(f, line);)
        if (line.starts_with("Umask:")) return 0666u & ~(static_cast<unsigned>(std::strtoul(line.c_str() + 6, nullptr, 8)) & 0777u);
    return 0644u;  // a kernel before 4.7 shows no umask: the common 022
}

int makeTemporaryBeside(const std::string& target, std::string& dir, std::string& tmp) {
    const std::size_t slash = target.find_last_of('/');
    dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : target.substr(0, slash));
    const std::string base = slash == std::string::npos ? target : target.substr(slash + 1);
    tmp = dir + "/." + base + ".tmpXXXXXX";
    const int fd = ::mkstemp(tmp.data());
    if (fd >= 0) ::fchmod(fd, static_cast<mode_t>(fileModeFor(target)));  // mkstemp's 0600: the mode the file gets
    return fd;
}

Status linkTarget(const std::string& path, std::string& target) {
    std::string p = path;
    for (int hops = 0; hops < 40; ++hops) {
        struct stat st {};
        if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) {
            target = p;
            return {};
        }
        std::string to(static_cast<std::size_t>(st.st_size > 0 ? st.st_size : 255) + 1, '\0');
        const ssize_t n = ::readlink(p.c_str(), to.data(), to.size());
        if (n <= 0 || static_cast<std::size_t>(n) >= to.size()) {
            target = p;  // changed under us: the link itself, as before links were followed
            return {};
        }
        to.resize(static_cast<std::size_t>(n));
        const std::size_t slash = p.find_last_of('/');
        p = to.front() == '/' || slash == std::string::npos ? to : p.substr(0, slash + 1) + to;
    }
    return Status::fromErrno(ELOOP, path + ": too many levels of symbolic links");
}

Status writeFileAtomic(const std::string& path, std::string_view content) {
    if (isDeviceOrFifo(path)) {
        int fd = -1;
        if (Status st = openInPlace(path, fd); !st.ok()) return st;
        const Status st = writeThrough(fd, path, content);
        ::close(fd);
        return st;
    }
    std::string target;
    if (Status st = linkTarget(path, target); !st.ok()) return st;
    std::string dir, tmp;
    if (Status st = writeTemporary(target, content, dir, tmp); !st.ok()) return st;
    return renameInto(tmp, target, dir);
}

Status writeFilesAtomic(std::span<const FileToWrite> files) {
    struct Staged {
        const FileToWrite* file;
        std::string dir, tmp;  // tmp empty: a device or FIFO, opened now (fd) and written through at the end
        std::string target;    // the file replaced (linkTarget)
        int fd = -1;
    };
    std::vector<Staged> staged;
    staged.reserve(files.size());
    const auto dropTemporaries = [&] {
        for (const Staged& s : staged) {
            if (!s.tmp.empty()) ::unlink(s.tmp.c_str());
            if (s.fd >= 0) ::close(s.fd);
        }
    };
    for (const FileToWrite& f : files) {
        Staged s{&f, {}, {}, {}, -1};
        Status st = linkTarget(f.path, s.target);
        // A device or FIFO is opened before anything is renamed: one that cannot be (a FIFO
        // no process reads) leaves every file as it was.
        if (st.ok())
            st = isDeviceOrFifo(f.path) ? openInPlace(f.path, s.fd) : writeTemporary(s.target, f.content, s.dir, s.tmp);
        if (!st.ok()) {
            dropTemporaries();
            return st;
        }
        staged.push_back(std::move(s));
    }
    // Devices and FIFOs are written before anything is renamed, so one that
    // fails (a full device, a FIFO whose reader left: EPIPE, or SIGPIPE's
    // default end of the process) leaves every file as it was; they are
    // closed after, so their reader sees the end once the files are in place.
    for (const Staged& s : staged)
        if (s.fd >= 0)
            if (Status st = writeThrough(s.fd, s.file->path, s.file->content); !st.ok()) {
                dropTemporaries();
                return st;
            }
    Status result;
    for (Staged& s : staged) {
        if (s.tmp.empty()) continue;
        Status st = result.ok() ? renameInto(s.tmp, s.target, s.dir) : Status{};
        if (!result.ok()) ::unlink(s.tmp.c_str());  // after a failed rename: the rest stay as they were
        if (!st.ok()) result = st;
        s.tmp.clear();
    }
    for (Staged& s : staged)
        if (s.fd >= 0) ::close(s.fd);
    return result;
}

} // namespace rost::text
