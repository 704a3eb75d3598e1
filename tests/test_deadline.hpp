#pragma once

// A deadline for code that may hang (a pool job whose count never
// completes, a drawing loop that never ends): the test fails at once and
// says what did not end, instead of waiting for ctest's limit.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <utility>

#include <gtest/gtest.h>

namespace rost::testing {

// Runs `fn` on a thread of its own and waits for it at most `limit`: true
// when it ended in time. A thread that does not end is left running
// (detached), so the caller should then endTheRun(); `fn` may capture by
// reference only where it does.
template <typename Fn>
bool endsWithin(std::chrono::milliseconds limit, Fn fn) {
    auto done = std::make_shared<std::promise<void>>();
    std::future<void> ended = done->get_future();
    std::thread([fn = std::move(fn), done]() mutable {
        fn();
        done->set_value();
    }).detach();
    return ended.wait_for(limit) == std::future_status::ready;
}

// Fails the test with `what` and ends the test binary: a thread still runs
// what did not end, and the rest of the binary cannot be trusted to.
[[noreturn]] inline void endTheRun(const std::string& what) {
    ADD_FAILURE() << what;
    std::fprintf(stderr, "%s: ending the test binary\n", what.c_str());
    std::fflush(nullptr);
    std::_Exit(1);
}

} // namespace rost::testing
