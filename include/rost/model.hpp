#pragma once

// The spatiotemporal topic model of the paper (sections III-V) over a fixed
// ring of temporal cells. Single-threaded: exactly one thread (the refiner)
// may call its mutating functions. Nothing allocates after construction.
// The implementation (the ring store, refinement, measurements) is the
// library's own: src/core/model_core.hpp.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "rost/config.hpp"
#include "rost/kernel_types.hpp"
#include "rost/position.hpp"
#include "rost/random.hpp"
#include "rost/state_layout.hpp"
#include "rost/status.hpp"

namespace rost {

struct ThreadSettings;
namespace detail {
class ModelCore;
}

enum class AddError : uint8_t {
    None,
    SizeMismatch,        // words and positions (or the given initial labels) differ in length
    WordOutOfRange,      // a word id >= V
    PositionOutOfRange,  // a position outside [0, width) x [0, height)
    LabelOutOfRange,     // a given initial label >= K (addObservation with labels)
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
    // When set, no further window starts once it reads true (an interruption,
    // e.g. Ctrl-C during a final pass; what was refined stays). Unlike a
    // control it leaves the rounds as they are without one: the results of
    // a run it does not stop are the same bits.
    const std::atomic<bool>* stop = nullptr;
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

// What a checkpoint's state failed on (Model::checkRestoredState): the
// state section (rost/state_layout.hpp) and element that hold the bad value,
// and what is wrong with it.
struct StateProblem {
    std::string section;
    std::size_t element = 0;
    std::string what;
};

// The model's API. Its tables (the ring of cells, the count tables, the
// kernel's view of them) live behind the implementation (src/core/model_core.hpp),
// as the Engine's do: no installed header names a buffer.
class Model {
public:
    // Throws std::invalid_argument with Config::validate()'s message on a bad configuration.
    explicit Model(const Config& config);
    // Non-throwing factory: returns nullptr and sets status on a bad configuration.
    static std::unique_ptr<Model> create(const Config& config, Status& status);

    ~Model();
    Model(const Model&) = delete;
    Model& operator=(const Model&) = delete;

    const Config& config() const noexcept;
    int K() const noexcept;
    // Active topics A: labels are 0..A-1. K without topic growth; with
    // topics.grow, the topics opened so far (1 at the start, at most K).
    int activeTopics() const noexcept;
    // True when topics grow and every one of the K topics is open.
    bool topicCapReached() const noexcept;
    // Growth from the data (docs/design.md): the split and merge moves
    // accepted so far in this process (not checkpointed), and the
    // concentration gamma the last moves used (0 before the first).
    uint64_t growthMovesAccepted() const noexcept;
    double learnedGamma() const noexcept;
    // Whether topic k is open (holds a word; always, without growth).
    bool topicOpen(int k) const noexcept;
    // Output numbering of the topics (docs/design.md, "Topics that grow"):
    // map[k] = the number of open topics below k, so open topics are numbered
    // 0..A-1 in label order (0xFFFF for a closed one). Without growth the
    // identity. observationLabels and observationSamples are numbered this
    // way; cellHistogram, topicWordCount and topicCount are indexed by topic
    // slot k (0..K-1, open or not): map[k] is slot k's label. map.size() >= K.
    void outputNumbering(std::span<uint16_t> map) const noexcept;
    // Its inverse, with the closed slots after: slots[i] is the slot labelled
    // i for i < activeTopics(), then the closed slots in slot order. A topic
    // model's rows in this order are what every face writes and reads
    // (topicmodel.csv holds the first activeTopics() of them; Python's
    // topic_model() and rost_node's ~get_topic_model all K, the closed slots'
    // zero rows last; rost_node's ~topic_model is by slot, and each published
    // result carries this map, PublishedResult::topic_slots). Without growth
    // the identity. slots.size() >= K.
    void slotsInLabelOrder(std::span<uint16_t> slots) const noexcept;
    int V() const noexcept;
    int cellsPerStep() const noexcept;

    // ---- ingest ---------------------------------------------------------
    // Adds one observation (the next time step). Words land in cell
    // (t / cell.time, x / cell.space, y / cell.space) with uniformly random
    // initial topics (paper Algorithm 2). Input beyond max_words_per_frame or
    // a cell's capacity is uniformly subsampled (selection sampling, seeded)
    // and counted. On error nothing changes. Never allocates.
    AddResult addObservation(std::span<const uint32_t> words, std::span<const Position> positions) noexcept;
    // The same with each word's initial topic given (`labels`, one a word,
    // each < K; with growth the topics they name are open) instead of drawn:
    // a run started from earlier labels (rost-cli's --in.topics). A word
    // subsampled away takes its label with it. Never allocates.
    AddResult addObservation(std::span<const uint32_t> words, std::span<const Position> positions,
                             std::span<const uint16_t> labels) noexcept;
    // The checks addObservation makes before it changes anything (sizes,
    // word ids < V, positions inside the frame): the first offending word.
    AddResult validateObservation(std::span<const uint32_t> words, std::span<const Position> positions) const noexcept;

