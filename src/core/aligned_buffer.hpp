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

namespace rost {

// Buffers of at least this size are aligned to it and, on Linux, asked for
// transparent huge pages: the ring's tables are touched once at set-up (one
// fault per 2 MiB instead of per 4 KiB) and refinement's random reads across
// them miss the TLB less. Where huge pages are off this changes nothing.
inline constexpr std::size_t kHugePage = std::size_t{2} << 20;

// Large buffers come straight from the kernel (an anonymous mapping, aligned
// to kHugePage, asked for huge pages): their pages are zero before they are
// touched, so setting them up is faulting them in, which one madvise call
// (MADV_POPULATE_WRITE, Linux 5.14) does for a whole range, without the
// fault taken per page by a memset and without writing the zeros twice.
// `bytes` is a multiple of kHugePage; throws std::bad_alloc. Where there is
// no such mapping (not Linux) it returns null and the caller allocates.
// (malloc does not count these: bench/footprint adds mappedBytes(), the bytes
// mapped now; LeakSanitizer does not see them either.)
void* mapZeroed(std::size_t bytes);
void unmapZeroed(void* p, std::size_t bytes) noexcept;
std::size_t mappedBytes() noexcept;
// Faults in [p, p + bytes) of such a mapping, writable (its pages stay
// zero); false where the kernel cannot (older kernels) or did not (an
// emulator that ignores the advice), and then the caller touches the pages.
bool populateZeroed(void* p, std::size_t bytes) noexcept;

// Buffers zeroed together at set-up (a model's ring tables): run() zeroes
// every range added on `threads` threads, which claim 2 MiB pieces of all of
// them in turn, so no thread waits while another faults its part in.
class PageZeroer {
public:
    // `mapped`: the range is (part of) a fresh mapZeroed() mapping, already
    // zero: run() faults its pages in and writes nothing.
    void add(void* p, std::size_t bytes, bool mapped = false);
    void run(int threads);  // then forgets the ranges
    std::size_t bytes() const noexcept { return total_; }

private:
    struct Range {
        unsigned char* p;
        std::size_t bytes;
        bool mapped;
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
    ~AlignedBuffer() { release(); }
    AlignedBuffer(const AlignedBuffer&) = delete;
    AlignedBuffer& operator=(const AlignedBuffer&) = delete;
    AlignedBuffer(AlignedBuffer&& o) noexcept : data_(o.data_), size_(o.size_), mapped_(o.mapped_) {
        o.data_ = nullptr;
        o.size_ = 0;
        o.mapped_ = 0;
    }
    AlignedBuffer& operator=(AlignedBuffer&& o) noexcept {
        if (this != &o) {
            release();
            data_ = o.data_;
            size_ = o.size_;
            mapped_ = o.mapped_;
            o.data_ = nullptr;
            o.size_ = 0;
            o.mapped_ = 0;
        }
        return *this;
    }

    // `threads`: how many threads touch (zero) a large buffer at set-up.
    void reset(std::size_t n, int threads = 1) {
        PageZeroer z;
        reset(n, z);
        z.run(threads);  // every page is touched now, at set-up
    }
    // Allocates and leaves the zeroing to `zeroer`: the buffer must not be
    // used before zeroer.run(), which zeroes it with the others added (a
    // mapped buffer is zero already: run() only faults its pages in).
    void reset(std::size_t n, PageZeroer& zeroer) {
        allocate(n);
        zeroer.add(data_, bytes(), mapped_ != 0);
    }
    // The buffer is a mapping of its own (mapZeroed), not heap memory.
    bool mapped() const noexcept { return mapped_ != 0; }

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
    void release() noexcept {
        if (mapped_ != 0)
            unmapZeroed(data_, mapped_);
        else
            std::free(data_);
        data_ = nullptr;
        size_ = 0;
        mapped_ = 0;
    }
    void allocate(std::size_t n) {
        release();
        if (n == 0) return;
        std::size_t bytes = (n * sizeof(T) + kCacheLine - 1) / kCacheLine * kCacheLine;
        const std::size_t align = bytes >= kHugePage ? kHugePage : kCacheLine;
        const std::size_t whole = (bytes + align - 1) / align * align;
        void* p = align == kHugePage ? mapZeroed(whole) : nullptr;
        if (p != nullptr) {
            mapped_ = whole;
        } else {
            p = std::aligned_alloc(align, whole);
            if (p == nullptr) throw std::bad_alloc();
        }
        data_ = static_cast<T*>(p);
        size_ = n;
    }

    T* data_ = nullptr;
    std::size_t size_ = 0;
    std::size_t mapped_ = 0;  // the mapping's length, 0 for heap memory
};

} // namespace rost
