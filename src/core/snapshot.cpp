// The engine's snapshot (rost/snapshot.hpp): a reader's copy of the newest
// results, and the lock-free double-buffered seqlock the refiner publishes
// it through (docs/engine.md, "Why a seqlock").

#include "rost/snapshot.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

namespace rost {

namespace {

inline uint64_t bitsOf(double d) noexcept { return std::bit_cast<uint64_t>(d); }
inline double doubleOf(uint64_t u) noexcept { return std::bit_cast<double>(u); }

// The seqlock payload is atomic words written with release stores and read
// with acquire loads: a reader that sees any word of a new publication then
// also sees the odd sequence number written before it, so its final check
// fails. No standalone fences (which ThreadSanitizer does not model); on
// x86 these are plain moves, on ARM load-acquire/store-release.
constexpr auto kPut = std::memory_order_release;
constexpr auto kGet = std::memory_order_acquire;

void storeBytes(std::atomic<uint64_t>* dst, const void* src, std::size_t bytes) noexcept {
    const auto* s = static_cast<const unsigned char*>(src);
    std::size_t i = 0;
    for (; i + 8 <= bytes; i += 8) {
        uint64_t v;
        std::memcpy(&v, s + i, 8);
        dst[i / 8].store(v, kPut);
    }
    if (i < bytes) {
        uint64_t v = 0;
        std::memcpy(&v, s + i, bytes - i);
        dst[i / 8].store(v, kPut);
    }
}
void loadBytes(void* dst, const std::atomic<uint64_t>* src, std::size_t bytes) noexcept {
    auto* d = static_cast<unsigned char*>(dst);
    std::size_t i = 0;
    for (; i + 8 <= bytes; i += 8) {
        const uint64_t v = src[i / 8].load(kGet);
        std::memcpy(d + i, &v, 8);
    }
    if (i < bytes) {
        const uint64_t v = src[i / 8].load(kGet);
        std::memcpy(d + i, &v, bytes - i);
    }
}
constexpr std::size_t wordsFor(std::size_t bytes) noexcept { return (bytes + 7) / 8; }

// Header of a snapshot buffer, in 64-bit words.
enum Header : std::size_t {
    kObservation, kSequence, kTimestamp, kStep, kPerplexity, kSurprise, kPrevStep, kPrevPerplexity, kPrevPlugin, kActiveTopics, kWords,
    kPushed, kDroppedNewest, kDroppedOldest, kWordsTruncated, kIngested, kRejected, kWordsDroppedCell,
    kRefinements, kTokens, kOverruns, kMaxOverrun, kPublished,
    kHeaderWords
};

} // namespace

// ---- Snapshot ---------------------------------------------------------------

void Snapshot::reserve(const Config& cfg) {
    K_ = cfg.K;
    cells_ = cfg.cellsPerStep();
    const auto cap = static_cast<std::size_t>(cfg.max_words_per_frame);
    labels_.assign(cap, 0);
    words_.assign(cap, 0);
    positions_.assign(cap, Position{});
    hist_.assign(static_cast<std::size_t>(cells_) * static_cast<std::size_t>(K_), 0);
    cell_surprise_.assign(static_cast<std::size_t>(cells_), 0.f);
    n_words_ = 0;
}

// ---- SnapshotPublisher --------------------------------------------------------

SnapshotPublisher::SnapshotPublisher(const Config& cfg)
    : capacity_(static_cast<uint32_t>(cfg.max_words_per_frame)), K_(cfg.K), cells_(cfg.cellsPerStep()) {
    const std::size_t cap = capacity_;
    const std::size_t hk = static_cast<std::size_t>(cells_) * static_cast<std::size_t>(K_);
    off_labels_ = kHeaderWords;
    off_words_ = off_labels_ + wordsFor(cap * sizeof(uint16_t));
    off_positions_ = off_words_ + wordsFor(cap * sizeof(uint32_t));
    off_hist_ = off_positions_ + wordsFor(cap * sizeof(Position));
    off_surprise_ = off_hist_ + wordsFor(hk * sizeof(int32_t));
    words_per_buffer_ = off_surprise_ + wordsFor(static_cast<std::size_t>(cells_) * sizeof(float));
    for (auto& b : buf_) {
        b = std::make_unique<std::atomic<uint64_t>[]>(words_per_buffer_);
        for (std::size_t i = 0; i < words_per_buffer_; ++i) b[i].store(0, std::memory_order_relaxed);
    }
}

std::size_t SnapshotPublisher::memoryBytes() const noexcept {
    return 2 * words_per_buffer_ * sizeof(uint64_t) + sizeof(*this);
}

void SnapshotPublisher::publish(const Snapshot& s) noexcept {
    // Publication n goes to buffer n % 2; readers are directed to buffer
    // (n - 1) % 2 until published_ moves on, so they rarely see this one
    // change under them (only a reader still copying publication n - 2).
    const uint64_t n = written_;
    const std::size_t b = n % 2;
    std::atomic<uint64_t>* d = buf_[b].get();
    const uint64_t seq = bseq_[b].load(std::memory_order_relaxed);
    bseq_[b].store(seq + 1, std::memory_order_relaxed);  // odd: readers of buffer b will retry

    const uint32_t nw = std::min(s.n_words_, capacity_);
    auto put = [&](std::size_t at, uint64_t v) { d[at].store(v, kPut); };
    put(kObservation, s.observation);
    put(kSequence, s.sequence);
    put(kTimestamp, static_cast<uint64_t>(s.timestamp));
    put(kStep, static_cast<uint64_t>(s.step));
    put(kPerplexity, bitsOf(s.perplexity));
    put(kSurprise, bitsOf(s.surprise));
    put(kPrevStep, static_cast<uint64_t>(s.previous_step));
    put(kPrevPerplexity, bitsOf(s.previous_perplexity));
    put(kPrevPlugin, bitsOf(s.previous_plugin));
    put(kActiveTopics, static_cast<uint64_t>(s.active_topics));
    put(kWords, nw);
    const EngineCounters& c = s.counters;
    put(kPushed, c.pushed);
    put(kDroppedNewest, c.dropped_newest);
    put(kDroppedOldest, c.dropped_oldest);
    put(kWordsTruncated, c.words_truncated);
    put(kIngested, c.ingested);
    put(kRejected, c.rejected);
    put(kWordsDroppedCell, c.words_dropped_cell);
    put(kRefinements, c.refinements);
    put(kTokens, c.tokens);
    put(kOverruns, c.overruns);
    put(kMaxOverrun, static_cast<uint64_t>(c.max_overrun_ns));
    put(kPublished, n + 1);
    if (s.labels_.size() >= nw && s.words_.size() >= nw && s.positions_.size() >= nw) {
        storeBytes(d + off_labels_, s.labels_.data(), nw * sizeof(uint16_t));
        storeBytes(d + off_words_, s.words_.data(), nw * sizeof(uint32_t));
        storeBytes(d + off_positions_, s.positions_.data(), nw * sizeof(Position));
    }
    const std::size_t hk = static_cast<std::size_t>(cells_) * static_cast<std::size_t>(K_);
    if (s.hist_.size() == hk) storeBytes(d + off_hist_, s.hist_.data(), hk * sizeof(int32_t));
    if (s.cell_surprise_.size() == static_cast<std::size_t>(cells_))
        storeBytes(d + off_surprise_, s.cell_surprise_.data(), static_cast<std::size_t>(cells_) * sizeof(float));

    bseq_[b].store(seq + 2, std::memory_order_release);
    written_ = n + 1;
    published_.store(n + 1, std::memory_order_release);
}

bool SnapshotPublisher::read(Snapshot& out, int max_retries) const noexcept {
    if (out.K_ != K_ || out.cells_ != cells_ || out.labels_.size() < capacity_ || out.words_.size() < capacity_ ||
        out.positions_.size() < capacity_)
        return false;
    const std::size_t hk = static_cast<std::size_t>(cells_) * static_cast<std::size_t>(K_);
    for (int attempt = 0; attempt <= max_retries; ++attempt) {
        const uint64_t n = published_.load(std::memory_order_acquire);
        if (n == 0) return false;
        const std::size_t b = (n - 1) % 2;
        const uint64_t s1 = bseq_[b].load(std::memory_order_acquire);
        if (s1 & 1u) continue;
        const std::atomic<uint64_t>* d = buf_[b].get();
        auto get = [&](std::size_t at) { return d[at].load(kGet); };
        out.version = get(kPublished);
        out.observation = get(kObservation);
        out.sequence = get(kSequence);
        out.timestamp = static_cast<int64_t>(get(kTimestamp));
        out.step = static_cast<int64_t>(get(kStep));
        out.perplexity = doubleOf(get(kPerplexity));
        out.surprise = doubleOf(get(kSurprise));
        out.previous_step = static_cast<int64_t>(get(kPrevStep));
        out.previous_perplexity = doubleOf(get(kPrevPerplexity));
        out.previous_plugin = doubleOf(get(kPrevPlugin));
        out.active_topics = static_cast<int>(get(kActiveTopics));
        const auto nw = static_cast<uint32_t>(std::min<uint64_t>(get(kWords), capacity_));
        out.n_words_ = nw;
        EngineCounters& c = out.counters;
        c.pushed = get(kPushed);
        c.dropped_newest = get(kDroppedNewest);
        c.dropped_oldest = get(kDroppedOldest);
        c.words_truncated = get(kWordsTruncated);
        c.ingested = get(kIngested);
        c.rejected = get(kRejected);
        c.words_dropped_cell = get(kWordsDroppedCell);
        c.refinements = get(kRefinements);
        c.tokens = get(kTokens);
        c.overruns = get(kOverruns);
        c.max_overrun_ns = static_cast<int64_t>(get(kMaxOverrun));
        c.published = out.version;
        loadBytes(out.labels_.data(), d + off_labels_, nw * sizeof(uint16_t));
        loadBytes(out.words_.data(), d + off_words_, nw * sizeof(uint32_t));
        loadBytes(out.positions_.data(), d + off_positions_, nw * sizeof(Position));
        loadBytes(out.hist_.data(), d + off_hist_, hk * sizeof(int32_t));
        loadBytes(out.cell_surprise_.data(), d + off_surprise_, static_cast<std::size_t>(cells_) * sizeof(float));
        if (bseq_[b].load(std::memory_order_relaxed) == s1) return true;
    }
    return false;
}

} // namespace rost
