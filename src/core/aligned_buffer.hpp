#pragma once

// Cache-line (or huge-page) aligned, zeroed buffers for a model's tables
// and the engine's queue: internal to the library (no installed header holds
// one; the public Model keeps its tables behind its implementation).

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <new>
#include <vector>

#include "rost/cache_line.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace rost {

// Buffers of at least this size are aligned to it and, on Linux, asked for
// transparent huge pages: the ring's tables are touched once at set-up (one
// fault per 2 MiB instead of per 4 KiB) and refinement's random reads across
// them miss the TLB less. Where huge pages are off this changes nothing.
inline constexpr std::size_t kHugePage = std::size_t{2} << 20;

// Zeroes `bytes` at `p` (set-up code). With `threads` > 1 a large buffer is
// cut at 2 MiB boundaries and zeroed by that many threads at once: the
// first touch of a page makes the kernel clear it, which for the tens of
// MiB of a ring is most of a model's set-up time (src/core/memory.cpp).
void zeroPages(void* p, std::size_t bytes, int threads);

// Buffers zeroed together at set-up (a model's ring tables): run() zeroes
// every range added on `threads` threads, which claim 2 MiB pieces of all of
// them in turn, so no thread waits while another faults its part in.
class PageZeroer {
public:
    void add(void* p, std::size_t bytes);
    void run(int threads);  // then forgets the ranges
    std::size_t bytes() const noexcept { return total_; }

private:
    struct Range {
        unsigned char* p;
        std::size_t bytes;
    };
    std::vector<Range> ranges_;
    std::size_t total_ = 0;
};

// A fixed-size, zero-initialised, cache-line-aligned array. Allocates once in
// its constructor or reset() (set-up time) and never again; not copyable.
// reset(n, zeroer) leaves the zeroing to the zeroer's run().
template <typename T>
class AlignedBuffer {
public:
    AlignedBuffer() = default;
    explicit AlignedBuffer(std::size_t n) { reset(n); }
    ~AlignedBuffer() { std::free(data_); }
    AlignedBuffer(const AlignedBuffer&) = delete;
    AlignedBuffer& operator=(const AlignedBuffer&) = delete;
    AlignedBuffer(AlignedBuffer&& o) noexcept : data_(o.data_), size_(o.size_) {
        o.data_ = nullptr;
        o.size_ = 0;
    }
    AlignedBuffer& operator=(AlignedBuffer&& o) noexcept {
        if (this != &o) {
            std::free(data_);
            data_ = o.data_;
            size_ = o.size_;
            o.data_ = nullptr;
            o.size_ = 0;
        }
        return *this;
    }

    // `threads`: how many threads touch (zero) a large buffer at set-up.
    void reset(std::size_t n, int threads = 1) {
        allocate(n);
        zeroPages(data_, bytes(), threads);  // every page is touched now, at set-up
    }
    // Allocates and leaves the zeroing to `zeroer`: the buffer must not be
    // used before zeroer.run(), which zeroes it with the others added.
    void reset(std::size_t n, PageZeroer& zeroer) {
        allocate(n);
        zeroer.add(data_, bytes());
    }

    T* data() noexcept { return data_; }
    const T* data() const noexcept { return data_; }
    std::size_t size() const noexcept { return size_; }
    std::size_t bytes() const noexcept { return (size_ * sizeof(T) + kCacheLine - 1) / kCacheLine * kCacheLine; }
    T& operator[](std::size_t i) noexcept { return data_[i]; }
    const T& operator[](std::size_t i) const noexcept { return data_[i]; }
    void zero() noexcept {
        if (data_) std::memset(static_cast<void*>(data_), 0, bytes());
    }

private:
    void allocate(std::size_t n) {
        std::free(data_);
        data_ = nullptr;
        size_ = 0;
        if (n == 0) return;
        std::size_t bytes = (n * sizeof(T) + kCacheLine - 1) / kCacheLine * kCacheLine;
        const std::size_t align = bytes >= kHugePage ? kHugePage : kCacheLine;
        void* p = std::aligned_alloc(align, (bytes + align - 1) / align * align);
        if (p == nullptr) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        if (align == kHugePage) (void)madvise(p, (bytes + align - 1) / align * align, MADV_HUGEPAGE);
#endif
        data_ = static_cast<T*>(p);
        size_ = n;
    }

    T* data_ = nullptr;
    std::size_t size_ = 0;
};

} // namespace rost
