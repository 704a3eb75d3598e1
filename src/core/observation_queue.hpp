#pragma once

// Single-producer single-consumer queue of preallocated observation slots
// (words, positions, time stamp, count), between the capture thread and the
// refiner. All memory is allocated in the constructor. Internal to the
// library (engine.hpp only forward-declares it).
//
// Built on the library's SPSC ring indices (spsc_ring.hpp), which hold two of
// its three monotone 64-bit counters, each on its own cache line:
//   published  observations published (written by the producer only)
//   released   observations whose slot may be reused (the consumer after it
//              has finished reading a slot; the producer after discarding one)
// and adds a third, on its own cache line:
//   head_      observations taken up by the consumer or discarded by the
//              producer (advanced by compare-exchange from either side)
// Each side caches the other side's index and reloads it only when the
// cached value says full (producer) or empty (consumer).
//
// Dropping the oldest observation from the producer side is safe because the
// consumer *claims* an observation (compare-exchange on head_) before it reads
// the slot, and releases it afterwards. The producer discards only when the
// consumer holds no claim (head_ == released), by a single compare-exchange
// of head_ from that value: if the consumer claims the observation first,
// the exchange fails and the producer drops the new observation instead. A
// discarded observation's slot is the very slot the new one goes into, so the
// consumer can never be reading it. See docs/engine.md.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "aligned_buffer.hpp"
#include "model_core.hpp"
#include "rost/random.hpp"
#include "spsc_ring.hpp"

namespace rost {

class ObservationQueue {
public:
    enum class Push : uint8_t {
        Queued,              // published, nothing lost
        QueuedDroppedOldest, // published; the oldest waiting observation was discarded
        Dropped,             // queue full: this observation was not queued
    };

    // A claimed observation: valid until release().
    struct Item {
        uint64_t sequence = 0;   // producer's push count when it was pushed
        int64_t timestamp = 0;
        uint32_t size = 0;       // words (and positions) in the slot
        bool size_mismatch = false;  // words and positions had different lengths
        uint32_t mismatch_index = 0; // the shorter length, when size_mismatch
        uint32_t truncated = 0;      // words subsampled away at push (counted in wordsTruncated())
        const uint32_t* words = nullptr;
        const Position* positions = nullptr;
    };

    // `slots` observations of up to `max_words` words each. Observations
    // with more words are uniformly subsampled on push, seeded by `seed` and
    // the sequence number, so the same stream gives the same words.
    ObservationQueue(uint32_t slots, uint32_t max_words, uint64_t seed)
        : n_(slots), maxw_(max_words), seed_(seed), ring_(slots), words_(static_cast<std::size_t>(slots) * max_words),
          positions_(static_cast<std::size_t>(slots) * max_words), meta_(slots) {}

    ObservationQueue(const ObservationQueue&) = delete;
    ObservationQueue& operator=(const ObservationQueue&) = delete;

    uint32_t slots() const noexcept { return n_; }
    uint32_t maxWords() const noexcept { return maxw_; }
    std::size_t memoryBytes() const noexcept {
        return words_.bytes() + positions_.bytes() + meta_.bytes() + sizeof(*this);
    }

    // ---- producer ----------------------------------------------------------
    // Never blocks or allocates. `drop_oldest` selects the full-queue policy.
    Push tryPush(int64_t timestamp, std::span<const uint32_t> words, std::span<const Position> positions,
                 bool drop_oldest) noexcept {
        const uint64_t seq = p_.pushed.load(std::memory_order_relaxed);
        p_.pushed.store(seq + 1, std::memory_order_relaxed);
        const uint64_t t = ring_.next();
        Push result = Push::Queued;
        if (!ring_.hasSpace()) {
            if (!drop_oldest || !discardOldest(t)) {
                p_.dropped_newest.store(p_.dropped_newest.load(std::memory_order_relaxed) + 1,
                                        std::memory_order_relaxed);
                return Push::Dropped;
            }
            result = Push::QueuedDroppedOldest;
        }
        write(ring_.slot(t), seq, timestamp, words, positions);
        ring_.publish();  // release: the slot's contents before the new count
        return result;
    }

    // Producer side: a slot is free now (a push would not drop).
    bool hasSpace() noexcept { return ring_.hasSpace(); }

    // ---- consumer ----------------------------------------------------------
    // Claims the oldest published observation; false when there is none.
    bool claim(Item& out) noexcept {
        uint64_t h = head_.load(std::memory_order_acquire);
        for (;;) {
            if (!ring_.available(h)) return false;  // acquire: the slot's contents are visible
            // Fails only when the producer discarded observation h meanwhile.
            if (head_.compare_exchange_weak(h, h + 1, std::memory_order_acq_rel, std::memory_order_acquire)) break;
        }
        c_.claimed = h;
        const std::size_t s = ring_.slot(h);
        const Meta& m = meta_[s];
        out.sequence = m.sequence;
        out.timestamp = m.timestamp;
        out.size = m.size;
        out.size_mismatch = m.mismatch != 0;
        out.mismatch_index = m.mismatch_index;
        out.truncated = m.truncated;
        out.words = words_.data() + s * maxw_;
        out.positions = positions_.data() + s * maxw_;
        return true;
    }
    // Gives the claimed slot back to the producer.
    void release() noexcept { ring_.release(c_.claimed + 1); }
    // Consumer side: something is published and not yet claimed.
    bool pending() noexcept {
        return ring_.available(head_.load(std::memory_order_acquire));
    }

