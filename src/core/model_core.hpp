#pragma once

// The model's implementation behind rost::Model (include/rost/model.hpp,
// the API and its documentation): the ring store of temporal cells and its
// count tables (src/core/model_store.cpp), refinement (src/core/model_refine.cpp,
// refine_windows.cpp, kernel.cpp), measurements and outputs
// (src/core/model_measure.cpp, measure.cpp, plugin_perplexity.cpp). Internal
// to the library: no installed header names a buffer or a kernel table.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "aligned_buffer.hpp"
#include "kernel_tables.hpp"
#include "rost/model.hpp"

namespace rost {

// ---- one observation's checks and subsampling ----------------------------------
// Shared by Model::addObservation and the engine's queue (which subsamples a
// long observation when it is pushed and checks the rest when it is taken
// up), so an observation is judged and thinned the same way wherever it enters.

// Words and positions must be as many: SizeMismatch at the shorter length otherwise.
AddResult checkObservationSizes(std::size_t words, std::size_t positions) noexcept;

// Uniform subsample of `keep` of `n` items in input order (selection
// sampling, Knuth's algorithm S): calls kept(i) for each index kept and
// returns how many. Keeps everything without a draw when n <= keep;
// otherwise draws rng.below(n - i) for each item looked at.
template <typename Kept>
std::size_t selectUniform(std::size_t n, std::size_t keep, Rng& rng, Kept&& kept) noexcept {
    if (n <= keep) {
        for (std::size_t i = 0; i < n; ++i) kept(i);
        return n;
    }
    std::size_t need = keep, j = 0;
    for (std::size_t i = 0; i < n && need > 0; ++i) {
        const uint64_t left = n - i;
        const uint64_t pick = left > 0xFFFFFFFFull ? need : rng.below(static_cast<uint32_t>(left));
        if (pick >= need) continue;
        kept(i);
        ++j;
        --need;
    }
    return j;
}

} // namespace rost

namespace rost::detail {

class WorkerPool;

// Topics (padded) a model may have: the stack buffers of per-topic sums.
inline constexpr int kMaxKp = 1024;

class ModelCore {
public:
    // rost::Model's API, each function documented there (include/rost/model.hpp).
    explicit ModelCore(const Config& config);
    ~ModelCore();
    ModelCore(const ModelCore&) = delete;
    ModelCore& operator=(const ModelCore&) = delete;

    const Config& config() const noexcept { return cfg_; }
    int K() const noexcept { return K_; }
    int activeTopics() const noexcept { return tables_.active; }
    double learnedGamma() const noexcept { return gamma_learned_; }
    uint64_t growthMovesAccepted() const noexcept { return growth_moves_; }
    bool topicCapReached() const noexcept { return cfg_.grow && tables_.active >= K_; }
    bool topicOpen(int k) const noexcept { return !cfg_.grow || (k >= 0 && k < K_ && nk_[k] > 0); }
    void outputNumbering(std::span<uint16_t> map) const noexcept;
    // model_store_restore.cpp
    bool checkRestoredState(StateProblem& problem) const;
    void stateRestored() noexcept;
    int V() const noexcept { return V_; }
    int cellsPerStep() const noexcept { return cells_; }

    // ---- ingest ---------------------------------------------------------
    // `labels`: each word's initial topic (empty: drawn at random).
    AddResult addObservation(std::span<const uint32_t> words, std::span<const Position> positions,
                             std::span<const uint16_t> labels) noexcept;
    AddResult validateObservation(std::span<const uint32_t> words, std::span<const Position> positions) const noexcept;

    uint64_t observations() const noexcept { return frames_; }
    int64_t steps() const noexcept { return steps_; }
    int64_t oldestStep() const noexcept { return steps_ > ring_ ? steps_ - ring_ : 0; }
    bool inWindow(int64_t step) const noexcept { return step >= oldestStep() && step < steps_; }
    int64_t stepOfObservation(uint64_t frame) const noexcept { return static_cast<int64_t>(frame) / cfg_.cell_time; }
    bool observationInWindow(uint64_t frame) const noexcept {
        return frame < frames_ && inWindow(stepOfObservation(frame));
    }

