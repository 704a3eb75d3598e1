#pragma once

#include <cerrno>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

namespace rost {

// What a failed set-up call's error is about, so that a face can say it in
// its own terms (Python: FileNotFoundError, PermissionError, ...: as open()
// raises them) without looking at the file again itself. Most errors are
// Invalid: input or settings the library refuses.
enum class StatusKind : uint8_t {
    Invalid,           // bad content, a setting out of range, ...: not the system's refusal
    NotFound,          // a file or directory to read (or to write into) is not there
    PermissionDenied,  // it is there and may not be read (or written)
    IsADirectory,      // a directory where a file was expected
    NotADirectory,     // a file where a directory was expected: "words.csv/x"
    OsError,           // another refusal of the system: a loop of links, a name too long, an I/O error
    OutOfMemory,       // valid settings this machine cannot hold (tables, a checkpoint's state)
};

// Result of a set-up call (configuration, loading, opening a source). Empty
// message means success. Set-up code may allocate; realtime calls return
// small enums instead (see model.hpp). [[nodiscard]]: a Status must be looked
// at; where ignoring one is right, say so with a (void) cast and a comment.
class [[nodiscard]] Status {
public:
    Status() = default;
    static Status error(std::string message) { return Status(StatusKind::Invalid, std::move(message)); }
    static Status error(StatusKind kind, std::string message) { return Status(kind, std::move(message)); }
    // A failed system call's errno as a kind: ENOENT NotFound, EACCES and
    // EPERM PermissionDenied, EISDIR IsADirectory, ENOTDIR NotADirectory,
    // any other OsError.
    static Status fromErrno(int err, std::string message) {
        const StatusKind kind = err == ENOENT                   ? StatusKind::NotFound
                                : err == EACCES || err == EPERM ? StatusKind::PermissionDenied
                                : err == EISDIR                 ? StatusKind::IsADirectory
                                : err == ENOTDIR                ? StatusKind::NotADirectory
                                                                : StatusKind::OsError;
        return Status(kind, std::move(message));
    }

    [[nodiscard]] bool ok() const noexcept { return message_.empty(); }
    [[nodiscard]] const std::string& message() const noexcept { return message_; }
    [[nodiscard]] StatusKind kind() const noexcept { return kind_; }

    // The same error with `prefix` before its message (a caller naming what
    // it was doing: "--resume: "), its kind kept. An ok Status stays ok.
    [[nodiscard]] Status prefixed(std::string_view prefix) const {
        if (ok()) return {};
        return Status(kind_, std::string(prefix) + message_);
    }

private:
    Status(StatusKind kind, std::string message) : message_(std::move(message)), kind_(kind) {}
    std::string message_;
    StatusKind kind_ = StatusKind::Invalid;
};

} // namespace rost
