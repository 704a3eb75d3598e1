#pragma once

// A fixed ring of preallocated slots between one producer thread and one
// consumer thread. The producer fills a slot in place (no copy through a
// temporary) and publishes it; the consumer reads it in place and releases
// it. No allocation after construction, no lock. Used by the tool to carry
// per-observation records from the engine's hooks (refiner thread) and
// frames from the capture thread to the writer.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "rost/aligned_buffer.hpp"  // kCacheLine

namespace rost::tool {

template <typename T>
class SpscRing {
public:
    // `slots` >= 1; `init` is called once per slot (sizing its buffers).
    template <typename Init>
    SpscRing(std::size_t slots, Init&& init) : slots_(slots) {
        for (auto& s : slots_) init(s);
    }
    SpscRing(const SpscRing&) = delete;
    SpscRing& operator=(const SpscRing&) = delete;

    std::size_t capacity() const noexcept { return slots_.size(); }

    // Producer: a free slot to fill, or nullptr when full.
    T* beginPush() noexcept {
        const uint64_t t = tail_.load(std::memory_order_relaxed);
        if (t - headCache_ >= slots_.size()) {
            headCache_ = head_.load(std::memory_order_acquire);
            if (t - headCache_ >= slots_.size()) return nullptr;
        }
        return &slots_[t % slots_.size()];
    }
    void commitPush() noexcept { tail_.store(tail_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

    // Consumer: the oldest published slot, or nullptr when empty.
    T* front() noexcept {
        const uint64_t h = head_.load(std::memory_order_relaxed);
        if (h == tailCache_) {
            tailCache_ = tail_.load(std::memory_order_acquire);
            if (h == tailCache_) return nullptr;
        }
        return &slots_[h % slots_.size()];
    }
    void pop() noexcept { head_.store(head_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

private:
    std::vector<T> slots_;
    alignas(kCacheLine) std::atomic<uint64_t> tail_{0};  // written by the producer
    uint64_t headCache_ = 0;                             // producer's copy of head_
    alignas(kCacheLine) std::atomic<uint64_t> head_{0};  // written by the consumer
    uint64_t tailCache_ = 0;                             // consumer's copy of tail_
};

} // namespace rost::tool