    // ---- refinement -------------------------------------------------------
    uint32_t refineCell(int64_t step, int cell) noexcept;
    uint32_t refineStep(int64_t step) noexcept;
    uint64_t refineAll(int sweeps = 1, const std::atomic<bool>* stop = nullptr) noexcept;

    RefineCount refine(StepPicker& picker, const RefineLimits& limits) noexcept;

    int threads() const noexcept;
    void setThreads(int n);
    void applyWorkerSettings(const ThreadSettings& settings);
    int colours() const noexcept { return colours_; }
    int colourStride() const noexcept { return colour_b_; }
    int colourOf(int64_t step, int cell) const noexcept {
        return static_cast<int>((static_cast<uint64_t>(step) + static_cast<uint64_t>(cell % gw_) +
                                 static_cast<uint64_t>(colour_b_) * static_cast<uint64_t>(cell / gw_)) %
                                static_cast<uint64_t>(colours_));
    }
    uint64_t tokensRefined() const noexcept { return tokens_refined_; }
    uint32_t wordsInStep(int64_t step) const noexcept;

    void setKernelPath(kernel::Path p) noexcept { path_ = p; }
    kernel::Path kernelPath() const noexcept { return path_; }

    // ---- measurements on the workers ------------------------------------
    uint64_t poolJobs() const noexcept;

    // ---- perplexity -----------------------------------------------------
    LogLoss cellLogLoss(int64_t step, int cell) const noexcept;
    LogLoss stepLogLoss(int64_t step) const noexcept;
    double stepPerplexity(int64_t step) const noexcept { return stepLogLoss(step).perplexity(); }
    double cellPerplexity(int64_t step, int cell) const noexcept { return cellLogLoss(step, cell).perplexity(); }
    double wordLogProb(int64_t step, int cell, uint32_t slot) const noexcept;

    // ---- plug-in perplexity (the 2013 ROST code's) -----------------------
    LogLoss cellPluginLogLoss(int64_t step, int cell) const noexcept;
    LogLoss stepPluginLogLoss(int64_t step) const noexcept;
    double stepPluginPerplexity(int64_t step) const noexcept { return stepPluginLogLoss(step).perplexity(); }

    // ---- curiosity ------------------------------------------------------
    double observationSurprise(uint64_t frame) const noexcept;
    std::span<const float> cellSurprise(int64_t step) const noexcept;

    // ---- outputs --------------------------------------------------------
    uint32_t observationSize(uint64_t frame) const noexcept;
    void observationWords(uint64_t frame, std::span<uint32_t> out) const noexcept;
    void observationPositions(uint64_t frame, std::span<Position> out) const noexcept;
    void observationLabels(uint64_t frame, std::span<uint16_t> out) const noexcept;
    void finalMeasurements(uint64_t first, std::span<double> perplexity, std::span<uint16_t> labels,
                           std::size_t stride) const noexcept;
    void observationSamples(uint64_t frame, std::span<uint16_t> out) const noexcept;
    std::span<const int32_t> cellHistogram(int64_t step, int cell) const noexcept;
    uint32_t cellWordCount(int64_t step, int cell) const noexcept;

    int32_t topicWordCount(int k, int v) const noexcept { return nkv_[static_cast<std::size_t>(v) * Kp_ + k]; }
    int32_t topicCount(int k) const noexcept { return nk_[k]; }
    uint64_t wordsInModel() const noexcept { return words_in_model_; }
    Status addTopicCounts(std::span<const int32_t> counts);

    bool checkInvariants(std::string* why = nullptr) const;

    std::size_t memoryBytes() const noexcept { return memory_bytes_; }

    Rng& rng() noexcept { return rng_; }

