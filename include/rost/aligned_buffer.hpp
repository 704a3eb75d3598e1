#pragma once

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <new>

namespace rost {

// Cache-line constant pinned here rather than taken from
// std::hardware_destructive_interference_size, which differs between targets
// and compilers and would change struct layouts across architectures.
inline constexpr std::size_t kCacheLine = 64;

// A fixed-size, zero-initialised, cache-line-aligned array. Allocates once in
// its constructor (set-up time) and never again; not copyable.
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

    void reset(std::size_t n) {
        std::free(data_);
        data_ = nullptr;
        size_ = 0;
        if (n == 0) return;
        std::size_t bytes = (n * sizeof(T) + kCacheLine - 1) / kCacheLine * kCacheLine;
        void* p = std::aligned_alloc(kCacheLine, bytes);
        if (p == nullptr) throw std::bad_alloc();
        std::memset(p, 0, bytes);
        data_ = static_cast<T*>(p);
        size_ = n;
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
    T* data_ = nullptr;
    std::size_t size_ = 0;
};

} // namespace rost
