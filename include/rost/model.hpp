#pragma once

// The spatiotemporal topic model of the paper (sections III-V) over a fixed
// ring of temporal cells. Single-threaded: exactly one thread (the refiner)
// may call its mutating functions. Nothing allocates after construction.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>


#include "rost/aligned_buffer.hpp"
#include "rost/config.hpp"
#include "rost/kernel_types.hpp"
#include "rost/position.hpp"
#include "rost/random.hpp"
#include "rost/state_layout.hpp"
#include "rost/status.hpp"

namespace rost {

struct ThreadSettings;
namespace detail {
class WorkerPool;
}

enum class AddError : uint8_t {
    None,
    SizeMismatch,        // words and positions differ in length
    WordOutOfRange,      // a word id >= V
    PositionOutOfRange,  // a position outside [0, width) x [0, height)
};
const char* toString(AddError e) noexcept;

struct AddResult {
    AddError error = AddError::None;
    uint32_t index = 0;          // the offending word's index when error != None
    uint32_t kept = 0;           // words that entered cells
    uint32_t dropped_frame = 0;  // words beyond max_words_per_frame (uniformly subsampled away)
    uint32_t dropped_cell = 0;   // words beyond a cell's capacity (uniformly subsampled away)
    [[nodiscard]] bool ok() const noexcept { return error == AddError::None; }
};

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

// Sum of -log p(w) over some words; perplexity = exp(nll / words).
struct LogLoss {
    double nll = 0.0;
    uint64_t words = 0;
    [[nodiscard]] double perplexity() const noexcept;
    LogLoss& operator+=(const LogLoss& o) noexcept {
        nll += o.nll;
        words += o.words;
        return *this;
    }
};

// ---- refinement in windows (docs/design.md, "Refinement on every core") -----

// The time steps to refine, one pick at a time: a strategy's draws, or the
// window's steps in order for a batch sweep. With workers, next() may be
// called on a pool thread while a round is refining (the next window is
// planned ahead): a picker may draw from the model's generator and read the
// window's extent (steps(), oldestStep()), but not the counts or labels,
// which the round is changing.
class StepPicker {
public:
    virtual int64_t next() noexcept = 0;

protected:
    ~StepPicker() = default;
};

// Optional limits a caller checks between picks and rounds (a time budget,
// stop on arrival). Called on the refining thread.
class RefineControl {
public:
    // Before another step is drawn; false: draw no more.
    virtual bool beforeStep() noexcept { return true; }
    // Before a round of `tokens` token refinements; false: stop here.
    virtual bool beforeRound(uint64_t /*tokens*/) noexcept { return true; }
    // After a round of `tokens` token refinements.
    virtual void afterRound(uint64_t /*tokens*/) noexcept {}
    // Before a window is filled: the token refinements still affordable (a
    // time budget's estimate of what fits before its deadline). The window
    // takes cells until it holds this many tokens, so the rounds shrink as the
    // deadline nears instead of one large round being refused early.
    virtual uint64_t tokenAllowance() noexcept { return UINT64_MAX; }

protected:
    ~RefineControl() = default;
};

struct RefineLimits {
    uint64_t steps = UINT64_MAX;   // step picks drawn at most
    uint64_t tokens = UINT64_MAX;  // no round starts once this many tokens are refined
    RefineControl* control = nullptr;
};

struct RefineCount {
    uint64_t steps = 0;    // step picks drawn
    uint64_t started = 0;  // step picks of which at least one cell was refined
    uint64_t tokens = 0;   // token refinements
    uint64_t rounds = 0;   // rounds run (a round of a serial window is one cell)
    uint64_t planned = 0;  // windows planned by a worker during the window before (same draws)
    // Rounds whose merge was deferred to the next round's job, and copies of
    // n_k^v given a deferred round's moves by the caller: their worker took
    // no task of the next round, or the next round was one cell, refined live
    // (docs/design.md, "A copy of n_k^v per worker").
    uint64_t deferred = 0;
    uint64_t caught_up = 0;
};

class Model {
public:
    // Throws std::invalid_argument with Config::validate()'s message on a bad configuration.
    explicit Model(const Config& config);
    // Non-throwing factory: returns nullptr and sets status on a bad configuration.
    static std::unique_ptr<Model> create(const Config& config, Status& status);

    ~Model();
    Model(const Model&) = delete;
    Model& operator=(const Model&) = delete;

