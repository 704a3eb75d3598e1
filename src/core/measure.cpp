// The per-observation measurements (left-out and plug-in perplexity of a
// step, surprise, maximum-likelihood labels) on the refinement workers, with
// the same bits as the serial code for any number of threads (rost/model.hpp,
// "Measurements on the workers"; docs/design.md, "Refinement on every core").
//
// Each task computes the per-word terms of one cell (the same functions the
// serial code calls, -ffp-contract=off) into a buffer of one step's words;
// the sums are then made on the calling thread in the serial order, word by
// word and cell by cell in one double, so not one bit changes. The final
// pass (finalMeasurements) is cut the other way: a task per observation,
// which sums its step in the serial order itself.

#include <algorithm>

#include "measure.hpp"
#include "model_core.hpp"
#include "worker_pool.hpp"

namespace rost {

namespace {


// Fewer words are measured serially: a job costs a futex wake and the
// barrier (microseconds), what about 256 words' terms cost (about 40 ns each
// at K = 16). A step of one cell (a word stream) is measured serially: the
// tasks are cells (except finalMeasurements', which are observations).
constexpr uint64_t kParallelWords = 256;

// One task per cell: f(cell).
template <typename F>
struct CellJob final : detail::WorkerPool::Job {
    explicit CellJob(const F& fn) noexcept : f(fn) {}
    const F& f;
    void task(int /*worker*/, uint32_t cell) noexcept override { f(static_cast<int>(cell)); }
};

template <typename F>
void runCells(detail::WorkerPool& pool, int cells, const F& f) noexcept {
    CellJob<F> job(f);
    pool.run(job, static_cast<uint32_t>(cells));
}

} // namespace

void ModelCore::sizeMeasure() {
    if (!measure_) measure_ = std::make_unique<Measure>();
    memory_bytes_ -= measure_->bytes();
    const bool pooled = pool_ != nullptr;
    measure_->size(pooled ? static_cast<std::size_t>(cells_) : 0, pooled ? static_cast<std::size_t>(cap_) : 0,
                   pooled ? static_cast<std::size_t>(maxw_) : 0,
                   pooled ? static_cast<std::size_t>(pool_->workers()) : 0);
    memory_bytes_ += measure_->bytes();
}

uint64_t ModelCore::poolJobs() const noexcept { return pool_ ? pool_->jobs() : 0; }

bool ModelCore::claimMeasure(uint64_t words) const noexcept {
    if (!pool_ || cells_ < 2 || words < kParallelWords) return false;
    return !measure_->busy.exchange(true, std::memory_order_acquire);
}

void ModelCore::releaseMeasure() const noexcept { measure_->busy.store(false, std::memory_order_release); }

// ---- left-out perplexity -------------------------------------------------------

bool ModelCore::parallelStepLogLoss(int64_t step, LogLoss& out) const noexcept {
    if (!claimMeasure(wordsInStep(step))) return false;
    const std::size_t slot = slotOf(step);
    Reciprocals r;
    reciprocals(r);
    double* terms = measure_->terms.data();
    runCells(*pool_, cells_, [&](int c) {
        const uint32_t n = cell_n_[slot * cells_ + c];
        if (n == 0) return;
        alignas(64) int32_t g[kMaxKp];
        neighbourhood(step, c, g, false);
        int32_t gsum = 0;
        for (int k = 0; k < K_; ++k) gsum += g[k];
        const std::size_t base = (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
        double* t = terms + static_cast<std::size_t>(c) * cap_;
        for (uint32_t i = 0; i < n; ++i) t[i] = logProbLeftOut(cell_words_[base + i], cell_z_[base + i], g, gsum, r);
    });
    // Summed as stepLogLoss sums: word by word, cell by cell, in one double.
    for (int c = 0; c < cells_; ++c) {
        const uint32_t n = cell_n_[slot * cells_ + c];
        const double* t = terms + static_cast<std::size_t>(c) * cap_;
        for (uint32_t i = 0; i < n; ++i) out.nll -= t[i];
        out.words += n;
    }
    releaseMeasure();
    return true;
}

// ---- plug-in perplexity --------------------------------------------------------

bool ModelCore::parallelStepPluginLogLoss(int64_t step, LogLoss& out) const noexcept {
    if (!claimMeasure(wordsInStep(step))) return false;
    const std::size_t slot = slotOf(step);
    double* terms = measure_->terms.data();
    runCells(*pool_, cells_, [&](int c) {
        const uint32_t n = cell_n_[slot * cells_ + c];
        if (n == 0) return;
        double weight[kMaxKp];
        const double freshP = pluginWeights(slot, c, n, weight);
        const uint32_t* words = cell_words_.data() + (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
        double* t = terms + static_cast<std::size_t>(c) * cap_;
        for (uint32_t i = 0; i < n; ++i) t[i] = pluginLogProb(words[i], weight, freshP);
    });
    // Summed as stepPluginLogLoss sums: each cell in its own double, then the cells in order.
    for (int c = 0; c < cells_; ++c) {
        LogLoss cell;
        cell.words = cell_n_[slot * cells_ + c];
        const double* t = terms + static_cast<std::size_t>(c) * cap_;
        for (uint32_t i = 0; i < cell.words; ++i) cell.nll -= t[i];
        out += cell;
    }
    releaseMeasure();
    return true;
}

// ---- surprise ------------------------------------------------------------------

const double* ModelCore::surpriseTermsOnPool(int64_t step, std::size_t slot, const uint32_t* firstNew,
                                         double globalSum) noexcept {
    const uint32_t* cellN = cell_n_.data() + slot * cells_;
    uint64_t words = 0;
    for (int c = 0; c < cells_; ++c) words += cellN[c] - firstNew[c];
    if (!claimMeasure(words)) return nullptr;
    double* terms = measure_->terms.data();
    runCells(*pool_, cells_, [&](int c) {
        const uint32_t s0 = firstNew[c], s1 = cellN[c];
        if (s1 == s0) return;
        alignas(64) int32_t g[kMaxKp];
        double thetaNorm = 0.0;
        const int32_t* prior = surprisePrior(step, c, globalSum, g, thetaNorm);
        const uint32_t* w = cell_words_.data() + (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
        double* t = terms + static_cast<std::size_t>(c) * cap_;
        for (uint32_t s = s0; s < s1; ++s) t[s] = surpriseLogProb(w[s], prior, thetaNorm);
    });
    return terms;  // the caller sums and then releases
}

// ---- maximum-likelihood labels -------------------------------------------------

bool ModelCore::parallelLabels(uint64_t frame, std::span<uint16_t> out) const noexcept {
    const auto n = static_cast<uint32_t>(std::min<std::size_t>(out.size(), observationSize(frame)));
    if (!claimMeasure(n)) return false;
    const int64_t step = stepOfObservation(frame);
    const std::size_t slot = slotOf(step);
    const std::size_t base = (slot * ct_ + frame % static_cast<uint64_t>(ct_)) * static_cast<std::size_t>(maxw_);
    const CellGroups groups = measure_->groups();
    groupInputsByCell(base, n, groups);
    Reciprocals r;
    reciprocals(r);
    const uint16_t* z = cell_z_.data() + slot * cells_ * cap_;
    runCells(*pool_, cells_, [&](int c) { labelCell(step, c, groups, base, z, r, out.data()); });
    releaseMeasure();
    renumber(frame, out);
    return true;
}

// Inputs [base, base + n) of an observation grouped by cell (a counting
// sort), so that a task takes its cell's inputs.
void ModelCore::groupInputsByCell(std::size_t base, uint32_t n, const CellGroups& g) const noexcept {
    std::fill_n(g.begin, cells_ + 1, 0u);
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t s = in_slot_[base + i];
        g.cell_of[i] = (s & kDropped) ? (s & ~kDropped) : s / static_cast<uint32_t>(cap_);
        ++g.begin[g.cell_of[i] + 1];
    }
    for (int c = 0; c < cells_; ++c) {
        g.begin[c + 1] += g.begin[c];
        g.cursor[c] = g.begin[c];
    }
    for (uint32_t i = 0; i < n; ++i) g.by_cell[g.cursor[g.cell_of[i]]++] = i;
}

// The ML labels of an observation's inputs in cell c (grouped by
// groupInputsByCell), its neighbourhood computed once; z: the step's labels.
void ModelCore::labelCell(int64_t step, int c, const CellGroups& groups, std::size_t base, const uint16_t* z,
                      const Reciprocals& r, uint16_t* out) const noexcept {
    if (groups.begin[c] == groups.begin[c + 1]) return;
    alignas(64) int32_t g[kMaxKp];
    neighbourhood(step, c, g, false);
    for (uint32_t j = groups.begin[c]; j < groups.begin[c + 1]; ++j) {
        const uint32_t i = groups.by_cell[j], s = in_slot_[base + i];
        out[i] = static_cast<uint16_t>(mlTopic(in_word_[base + i], (s & kDropped) ? -1 : z[s], g, r));
    }
}

// ---- the final pass: many observations, a task each ---------------------------

// Observation first + i: its step's perplexity when it is the first of the
// batch in its step (the others copy it after the job), and its labels, each
// word's cell's neighbourhood computed once (as parallelLabels does, the same
// mlTopic of the same counts, so the same labels).
void ModelCore::finalTask(int worker, uint64_t first, uint32_t i, double* perplexity, uint16_t* labels,
                      std::size_t stride) const noexcept {
    const uint64_t frame = first + i;
    const int64_t step = stepOfObservation(frame);
    if (i == 0 || stepOfObservation(frame - 1) != step) perplexity[i] = serialStepLogLoss(step).perplexity();
    if (!observationInWindow(frame)) return;
    const auto n = static_cast<uint32_t>(std::min<std::size_t>(stride, observationSize(frame)));
    const std::size_t slot = slotOf(step);
    const std::size_t base = (slot * ct_ + frame % static_cast<uint64_t>(ct_)) * static_cast<std::size_t>(maxw_);
    const CellGroups groups = measure_->workerGroups(worker, static_cast<std::size_t>(cells_), static_cast<std::size_t>(maxw_));
    groupInputsByCell(base, n, groups);
    Reciprocals r;
    reciprocals(r);
    const uint16_t* z = cell_z_.data() + slot * cells_ * cap_;
    uint16_t* out = labels + static_cast<std::size_t>(i) * stride;
    for (int c = 0; c < cells_; ++c) labelCell(step, c, groups, base, z, r, out);
    renumber(frame, {out, n});
}

void ModelCore::finalMeasurements(uint64_t first, std::span<double> perplexity, std::span<uint16_t> labels,
                              std::size_t stride) const noexcept {
    // A pool job holds fewer than 2^20 tasks: larger batches go in parts
    // (each part's first observation computes its step's perplexity again, the same bits).
    constexpr std::size_t kPart = std::size_t{1} << 16;
    if (perplexity.size() > kPart) {
        for (std::size_t at = 0; at < perplexity.size(); at += kPart) {
            const std::size_t n = std::min(kPart, perplexity.size() - at);
            finalMeasurements(first + at, perplexity.subspan(at, n), labels.subspan(at * stride), stride);
        }
        return;
    }
    const auto count = static_cast<uint32_t>(perplexity.size());
    if (count == 0) return;
    uint64_t words = 0;
    for (uint32_t i = 0; i < count; ++i) words += observationSize(first + i);
    // Tasks are observations here, so a step of one cell (a word stream) is worth a job too.
    if (count > 1 && pool_ && words >= kParallelWords && !measure_->busy.exchange(true, std::memory_order_acquire)) {
        struct FinalJob final : detail::WorkerPool::Job {
            const ModelCore& m;
            uint64_t first;
            double* perplexity;
            uint16_t* labels;
            std::size_t stride;
            FinalJob(const ModelCore& model, uint64_t f, double* p, uint16_t* l, std::size_t s) noexcept
                : m(model), first(f), perplexity(p), labels(l), stride(s) {}
            void task(int worker, uint32_t i) noexcept override {
                m.finalTask(worker, first, i, perplexity, labels, stride);
            }
        } job(*this, first, perplexity.data(), labels.data(), stride);
        pool_->run(job, count);
        releaseMeasure();
        for (uint32_t i = 1; i < count; ++i)
            if (stepOfObservation(first + i) == stepOfObservation(first + i - 1)) perplexity[i] = perplexity[i - 1];
        return;
    }
    // Serially (no workers, or the pool is another measurement's), one
    // measurement at a time: each may still use the pool itself.
    for (uint32_t i = 0; i < count; ++i) {
        const uint64_t frame = first + i;
        const int64_t step = stepOfObservation(frame);
        perplexity[i] = i > 0 && stepOfObservation(frame - 1) == step ? perplexity[i - 1] : stepPerplexity(step);
        const std::size_t n = std::min<std::size_t>(stride, observationSize(frame));
        observationLabels(frame, labels.subspan(static_cast<std::size_t>(i) * stride, n));
    }
}

} // namespace rost