    uint64_t observations() const noexcept;
    // Temporal cells so far (the paper's T, counting from 1). Step indices run 0..steps()-1.
    int64_t steps() const noexcept;
    // Oldest step still in the ring (refinable).
    int64_t oldestStep() const noexcept;
    bool inWindow(int64_t step) const noexcept;
    int64_t stepOfObservation(uint64_t frame) const noexcept;
    bool observationInWindow(uint64_t frame) const noexcept;

    // ---- refinement -------------------------------------------------------
    // Refines every word of one cell / one time step once, cells in index
    // order and a cell's words in the order they were added. Returns the
    // number of tokens refined (0 for a step outside the window).
    uint32_t refineCell(int64_t step, int cell) noexcept;
    uint32_t refineStep(int64_t step) noexcept;
    // Batch Gibbs (paper Algorithm 1): `sweeps` passes over every cell of the
    // window, in windows of refine.window cell refinements (below).
    uint64_t refineAll(int sweeps = 1) noexcept;
    // The same, ending early (between windows) once *stop reads true.
    uint64_t refineAll(int sweeps, const std::atomic<bool>* stop) noexcept;

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
    int colours() const noexcept;
    int colourStride() const noexcept;
    int colourOf(int64_t step, int cell) const noexcept;
    uint64_t tokensRefined() const noexcept;
    // Words currently in cells of a step.
    uint32_t wordsInStep(int64_t step) const noexcept;

    // Selects the scalar reference or the SIMD kernel (default: SIMD).
    void setKernelPath(kernel::Path p) noexcept;
    kernel::Path kernelPath() const noexcept;

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
    // Surprise of each cell of the step: of the words the step's latest
    // observation to add words to the cell brought (a cell a later
    // observation of the step adds none to keeps its value); a cell with no
    // words holds 0.
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

    int32_t topicWordCount(int k, int v) const noexcept;
    int32_t topicCount(int k) const noexcept;
    // Words counted in n_k^v (with EvictionPolicy::Keep this includes evicted steps).
    uint64_t wordsInModel() const noexcept;
    // phi as an Eigen matrix: topicModelMatrix() in rost/model_eigen.hpp (this header has no Eigen).
    // Adds K x V counts (row-major, topic by word) learned elsewhere to n_k^v and n_k;
    // they act as a prior that refinement never removes. Set-up only. Refused,
    // the model unchanged, for a negative count or a topic whose total with the
    // model's own would leave its 32-bit n_k no room for every word the window
    // can hold, and one more.
    Status addTopicCounts(std::span<const int32_t> counts);

    // Recomputes every count from the labels and compares; on failure `why` says what differs.
    bool checkInvariants(std::string* why = nullptr) const;

    // Bytes allocated for all tables and the ring; fixed at construction.
    std::size_t memoryBytes() const noexcept;

    Rng& rng() noexcept;

    // ---- state --------------------------------------------------------------
    // Every part of the state that changes after construction, as named
    // sections in a fixed order (rost/state_layout.hpp): the counters, the
    // RNG, the count tables and cached reciprocals, the ring. Their sizes
    // follow from the Config alone, so a checkpoint is the Config plus these
    // sections, and writing them back into a Model built from the same
    // Config resumes it exactly. Appends to `out`; allocates nothing.
    void describeState(StateLayout& out) noexcept;
    // After the sections were written back from an untrusted source (a
    // checkpoint file) and before anything reads them: every value the model
    // could index with, divide by or count is in range (counters, which
    // step each ring slot holds, word ids, labels, cell sizes, input slots,
    // positions, surprises; n_k^v at least the window's own words). False
    // and `problem` at the first bad value. Then stateRestored() and
    // checkInvariants() compare the counts with the labels.
    bool checkRestoredState(StateProblem& problem) const;
    // Call after the state sections (describeState) were written back.
    void stateRestored() noexcept;

    // The implementation, for the library's own code (the engine, checkpoints).
    detail::ModelCore& core() noexcept { return *core_; }
    const detail::ModelCore& core() const noexcept { return *core_; }

private:
    std::unique_ptr<detail::ModelCore> core_;
};
} // namespace rost
