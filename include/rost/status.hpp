#pragma once

#include <string>
#include <utility>

namespace rost {

// Result of a set-up call (configuration, loading, opening a source). Empty
// message means success. Set-up code may allocate; realtime calls return
// small enums instead (see model.hpp). [[nodiscard]]: a Status must be looked
// at; where ignoring one is right, say so with a (void) cast and a comment.
class [[nodiscard]] Status {
public:
    Status() = default;
    static Status error(std::string message) { return Status(std::move(message)); }

    [[nodiscard]] bool ok() const noexcept { return message_.empty(); }
    [[nodiscard]] const std::string& message() const noexcept { return message_; }

private:
    explicit Status(std::string message) : message_(std::move(message)) {}
    std::string message_;
};

} // namespace rost