    void describeState(StateLayout& out) noexcept;

private:
    std::size_t slotOf(int64_t step) const noexcept { return static_cast<std::size_t>(step % ring_); }
    // The prior mass of opening a new topic while topics grow and there is
    // room, else 0: with growth from the data (docs/design.md, "Growth from
    // the data") topics open by split moves, and a word alone opens one only
    // when no topic is open, so its weight is negligible beside any open topic's.
    static constexpr double kFreshMass = kGrowthFreshMass;
    double freshMass() const noexcept { return cfg_.grow && tables_.active < K_ ? kFreshMass : 0.0; }
    // Growth from the data (src/core/growth.cpp): between sweeps, a split and
    // a merge move on the model's own tables and the concentration learned.
    // `budget`: the tokens a split may move at most (its steps around its
    // first anchor's; the whole window when it holds fewer).
    void growthMoves(uint64_t budget = UINT64_MAX) noexcept;
    struct Census;
    void takeCensus(Census& c) noexcept;
    struct Split;
    bool trySplit(double gamma, const Census& census, uint64_t budget) noexcept;
    bool tryMerge(double gamma, const Census& census) noexcept;
    void foldTopic(int from, int into) noexcept;
    double splitLogRatio(int a, int b, double moreTopics, uint64_t others, double gamma) noexcept;
    uint64_t windowTokens() const noexcept { return window_words_; }
    void moveToken(int32_t* cellCounts, std::size_t at, int from, int to) noexcept;
    template <typename F>
    void forEachWindowCell(F&& f) noexcept;
    template <typename F>
    void forEachCellIn(int64_t s0, int64_t s1, F&& f) noexcept;
    RefineCount refineWindows(StepPicker& picker, const RefineLimits& limits) noexcept;
    int32_t* nck(std::size_t slot, int cell) noexcept {
        return nck_.data() + (slot * cells_ + static_cast<std::size_t>(cell)) * Kp_;
    }
    const int32_t* nck(std::size_t slot, int cell) const noexcept {
        return nck_.data() + (slot * cells_ + static_cast<std::size_t>(cell)) * Kp_;
    }
    void neighbourhood(int64_t step, int cell, int32_t* out, bool pastOnly) const noexcept;
    void renumber(uint64_t frame, std::span<uint16_t> out) const noexcept;
    // Ring slots of a step and of its temporal neighbours in the window,
    // computed once per step so a cell's refinement does no division.
    struct StepSlots {
        std::size_t self = 0;
        int count = 0;
        std::size_t temporal[2 * 64];
    };
    void stepSlots(int64_t step, StepSlots& out) const noexcept;
    // Refines cells [c0, c1) of the step in `slots`; KP is the padded K
    // when specialised at compile time (0: runtime).
    template <int KP, kernel::Path P>
    uint32_t refineCells(const StepSlots& slots, int c0, int c1) noexcept;
    void evict(std::size_t slot) noexcept;
    // Windows of cell picks (src/core/refine_windows.cpp).
    struct Windows;
    struct WindowPlan;
    struct MoveLog;
    struct WindowJob;
    struct MergeJob;
    struct CatchUpJob;
    struct CopyJob;
    bool fillWindow(WindowPlan& plan, StepPicker& picker, const RefineLimits& limits, RefineCount& rc) noexcept;
    bool refineSerialWindow(const RefineLimits& limits, RefineCount& rc) noexcept;
    bool refineParallelWindow(const RefineLimits& limits, RefineCount& rc) noexcept;
    void groupWindow(WindowPlan& plan) noexcept;
    void prepareWindow(WindowPlan& plan) noexcept;
    void planNextWindow() noexcept;
    void layoutRounds(WindowPlan& plan) noexcept;
    // Round (colour) c of the current window; its last round may also plan the next window.
    void runRound(int c) noexcept;
    void takeMoves(const MoveLog& log, uint32_t copy) noexcept;
    void takeMovesEverywhere(const MoveLog& log) noexcept;
    void takePendingMoves() noexcept;
    void runLiveRound(uint32_t task) noexcept;
    void syncWorkerTables(bool copy) noexcept;
    // Whether the workers' tables have kernel::Tables::left: where the frozen
    // register kernels run at a known K (selectKernels: 16 or 32, no growth).
    bool leftTables() const noexcept { return !cfg_.fixed && !cfg_.grow && (Kp_ == 16 || Kp_ == 32); }
    bool workerCopiesAgree(std::string* why) const;
    void finishRound() noexcept;
    void countStarted(RefineCount& rc) noexcept;
    void allocateWindows();
    void chooseColours() noexcept;
    template <int KP>
    void sumNeighbourhood(const StepSlots& slots, int cell, int32_t* g) const noexcept;
    template <int KP, kernel::Path P>
    void frozenTask(int worker, uint32_t task) noexcept;
    template <int KP, kernel::Path P>
    void frozenTaskPair(int worker, uint32_t a, uint32_t b) noexcept;
    template <int KP>
    kernel::FrozenCell openFrozenTask(uint32_t task, int32_t* g, int32_t* start) noexcept;
    template <int KP>
    void closeFrozenTask(int worker, uint32_t task, const kernel::FrozenCell& c, const int32_t* start,
                         uint32_t moved) noexcept;
    void prefetchTask(uint32_t task) const noexcept;
    template <int KP, kernel::Path P>
    void liveTask(int worker, uint32_t task) noexcept;
    template <int KP>
    void setTaskKernels() noexcept;
    // A fixed topic model's tasks, frozen or live alike (refine_fixed.cpp).
    void setFixedTaskKernels() noexcept;
    void fixedTask(int worker, uint32_t task) noexcept;
    // The parts of addObservation, in order (ring slot `slot`, input row `obs`).
    void openStep(int64_t step, std::size_t slot) noexcept;
    uint32_t keepInputs(std::span<const uint32_t> words, std::span<const Position> positions, std::span<const uint16_t> labels,
                        std::size_t obs) noexcept;
    void fillCells(std::size_t slot, std::size_t obs, uint32_t kept, bool labelled, AddResult& res) noexcept;
    void observeSurprise(int64_t step, std::size_t slot, std::size_t obs, const uint32_t* firstNew) noexcept;
    void drawInitialLabels(std::size_t slot, const uint32_t* firstNew, bool labelled) noexcept;
    // The parts of checkRestoredState (model_store_restore.cpp); `bad`
    // fills `problem` and returns false.
    bool restoredCounters(StateProblem& problem) const;
    bool restoredCells(StateProblem& problem) const;
    bool restoredCell(std::size_t slot, int cell, bool used, std::vector<int64_t>& windowCounts,
                      StateProblem& problem) const;
    bool restoredInputs(StateProblem& problem) const;
    bool restoredSurprises(StateProblem& problem) const;
    // The parts of the constructor.
    void allocateState();
    void buildNeighbourhoods();
    void selectKernels() noexcept;
    // 1 / (n_k + V beta) and 1 / (n_k - 1 + V beta) in double, computed once
    // per call of an output function instead of K divisions per word.
    struct Reciprocals {
        double inv[1024];
        double invLeftOut[1024];
    };
    void reciprocals(Reciprocals& r) const noexcept;
    // What a word's own label adds to n_k^v: 1, or 0 in a fixed topic model.
    int ownCount() const noexcept { return cfg_.fixed ? 0 : 1; }
    double logProbLeftOut(uint32_t v, int z, const int32_t* nG, int32_t nGsum, const Reciprocals& r) const noexcept;
    int mlTopic(uint32_t v, int z, const int32_t* nG, const Reciprocals& r) const noexcept;
    // Per-cell parts of the plug-in perplexity and the surprise, called by
    // the serial and the parallel code alike, so both compute the same bits:
    // the plug-in weights theta_c(k) / (n_k + V beta) (returns the fresh
    // topic's term), log p of one word; the surprise's prior (the past
    // neighbourhood, summed into g, or n_k when that is empty; thetaNorm:
    // 1 / its normaliser) and log(p * thetaNorm) of one word.
    double pluginWeights(std::size_t slot, int cell, uint32_t n, double* weight) const noexcept;
    double pluginLogProb(uint32_t v, const double* weight, double freshP) const noexcept;
    const int32_t* surprisePrior(int64_t step, int cell, double globalSum, int32_t* g,
                                 double& thetaNorm) const noexcept;
    double surpriseLogProb(uint32_t v, const int32_t* prior, double thetaNorm) const noexcept;
    // -log of the cell's new words, summed in order (terms: from the pool, or nullptr: computed here).
    double cellSurpriseNll(int64_t step, std::size_t slot, int cell, uint32_t s0, double globalSum,
                           const double* terms) const noexcept;
    // Measurements on the workers (src/core/measure.cpp): each returns false
    // (surpriseTermsOnPool nullptr) when the measurement is to be serial.
    // The buffers they write sit behind measure_ (a pointer: const functions
    // write them, under the claim).
    struct Measure;
    void sizeMeasure();
    bool claimMeasure(uint64_t words) const noexcept;
    void releaseMeasure() const noexcept;
    bool parallelStepLogLoss(int64_t step, LogLoss& out) const noexcept;
    bool parallelStepPluginLogLoss(int64_t step, LogLoss& out) const noexcept;
    const double* surpriseTermsOnPool(int64_t step, std::size_t slot, const uint32_t* firstNew,
                                      double globalSum) noexcept;
    bool parallelLabels(uint64_t frame, std::span<uint16_t> out) const noexcept;
    // An observation's inputs grouped by cell (a counting sort): cell c's are
    // by_cell[begin[c], begin[c + 1]); cursor (cells) and cell_of (an entry
    // an input) are scratch.
    struct CellGroups {
        uint32_t* begin;
        uint32_t* cursor;
        uint32_t* cell_of;
        uint32_t* by_cell;
    };
    void groupInputsByCell(std::size_t base, uint32_t n, const CellGroups& g) const noexcept;
    void labelCell(int64_t step, int c, const CellGroups& groups, std::size_t base, const uint16_t* z,
                   const Reciprocals& r, uint16_t* out) const noexcept;
    // The left-out log loss of a step computed here, cell by cell (stepLogLoss's bits).
    LogLoss serialStepLogLoss(int64_t step) const noexcept;
    // finalMeasurements' task: observation first + i (worker's scratch).
    void finalTask(int worker, uint64_t first, uint32_t i, double* perplexity, uint16_t* labels,
                   std::size_t stride) const noexcept;
    // G(c) of a cell of `step`, cached for the current output call (epoch).
    const int32_t* cachedNeighbourhood(int64_t step, int cell, bool own, int32_t* local) const noexcept;
    template <typename F>
    void forEachInput(uint64_t frame, F&& f) const noexcept;

