#pragma once

// What readers see of the engine: the newest observation's results and the
// engine's counters, copied out of a lock-free double-buffered seqlock (see
// SnapshotPublisher below and docs/engine.md for why a seqlock).

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "rost/cache_line.hpp"
#include "rost/config.hpp"
#include "rost/model.hpp"

namespace rost {

// Counters of an engine since construction. Producer-side fields are written
// by the producer, the rest by the refiner; each is monotone.
struct EngineCounters {
    // producer side
    uint64_t pushed = 0;          // tryPush() calls
    uint64_t dropped_newest = 0;  // pushes refused because the queue was full (DropPolicy::DropNewest,
                                  // or DropOldest when the oldest was being ingested)
    uint64_t dropped_oldest = 0;  // queued observations discarded to make room (DropPolicy::DropOldest)
    uint64_t words_truncated = 0; // words beyond max_words_per_frame, uniformly subsampled away at push
    // refiner side
    uint64_t ingested = 0;        // observations added to the model
    uint64_t rejected = 0;        // observations the model refused (bad word id, position, sizes)
    uint64_t words_dropped_cell = 0;  // words beyond a cell's capacity (Model subsampling)
    uint64_t refinements = 0;     // time-step draws refined (whole or, under a time/token budget, partly)
    uint64_t tokens = 0;          // token refinements (eq. 5 draws)
    uint64_t overruns = 0;        // observations whose time budget deadline was passed
    int64_t max_overrun_ns = 0;   // largest overrun past a deadline
    uint64_t published = 0;       // snapshots published

    // Observations lost to a full queue, whichever end.
    uint64_t dropped() const noexcept { return dropped_newest + dropped_oldest; }
};

// A reader's copy of the newest results. Sized once for a configuration
// (set-up); Engine::readSnapshot() copies into it without allocating.
class Snapshot {
public:
    Snapshot() = default;
    explicit Snapshot(const Config& cfg) { reserve(cfg); }
    // Sizes the buffers for `cfg` (allocates; set-up only).
    void reserve(const Config& cfg);

    // Publications so far when this copy was taken; 0 means nothing was published yet.
    uint64_t version = 0;
    // The newest ingested observation.
    uint64_t observation = 0;   // index among ingested observations (Model's frame index)
    uint64_t sequence = 0;      // producer sequence number (counts pushes, including dropped ones)
    int64_t timestamp = 0;      // as pushed
    int64_t step = 0;           // Model's 0-based time step
    double perplexity = std::numeric_limits<double>::quiet_NaN();  // of its step, after its budget
    double surprise = std::numeric_limits<double>::quiet_NaN();    // Model::observationSurprise
    // Instantaneous perplexity of the previous time step: computed just
    // before the first observation of `step` was added (paper section VII),
    // and published with that observation only: with cell.time > 1 a later
    // observation of the same step has -1 and NaN here.
    int64_t previous_step = -1;
    double previous_perplexity = std::numeric_limits<double>::quiet_NaN();
    double previous_plugin = std::numeric_limits<double>::quiet_NaN();  // plug-in, same step and instant
    int active_topics = 0;  // open topics (K without growth); labels and histograms are numbered 0..A-1
    EngineCounters counters;

    int K() const noexcept { return K_; }
    int cells() const noexcept { return cells_; }
    uint32_t words() const noexcept { return n_words_; }
    // Maximum-likelihood topic of each kept word, in input order.
    std::span<const uint16_t> labels() const noexcept { return {labels_.data(), n_words_}; }
    std::span<const uint32_t> wordIds() const noexcept { return {words_.data(), n_words_}; }
    std::span<const Position> positions() const noexcept { return {positions_.data(), n_words_}; }
    // n_c^k of every cell of the newest step, cell-major (cells() x K()).
    std::span<const int32_t> histograms() const noexcept { return {hist_.data(), hist_.size()}; }
    std::span<const int32_t> histogram(int cell) const noexcept {
        return {hist_.data() + static_cast<std::size_t>(cell) * static_cast<std::size_t>(K_),
                static_cast<std::size_t>(K_)};
    }
    // Per-cell surprise of the newest step (Model::cellSurprise).
    std::span<const float> cellSurprise() const noexcept { return {cell_surprise_.data(), cell_surprise_.size()}; }
    uint32_t capacity() const noexcept { return static_cast<uint32_t>(labels_.size()); }

private:
    friend class SnapshotPublisher;
    friend class Engine;
    int K_ = 0;
    int cells_ = 0;
    uint32_t n_words_ = 0;
    std::vector<uint16_t> labels_;
    std::vector<uint32_t> words_;
    std::vector<Position> positions_;
    std::vector<int32_t> hist_;
    std::vector<float> cell_surprise_;
};

// Single writer (the refiner), any number of readers, no locks. A seqlock
// over two buffers: the writer fills the buffer readers are not directed to,
// then flips a sequence number; a reader copies the current buffer and
// retries only if the writer came back to that buffer meanwhile. Every
// payload word is an atomic (release stores, acquire loads), so concurrent
// copy-out is well-defined and clean under ThreadSanitizer, and a copy that
// saw any word of a newer publication fails its sequence check.
class SnapshotPublisher {
public:
    explicit SnapshotPublisher(const Config& cfg);
    SnapshotPublisher(const SnapshotPublisher&) = delete;
    SnapshotPublisher& operator=(const SnapshotPublisher&) = delete;

    // Writer side (the refiner thread only). `staging` holds the new results.
    void publish(const Snapshot& staging) noexcept;
    // Reader side: copies the newest publication into `out` (sized by
    // Snapshot::reserve for the same configuration). Returns false when
    // nothing was published yet, `out` is too small, or the writer lapped the
    // reader `max_retries` times in a row (then `out` holds a torn copy and
    // must not be used).
    bool read(Snapshot& out, int max_retries = 1000) const noexcept;
    uint64_t version() const noexcept { return published_.load(std::memory_order_acquire); }

    std::size_t memoryBytes() const noexcept;

private:
    // Layout of one buffer, in 64-bit words: a fixed header, then the
    // labels, word ids, positions, cell histograms and cell surprise.
    std::size_t off_labels_ = 0, off_words_ = 0, off_positions_ = 0, off_hist_ = 0, off_surprise_ = 0;
    std::size_t words_per_buffer_ = 0;
    uint32_t capacity_ = 0;  // max words per observation
    int K_ = 0;
    int cells_ = 0;
    uint64_t written_ = 0;  // writer-private: publications so far
    // Publications completed; the newest is in buffer (published_ - 1) % 2.
    alignas(kCacheLine) std::atomic<uint64_t> published_{0};
    // Per-buffer sequence numbers: odd while the writer fills that buffer.
    alignas(kCacheLine) std::atomic<uint64_t> bseq_[2] = {0, 0};
    std::unique_ptr<std::atomic<uint64_t>[]> buf_[2];
    static_assert(std::atomic<uint64_t>::is_always_lock_free, "the snapshot seqlock needs lock-free 64-bit atomics");
};

} // namespace rost