    // ---- any thread (monitoring) -------------------------------------------
    uint32_t size() const noexcept {
        const uint64_t t = ring_.published();
        const uint64_t h = head_.load(std::memory_order_acquire);
        return t > h ? static_cast<uint32_t>(t - h) : 0u;
    }
    uint64_t pushed() const noexcept { return p_.pushed.load(std::memory_order_relaxed); }
    uint64_t droppedNewest() const noexcept { return p_.dropped_newest.load(std::memory_order_relaxed); }
    uint64_t droppedOldest() const noexcept { return p_.dropped_oldest.load(std::memory_order_relaxed); }
    uint64_t wordsTruncated() const noexcept { return p_.words_truncated.load(std::memory_order_relaxed); }

    // Checkpoint restore (set-up: no producer or consumer running, queue
    // empty): the next push gets sequence number `next_sequence` and the
    // loss counters resume from the given values.
    void restoreProducer(uint64_t next_sequence, uint64_t dropped_newest, uint64_t dropped_oldest,
                         uint64_t words_truncated) noexcept {
        p_.pushed.store(next_sequence, std::memory_order_relaxed);
        p_.dropped_newest.store(dropped_newest, std::memory_order_relaxed);
        p_.dropped_oldest.store(dropped_oldest, std::memory_order_relaxed);
        p_.words_truncated.store(words_truncated, std::memory_order_relaxed);
    }

private:
    struct Meta {
        uint64_t sequence;
        int64_t timestamp;
        uint32_t size;
        uint32_t mismatch;
        uint32_t mismatch_index;
        uint32_t truncated;
    };

    // Full queue, DropOldest: discard observation `released` if the consumer
    // holds no claim on it. Its slot is t % n_, where the new one goes.
    bool discardOldest(uint64_t t) noexcept {
        const uint64_t r = ring_.releasedSeen();
        uint64_t h = head_.load(std::memory_order_acquire);
        if (h != r || h >= t) return false;  // the consumer is reading observation r
        if (!head_.compare_exchange_strong(h, r + 1, std::memory_order_acq_rel, std::memory_order_acquire))
            return false;  // the consumer claimed it first
        // Advance released past the discarded observation (monotone maximum:
        // the consumer may already have released a later one; acquire orders
        // the consumer's reads of that slot before the producer's next write).
        ring_.advanceReleased(r + 1);
        p_.dropped_oldest.store(p_.dropped_oldest.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
        return true;
    }

    void write(std::size_t s, uint64_t seq, int64_t timestamp, std::span<const uint32_t> words,
               std::span<const Position> positions) noexcept {
        Meta& m = meta_[s];
        m.sequence = seq;
        m.timestamp = timestamp;
        const AddResult sizes = checkObservationSizes(words.size(), positions.size());  // shared with Model
        m.mismatch = sizes.ok() ? 0u : 1u;
        m.mismatch_index = sizes.index;
        const std::size_t n = words.size();
        m.truncated = 0;
        uint32_t* w = words_.data() + s * maxw_;
        Position* p = positions_.data() + s * maxw_;
        if (m.mismatch) {
            m.size = 0;
            return;
        }
        if (n <= maxw_) {
            if (n > 0) {  // an empty span's data() may be null, which memcpy must not get
                std::memcpy(w, words.data(), n * sizeof(uint32_t));
                std::memcpy(static_cast<void*>(p), positions.data(), n * sizeof(Position));
            }
            m.size = static_cast<uint32_t>(n);
            return;
        }
        // Uniform subsample of maxw_ of the n words, in input order
        // (selection sampling, as Model::addObservation), seeded by the sequence number.
        Rng rng(seed_ ^ (seq * 0x9E3779B97F4A7C15ull));
        uint32_t j = 0;
        selectUniform(n, maxw_, rng, [&](std::size_t i) {
            w[j] = words[i];
            p[j] = positions[i];
            ++j;
        });
        m.size = j;
        m.truncated = static_cast<uint32_t>(std::min<std::size_t>(n - j, UINT32_MAX));
        p_.words_truncated.store(p_.words_truncated.load(std::memory_order_relaxed) + (n - j),
                                 std::memory_order_relaxed);
    }

    const uint32_t n_;
    const uint32_t maxw_;
    const uint64_t seed_;
    SpscIndices ring_;  // published and released, the producer's and consumer's cached copies
    AlignedBuffer<uint32_t> words_;
    AlignedBuffer<Position> positions_;
    AlignedBuffer<Meta> meta_;

    alignas(kCacheLine) std::atomic<uint64_t> head_{0};
    // Producer-written counters.
    struct alignas(kCacheLine) ProducerSide {
        std::atomic<uint64_t> pushed{0};
        std::atomic<uint64_t> dropped_newest{0};
        std::atomic<uint64_t> dropped_oldest{0};
        std::atomic<uint64_t> words_truncated{0};
    } p_;
    // Consumer-private state.
    struct alignas(kCacheLine) ConsumerSide {
        uint64_t claimed = 0;
    } c_;
};

} // namespace rost