    Config cfg_;
    int K_, Kp_, V_, gw_, gh_, cells_, cap_, maxw_, ct_;
    int64_t ring_;
    float alpha_f_, beta_f_, vbeta_f_;

    // Topic model: n_k^v (V x Kp, word-major), n_k, cached reciprocals.
    AlignedBuffer<int32_t> nkv_;
    AlignedBuffer<int32_t> nk_;
    AlignedBuffer<float> inv_;
    AlignedBuffer<float> inv_dec_;
    AlignedBuffer<float> inv_inc_;

    // Ring of temporal cells (slot = step % ring_steps).
    AlignedBuffer<int64_t> slot_step_;   // which step a slot holds, -1 when empty
    AlignedBuffer<uint32_t> cell_n_;     // ring x cells: words in the cell
    AlignedBuffer<uint32_t> cell_words_; // ring x cells x cap
    AlignedBuffer<uint16_t> cell_z_;     // ring x cells x cap
    AlignedBuffer<int32_t> nck_;         // ring x cells x Kp
    AlignedBuffer<float> cell_surprise_; // ring x cells
    // Inputs of each observation in arrival order (ring x cell.time x max words).
    AlignedBuffer<uint32_t> in_word_;
    AlignedBuffer<uint32_t> in_pos_;     // x | y << 16
    AlignedBuffer<uint32_t> in_slot_;    // cell * cap + slot, or kDropped | cell
    AlignedBuffer<uint32_t> in_n_;       // ring x cell.time
    AlignedBuffer<float> obs_surprise_;  // ring x cell.time

