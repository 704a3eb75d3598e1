#pragma once

// The library's one single-producer single-consumer ring (internal, not
// installed): the engine's ObservationQueue, the rost tool's record and frame
// rings, rost-cli's --online record rings and the libcamera source's
// completed-request ring are built on it.
//
// Protocol. Two monotone 64-bit counters, each on its own cache line:
//   published_  slots the producer has filled (written by the producer only)
//   released_   slots the consumer is done with (written by the consumer;
//               SpscIndices::advanceReleased lets the producer discard too)
// Slot i lives at index i % capacity. The producer may write slot i while
// i - released < capacity, and makes it visible by storing published = i + 1
// with release order; the consumer may read slot i while i < published, which
// it loads with acquire order, so it sees everything the producer wrote into
// the slot. Symmetrically the consumer stores released = i + 1 with release
// order after its last read of slot i, and the producer loads it with acquire
// order before writing into that slot again. Each side keeps a private copy
// of the other side's counter and reloads it only when the copy says full
// (producer) or empty (consumer), so in steady state neither side touches
// the other's cache line. 64-bit counters never wrap in practice.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rost {

// Cache-line size used to separate the two sides (pinned rather than taken
// from std::hardware_destructive_interference_size, which differs between
// targets and compilers and would change layouts across architectures).
inline constexpr std::size_t kRingCacheLine = 64;

// The counters and the index arithmetic, without the slots.
class SpscIndices {
public:
    explicit SpscIndices(uint64_t capacity) noexcept : capacity_(capacity) {}
    SpscIndices(const SpscIndices&) = delete;
    SpscIndices& operator=(const SpscIndices&) = delete;

    uint64_t capacity() const noexcept { return capacity_; }
    std::size_t slot(uint64_t i) const noexcept { return static_cast<std::size_t>(i % capacity_); }

    // ---- producer ----------------------------------------------------------
    // The index of the next slot to fill.
    uint64_t next() const noexcept { return p_.published; }
    // Slot next() is free (reloads released_ only when the cached copy says full).
    bool hasSpace() noexcept {
        const uint64_t t = p_.published;
        if (t - p_.released < capacity_) return true;
        p_.released = released_.load(std::memory_order_acquire);
        return t - p_.released < capacity_;
    }
    // The producer's copy of released_ as of its last reload.
    uint64_t releasedSeen() const noexcept { return p_.released; }
    // Makes slot next() visible to the consumer.
    void publish() noexcept {
        p_.published += 1;
        published_.store(p_.published, std::memory_order_release);
    }
    // Producer-side discard: raises released_ to at least `to` (monotone
    // maximum, the consumer may already have released a later slot). The
    // caller's own protocol must ensure the consumer is not reading the
    // slots it discards. Acquire: a release by the consumer seen here orders
    // its reads of that slot before the producer's next write into it.
    void advanceReleased(uint64_t to) noexcept {
        uint64_t cur = released_.load(std::memory_order_acquire);
        while (cur < to &&
               !released_.compare_exchange_weak(cur, to, std::memory_order_acq_rel, std::memory_order_acquire)) {
        }
        p_.released = std::max(cur, to);
    }

    // ---- consumer ----------------------------------------------------------
    // Slot i has been published (reloads published_ only when the cached copy says empty).
    bool available(uint64_t i) noexcept {
        if (i < c_.published) return true;
        c_.published = published_.load(std::memory_order_acquire);
        return i < c_.published;
    }
    // The consumer is done with every slot before `upto`.
    void release(uint64_t upto) noexcept { released_.store(upto, std::memory_order_release); }

    // ---- any thread (monitoring) ---------------------------------------------
    uint64_t published() const noexcept { return published_.load(std::memory_order_acquire); }

private:
    const uint64_t capacity_;
    alignas(kRingCacheLine) std::atomic<uint64_t> published_{0};
    alignas(kRingCacheLine) std::atomic<uint64_t> released_{0};
    // Lock-free is the ring's promise: a target without 64-bit atomics (armv6) fails here, by name.
    static_assert(std::atomic<uint64_t>::is_always_lock_free, "the SPSC ring needs lock-free 64-bit atomics");
    struct alignas(kRingCacheLine) ProducerSide {
        uint64_t published = 0;  // the producer's own count (== published_)
        uint64_t released = 0;   // its copy of released_
    } p_;
    struct alignas(kRingCacheLine) ConsumerSide {
        uint64_t published = 0;  // the consumer's copy of published_
    } c_;
};

// A ring of preallocated slots on SpscIndices. The producer fills a slot in
// place (no copy through a temporary) and publishes it; the consumer reads it
// in place and pops it. No allocation after construction, no lock.
template <typename T>
class SpscRing {
public:
    // `slots` >= 1; `init` is called once per slot (sizing its buffers).
    template <typename Init>
    SpscRing(std::size_t slots, Init&& init) : slots_(slots), idx_(slots) {
        for (auto& s : slots_) init(s);
    }
    explicit SpscRing(std::size_t slots) : slots_(slots), idx_(slots) {}
    SpscRing(const SpscRing&) = delete;
    SpscRing& operator=(const SpscRing&) = delete;

    std::size_t capacity() const noexcept { return slots_.size(); }

    // Producer: a free slot to fill, or nullptr when full.
    T* beginPush() noexcept { return idx_.hasSpace() ? &slots_[idx_.slot(idx_.next())] : nullptr; }
    // Producer: publishes the slot beginPush() returned.
    void commitPush() noexcept { idx_.publish(); }

    // Consumer: the oldest published slot, or nullptr when empty.
    T* front() noexcept { return idx_.available(head_) ? &slots_[idx_.slot(head_)] : nullptr; }
    // Consumer: gives the slot front() returned back to the producer.
    void pop() noexcept {
        head_ += 1;
        idx_.release(head_);
    }

private:
    std::vector<T> slots_;
    SpscIndices idx_;
    uint64_t head_ = 0;  // consumer-private: the next slot to read (== released)
};

} // namespace rost