    const Config& config() const noexcept { return cfg_; }
    int K() const noexcept { return K_; }
    // Active topics A: labels are 0..A-1. K without topic growth; with
    // topics.grow, the topics opened so far (1 at the start, at most K).
    int activeTopics() const noexcept { return tables_.active; }
    // True when topics grow and every one of the K topics is open.
    bool topicCapReached() const noexcept { return cfg_.grow && tables_.active >= K_; }
    // Whether topic k is open (holds a word; always, without growth).
    bool topicOpen(int k) const noexcept { return !cfg_.grow || (k >= 0 && k < K_ && nk_[k] > 0); }
    // Output numbering of the topics (docs/design.md, "Topics that grow"):
    // map[k] = the number of open topics below k, so open topics are numbered
    // 0..A-1 in label order (0xFFFF for a closed one). Without growth the
    // identity. observationLabels and observationSamples are numbered this
    // way; cellHistogram, topicWordCount and topicCount take labels. map.size() >= K.
    void outputNumbering(std::span<uint16_t> map) const noexcept;
    // Call after the state sections (describeState) were written back.
    void stateRestored() noexcept;
    int V() const noexcept { return V_; }
    int cellsPerStep() const noexcept { return cells_; }

    // ---- ingest ---------------------------------------------------------
    // Adds one observation (the next time step). Words land in cell
    // (t / cell.time, x / cell.space, y / cell.space) with uniformly random
    // initial topics (paper Algorithm 2). Input beyond max_words_per_frame or
    // a cell's capacity is uniformly subsampled (selection sampling, seeded)
    // and counted. On error nothing changes. Never allocates.
    AddResult addObservation(std::span<const uint32_t> words, std::span<const Position> positions) noexcept;
    // The checks addObservation makes before it changes anything (sizes,
    // word ids < V, positions inside the frame): the first offending word.
    AddResult validateObservation(std::span<const uint32_t> words, std::span<const Position> positions) const noexcept;

    uint64_t observations() const noexcept { return frames_; }
    // Temporal cells so far (the paper's T, counting from 1). Step indices run 0..steps()-1.
    int64_t steps() const noexcept { return steps_; }
    // Oldest step still in the ring (refinable).
    int64_t oldestStep() const noexcept { return steps_ > ring_ ? steps_ - ring_ : 0; }
    bool inWindow(int64_t step) const noexcept { return step >= oldestStep() && step < steps_; }
    int64_t stepOfObservation(uint64_t frame) const noexcept { return static_cast<int64_t>(frame) / cfg_.cell_time; }
    bool observationInWindow(uint64_t frame) const noexcept {
        return frame < frames_ && inWindow(stepOfObservation(frame));
    }

    // ---- refinement -------------------------------------------------------
    // Refines every word of one cell / one time step once, cells in index
    // order and a cell's words in the order they were added. Returns the
    // number of tokens refined (0 for a step outside the window).
    uint32_t refineCell(int64_t step, int cell) noexcept;
    uint32_t refineStep(int64_t step) noexcept;
    // Batch Gibbs (paper Algorithm 1): `sweeps` passes over every cell of the
    // window, in windows of refine.window cell refinements (below).
    uint64_t refineAll(int sweeps = 1) noexcept;

    // Refines the steps `picker` draws until a limit is reached. The steps'
    // non-empty cells, in index order, form a sequence of cell picks that is
    // cut into windows of refine.window (W) picks. W = 1: each pick is
    // refined in turn against live counts, the exact serial sampler (and the
    // model's generator draws every token's topic). W > 1: a window's key is
    // drawn from the model's generator, its picks are grouped by cell and the
    // cells by colour, so that no two cells of a colour are neighbours;
    // colour by colour, a round refines its cells (a cell picked m times, m
    // times in a row) on `threads` threads against the word-topic counts as
    // they stood when the round began, and merges the changes after it.
    // Every draw is keyed by (window key, pick, word), so the result does not
    // depend on the number of threads. Limits are checked between rounds.
    RefineCount refine(StepPicker& picker, const RefineLimits& limits) noexcept;

    // Threads that refine (config().threads, the caller included).
    int threads() const noexcept;
    // Refines on n threads from now on (1..1024; the results do not change).
    // Set-up code: starts or stops workers, may throw std::system_error.
    void setThreads(int n);
    // Restarts the refinement workers with these scheduling settings (named,
    // SCHED_FIFO, pinned to the CPUs below settings.cpu). Set-up code.
    void applyWorkerSettings(const ThreadSettings& settings);
    // Colours of the cell grid: (step + x + b y) mod colours() (b: colourStride()).
    int colours() const noexcept { return colours_; }
    int colourStride() const noexcept { return colour_b_; }
    int colourOf(int64_t step, int cell) const noexcept {
        return static_cast<int>((static_cast<uint64_t>(step) + static_cast<uint64_t>(cell % gw_) +
                                 static_cast<uint64_t>(colour_b_) * static_cast<uint64_t>(cell / gw_)) %
                                static_cast<uint64_t>(colours_));
    }
    uint64_t tokensRefined() const noexcept { return tokens_refined_; }
    // Words currently in cells of a step.
    uint32_t wordsInStep(int64_t step) const noexcept;

