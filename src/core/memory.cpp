// Set-up time memory: zeroing (and so faulting in) large buffers on several threads.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <system_error>
#include <thread>
#include <vector>

#include "aligned_buffer.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace rost {

namespace {
// Below this in all a thread costs more than it saves.
constexpr std::size_t kParallelZeroBytes = std::size_t{4} << 20;
} // namespace

namespace {
std::atomic<std::size_t> g_mapped{0};  // bytes in mapZeroed() mappings (mappedBytes())
} // namespace

std::size_t mappedBytes() noexcept { return g_mapped.load(std::memory_order_relaxed); }

void* mapZeroed(std::size_t bytes) {
#if defined(__linux__)
    // One alignment more than asked, then the ends cut off: the kernel
    // aligns a mapping to its page, not to a huge page.
    const std::size_t len = bytes + kHugePage;
    void* m = ::mmap(nullptr, len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (m == MAP_FAILED) throw std::bad_alloc();
    auto* base = static_cast<unsigned char*>(m);
    const auto at = reinterpret_cast<std::uintptr_t>(base);
    unsigned char* p = base + ((kHugePage - at % kHugePage) % kHugePage);
    if (p != base) ::munmap(base, static_cast<std::size_t>(p - base));
    if (const std::size_t tail = static_cast<std::size_t>(base + len - (p + bytes)); tail != 0) ::munmap(p + bytes, tail);
#if defined(MADV_HUGEPAGE)
    (void)::madvise(p, bytes, MADV_HUGEPAGE);  // where huge pages are off, nothing changes
#endif
    g_mapped.fetch_add(bytes, std::memory_order_relaxed);
    return p;
#else
    (void)bytes;
    return nullptr;
#endif
}

void unmapZeroed(void* p, std::size_t bytes) noexcept {
#if defined(__linux__)
    if (p == nullptr) return;
    ::munmap(p, bytes);
    g_mapped.fetch_sub(bytes, std::memory_order_relaxed);
#else
    (void)p;
    (void)bytes;
#endif
}

bool populateZeroed(void* p, std::size_t bytes) noexcept {
#if defined(__linux__)
#ifndef MADV_POPULATE_WRITE
    constexpr int MADV_POPULATE_WRITE = 23;  // Linux 5.14's value; older headers lack it
#endif
    if (bytes == 0) return true;
    if (::madvise(p, bytes, MADV_POPULATE_WRITE) != 0) return false;
    // An emulator (qemu-user) may take the advice and do nothing: the range's
    // first and last pages say whether it was done.
    const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    auto* last = static_cast<unsigned char*>(p) + (bytes - 1) / page * page;
    unsigned char in[2] = {0, 0};
    return ::mincore(p, 1, &in[0]) == 0 && ::mincore(last, 1, &in[1]) == 0 && (in[0] & in[1] & 1) != 0;
#else
    (void)p;
    (void)bytes;
    return false;
#endif
}

void PageZeroer::add(void* p, std::size_t bytes, bool mapped) {
    if (bytes == 0) return;
    ranges_.push_back({static_cast<unsigned char*>(p), bytes, mapped});
    total_ += bytes;
}

namespace {
// Zeroes n bytes at p or, in a fresh mapping, faults them in. A mapped
// piece starts on a huge page (madvise wants a page-aligned start, and rounds
// the length up to whole pages, inside the same mapping).
void clearPiece(unsigned char* p, std::size_t n, bool mapped) {
    if (mapped && populateZeroed(p, n)) return;
    std::memset(p, 0, n);
}
} // namespace

void PageZeroer::run(int threads) {
    if (threads <= 1 || total_ < kParallelZeroBytes) {
        for (const Range& r : ranges_) clearPiece(r.p, r.bytes, r.mapped);
    } else {
        // The ranges are cut into pieces of one huge page (2 MiB-aligned
        // buffers: at page boundaries) and the threads claim the pieces in
        // turn. A static split left one thread idle whenever its part faulted
        // faster than the other's (memory the process had touched before, a
        // huge page to be had or not), and buffers too small to split on
        // their own were zeroed by one thread while the others waited.
        std::vector<std::size_t> first(ranges_.size() + 1, 0);  // each range's first piece
        for (std::size_t i = 0; i < ranges_.size(); ++i)
            first[i + 1] = first[i] + (ranges_[i].bytes + kHugePage - 1) / kHugePage;
        const std::size_t pieces = first.back();
        std::atomic<std::size_t> next{0};
        const auto work = [&] {
            std::size_t r = 0;
            for (std::size_t k = next.fetch_add(1, std::memory_order_relaxed); k < pieces;
                 k = next.fetch_add(1, std::memory_order_relaxed)) {
                while (first[r + 1] <= k) ++r;  // pieces are claimed in increasing order
                const std::size_t b = (k - first[r]) * kHugePage;
                clearPiece(ranges_[r].p + b, std::min(kHugePage, ranges_[r].bytes - b), ranges_[r].mapped);
            }
        };
        const auto n = std::min(static_cast<std::size_t>(threads), pieces);
        std::vector<std::jthread> helpers;
        helpers.reserve(n - 1);
        try {
            for (std::size_t i = 1; i < n; ++i) helpers.emplace_back(work);
        } catch (const std::system_error&) {
            // No more threads to be had: those started and this one share the pieces.
        }
        work();
    }  // the helpers are joined here, before the ranges are forgotten
    ranges_.clear();
    total_ = 0;
}

} // namespace rost