    // Neighbourhood geometry: spatial neighbours of each cell (itself first).
    AlignedBuffer<uint32_t> nbr_begin_;  // cells + 1
    AlignedBuffer<uint32_t> nbr_cell_;

    // Scratch for ingest and refinement.
    // A position's cell without a division per word: x / cell.space, and
    // (y / cell.space) * grid width, for every x and y of the frame.
    AlignedBuffer<uint32_t> cell_of_x_;
    AlignedBuffer<uint32_t> cell_of_y_;
    AlignedBuffer<uint32_t> scratch_cell_;   // per input: its cell
    AlignedBuffer<uint16_t> scratch_z_;      // per kept input: its given initial label
    AlignedBuffer<uint32_t> scratch_count_;  // per cell
    AlignedBuffer<uint32_t> scratch_need_;   // per cell
    AlignedBuffer<int32_t> scratch_g_;       // Kp
    AlignedBuffer<double> scratch_ll_;       // per cell (surprise)
    AlignedBuffer<uint32_t> scratch_wn_;     // per cell (surprise word counts)
    // Output-side cache of neighbourhood sums (cells x Kp) for the const
    // label outputs. Two threads may measure at once (model.hpp): a call claims
    // the cache with out_cache_busy_ (one exchange, never a wait); one that
    // finds it taken sums each word's neighbourhood on its own stack instead,
    // with the same bits.
    mutable AlignedBuffer<int32_t> out_g_;
    mutable AlignedBuffer<uint64_t> out_g_epoch_;
    mutable uint64_t out_epoch_ = 0;
    mutable std::atomic<bool> out_cache_busy_{false};