    // Selects the scalar reference or the SIMD kernel (default: SIMD).
    void setKernelPath(kernel::Path p) noexcept { path_ = p; }
    kernel::Path kernelPath() const noexcept { return path_; }

    // ---- measurements on the workers ------------------------------------
    // With workers (threads > 1 and refine.window > 1), stepLogLoss,
    // stepPluginLogLoss, the surprise of addObservation and
    // observationLabels compute their per-word terms on the refinement
    // workers, a task per cell, and sum them on the calling thread in the
    // serial order: the results are the same bits for any number of threads
    // (src/core/measure.cpp). Only a measurement of at least 256 words, on a
    // grid of more than one cell, does (a word stream's step is one cell);
    // finalMeasurements (below) has a task per observation instead, on any grid.
    // The calling thread drives the pool, as refine() does, so call these
    // where a reader may call them: on the refining thread, or while nothing
    // refines. Two threads may measure at once (the const functions): the
    // pool and its buffers are claimed with a flag (one atomic exchange,
    // never a wait) and the call that finds them taken computes serially,
    // with the same bits; two pool jobs never run at once. No allocation and
    // no lock; the pool's barrier is refine()'s (a bounded spin, then a futex
    // wait for a worker still running a task).
    // Jobs run on the pool so far, refinement and measurements (for tests).
    uint64_t poolJobs() const noexcept;

    // ---- perplexity -----------------------------------------------------
    // p(w_i) = sum_k phi_k(w_i) theta_G(k), with word i left out of its own
    // counts (n_k^v, n_k and n_G^k each lose one at z_i): the predictive
    // probability of the word given every other label, the same quantity
    // whose terms eq. 5 normalises. Used identically for every perplexity.
    LogLoss cellLogLoss(int64_t step, int cell) const noexcept;
    LogLoss stepLogLoss(int64_t step) const noexcept;
    double stepPerplexity(int64_t step) const noexcept { return stepLogLoss(step).perplexity(); }
    double cellPerplexity(int64_t step, int cell) const noexcept { return cellLogLoss(step, cell).perplexity(); }
    // log p(w_i) of one stored word (slot within its cell).
    double wordLogProb(int64_t step, int cell, uint32_t slot) const noexcept;

    // ---- plug-in perplexity (the 2013 ROST code's) -----------------------
    // p(w_i) = sum_k phi_k(w_i) theta_c(k), phi_k(v) = (n_k^v + beta) /
    // (n_k + V beta), theta_c(k) = (n_c^k + alpha) / (n_c + K alpha): every
    // count as it stands, word i included (not left out), and the topic mix
    // of the word's own cell alone (not its neighbourhood). This is what the
    // public ROST code of the paper computed (ROST::estimate with update_ppx,
    // yogeshgirdhar/rost-ros, rost_topics/include/rost.hpp; docs/design.md);
    // it rewards a word for its own label, so it lies below the left-out
    // perplexity above. src/core/plugin_perplexity.cpp; never allocates.
    LogLoss cellPluginLogLoss(int64_t step, int cell) const noexcept;
    LogLoss stepPluginLogLoss(int64_t step) const noexcept;
    double stepPluginPerplexity(int64_t step) const noexcept { return stepPluginLogLoss(step).perplexity(); }

    // ---- curiosity ------------------------------------------------------
    // Surprise of an observation, computed when it is added, before its own
    // words touch any count: the perplexity of its words under the model as
    // it stood, p(w) = sum_k phi_k(w) theta_past(k), where theta_past is the
    // topic mix of the cell's neighbourhood in earlier steps (same spatial
    // shape, steps t-1 .. t-g.time; the global topic mix when that is empty).
    // Per cell, and per observation (over all its words).
    double observationSurprise(uint64_t frame) const noexcept;
    // Surprise of each cell of the observation's step as of its latest
    // observation; cells with no words hold 0.
    std::span<const float> cellSurprise(int64_t step) const noexcept;

    // ---- outputs --------------------------------------------------------
    // Kept words and positions of an observation, in input order.
    uint32_t observationSize(uint64_t frame) const noexcept;
    void observationWords(uint64_t frame, std::span<uint32_t> out) const noexcept;
    void observationPositions(uint64_t frame, std::span<Position> out) const noexcept;
    // Maximum-likelihood topic of each kept word (argmax of the left-out
    // conditional, ties to the lowest topic), in input order.
    void observationLabels(uint64_t frame, std::span<uint16_t> out) const noexcept;
    // The final measurements of `perplexity.size()` observations from
    // `first` at once (the end of a stream): perplexity[i] is
    // stepPerplexity() of observation first + i's step, and labels[i *
    // stride, ...) its observationLabels(), the first min(stride,
    // observationSize()) of them; the same bits. With workers, one pool job
    // a task per observation, so the workers have whole observations to
    // take instead of a job of a few microseconds a measurement.
    // labels.size() >= perplexity.size() * stride. No allocation.
    void finalMeasurements(uint64_t first, std::span<double> perplexity, std::span<uint16_t> labels,
                           std::size_t stride) const noexcept;
    // The current Gibbs sample z_i of each kept word, in input order; a word
    // its cell had no room for (never in the counts) gets its ML label.
    void observationSamples(uint64_t frame, std::span<uint16_t> out) const noexcept;
    // n_c^k of a cell (K values).
    std::span<const int32_t> cellHistogram(int64_t step, int cell) const noexcept;
    uint32_t cellWordCount(int64_t step, int cell) const noexcept;

