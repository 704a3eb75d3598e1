// Set-up time memory: zeroing (and so faulting in) a large buffer on several threads.

#include <algorithm>
#include <cstring>
#include <system_error>
#include <thread>
#include <vector>

#include "rost/aligned_buffer.hpp"

namespace rost {

namespace {
// Below this a thread costs more than it saves.
constexpr std::size_t kParallelZeroBytes = std::size_t{8} << 20;
} // namespace

void zeroPages(void* p, std::size_t bytes, int threads) {
    if (threads <= 1 || bytes < kParallelZeroBytes) {
        std::memset(p, 0, bytes);
        return;
    }
    auto* base = static_cast<unsigned char*>(p);
    const std::size_t pages = (bytes + kHugePage - 1) / kHugePage;
    const auto n = static_cast<std::size_t>(std::min<std::size_t>(static_cast<std::size_t>(threads), pages));
    const auto part = [&](std::size_t i) {
        const std::size_t b = std::min(bytes, pages * i / n * kHugePage);
        const std::size_t e = std::min(bytes, pages * (i + 1) / n * kHugePage);
        std::memset(base + b, 0, e - b);
    };
    std::vector<std::jthread> helpers;
    helpers.reserve(n - 1);
    try {
        for (std::size_t i = 1; i < n; ++i) helpers.emplace_back(part, i);
    } catch (const std::system_error&) {
        // No thread to be had: the parts not started are zeroed here.
        for (std::size_t i = helpers.size() + 1; i < n; ++i) part(i);
    }
    part(0);
}

} // namespace rost