    Rng rng_;
    kernel::Path path_ = kernel::Path::Simd;
    using CellsKernel = uint32_t (ModelCore::*)(const StepSlots&, int, int) noexcept;
    CellsKernel simd_kernel_;
    CellsKernel scalar_kernel_;
    using TaskKernel = void (ModelCore::*)(int, uint32_t) noexcept;
    TaskKernel frozen_kernel_[2] = {};  // [Scalar, Simd]
    TaskKernel live_kernel_[2] = {};
    using PairKernel = void (ModelCore::*)(int, uint32_t, uint32_t) noexcept;
    PairKernel pair_kernel_[2] = {};  // two frozen tasks at once; null: one at a time
    std::unique_ptr<Windows> win_;
    std::unique_ptr<detail::WorkerPool> pool_;
    std::unique_ptr<Measure> measure_;
    int colours_ = 1;
    int colour_b_ = 0;
    kernel::Tables tables_;

    uint64_t frames_ = 0;
    int64_t steps_ = 0;
    uint64_t tokens_refined_ = 0;
    uint64_t words_in_model_ = 0;
    uint64_t window_words_ = 0;  // words in the window's cells (derived: recounted by stateRestored)
    // Growth from the data: the concentration of the last move, and the moves accepted (not state).
    double gamma_learned_ = 0.0;
    uint64_t growth_moves_ = 0;
    bool move_due_ = false;  // a move for the start of the next refine() under a control
    bool nkv_is_window_ = true;  // false once counts outside the window (prior, kept evictions) exist
    std::size_t memory_bytes_ = 0;

public:
    static constexpr uint32_t kDropped = 0x80000000u;
};

} // namespace rost::detail

namespace rost {
// The implementation's members are defined in namespace rost (src/core/model_*.cpp).
using detail::ModelCore;
} // namespace rost