    int32_t topicWordCount(int k, int v) const noexcept { return nkv_[static_cast<std::size_t>(v) * Kp_ + k]; }
    int32_t topicCount(int k) const noexcept { return nk_[k]; }
    // Words counted in n_k^v (with EvictionPolicy::Keep this includes evicted steps).
    uint64_t wordsInModel() const noexcept { return words_in_model_; }
    // phi as an Eigen matrix: topicModelMatrix() in rost/model_eigen.hpp (this header has no Eigen).
    // Adds K x V counts (row-major, topic by word) learned elsewhere to n_k^v and n_k;
    // they act as a prior that refinement never removes. Set-up only.
    Status addTopicCounts(std::span<const int32_t> counts);

    // Recomputes every count from the labels and compares; on failure `why` says what differs.
    bool checkInvariants(std::string* why = nullptr) const;

    // Bytes allocated for all tables and the ring; fixed at construction.
    std::size_t memoryBytes() const noexcept { return memory_bytes_; }

    Rng& rng() noexcept { return rng_; }

    // Every part of the state that changes after construction, as named
    // sections in a fixed order (rost/state_layout.hpp): the counters, the
    // RNG, the count tables and cached reciprocals, the ring. Their sizes
    // follow from the Config alone, so a checkpoint is the Config plus these
    // sections, and writing them back into a Model built from the same
    // Config resumes it exactly. Appends to `out`; allocates nothing.
    void describeState(StateLayout& out) noexcept;

private:
    std::size_t slotOf(int64_t step) const noexcept { return static_cast<std::size_t>(step % ring_); }
    // The prior mass of opening a new topic: gamma while topics grow and
    // there is room, else 0 (docs/design.md, "Topics that grow").
    double freshMass() const noexcept { return cfg_.grow && tables_.active < K_ ? cfg_.gamma : 0.0; }
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
    void liveTask(int worker, uint32_t task) noexcept;
    template <int KP>
    void setTaskKernels() noexcept;
    // The parts of addObservation, in order (ring slot `slot`, input row `obs`).
    void openStep(int64_t step, std::size_t slot) noexcept;
    uint32_t keepInputs(std::span<const uint32_t> words, std::span<const Position> positions, std::size_t obs) noexcept;
    void fillCells(std::size_t slot, std::size_t obs, uint32_t kept, AddResult& res) noexcept;
    void observeSurprise(int64_t step, std::size_t slot, std::size_t obs, const uint32_t* firstNew) noexcept;
    void drawInitialLabels(std::size_t slot, const uint32_t* firstNew) noexcept;
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
    const int32_t* cachedNeighbourhood(int64_t step, int cell) const noexcept;
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
    AlignedBuffer<uint32_t> scratch_count_;  // per cell
    AlignedBuffer<uint32_t> scratch_need_;   // per cell
    AlignedBuffer<int32_t> scratch_g_;       // Kp
    AlignedBuffer<double> scratch_ll_;       // per cell (surprise)
    AlignedBuffer<uint32_t> scratch_wn_;     // per cell (surprise word counts)
    // Output-side cache of neighbourhood sums (cells x Kp) for const output
    // functions; like everything else, a Model is used by one thread at a time.
    mutable AlignedBuffer<int32_t> out_g_;
    mutable AlignedBuffer<uint64_t> out_g_epoch_;
    mutable uint64_t out_epoch_ = 0;

    Rng rng_;
    kernel::Path path_ = kernel::Path::Simd;
    using CellsKernel = uint32_t (Model::*)(const StepSlots&, int, int) noexcept;
    CellsKernel simd_kernel_;
    CellsKernel scalar_kernel_;
    using TaskKernel = void (Model::*)(int, uint32_t) noexcept;
    TaskKernel frozen_kernel_[2] = {};  // [Scalar, Simd]
    TaskKernel live_kernel_[2] = {};
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
    bool nkv_is_window_ = true;  // false once counts outside the window (prior, kept evictions) exist
    std::size_t memory_bytes_ = 0;

public:
    static constexpr uint32_t kDropped = 0x80000000u;
};

} // namespace rost
