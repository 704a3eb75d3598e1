#pragma once

// The realtime engine (paper Algorithm 2 with a fixed-memory design):
//
//   producer (capture) --tryPush--> ObservationQueue (SPSC, preallocated slots)
//        --> refiner (the only writer of the Model): ingest one observation,
//            refine time steps t ~ P(t|T) until the budget is spent, publish
//        --> readers: readSnapshot() (lock-free seqlock), counters()
//
// Two ways to drive it, with the same code path and the same results:
//  * threaded: start() spawns the refiner thread; a producer thread calls
//    tryPush(); any thread reads snapshots and counters; stop().
//  * synchronous: processNow() ingests and refines one observation on the
//    calling thread (replay, the tool's non-realtime path, tests).
// Under a count budget (steps or tokens per observation) both give identical
// labels for the same seed and stream, bit for bit, whatever the timing.
//
// After start() nothing on the producer, refiner or reader path allocates,
// locks, throws or makes a blocking syscall. (The refiner sleeps in 50 us
// steps when it has nothing to do; hooks run on the refiner thread and are
// the caller's responsibility.) See docs/engine.md.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "rost/config.hpp"
#include "rost/model.hpp"
#include "rost/realtime.hpp"
#include "rost/settings_schema.hpp"
#include "rost/snapshot.hpp"
#include "rost/state_layout.hpp"
#include "rost/status.hpp"
#include "rost/strategy.hpp"

namespace rost {

class ObservationQueue;

// Refinement budget per observation.
enum class BudgetKind : uint8_t {
    Steps,   // `count` time-step refinements (the paper's R); deterministic
    Tokens,  // refine cell by cell until `count` tokens were refined; deterministic
    Time,    // refine until `ms` (the paper's T_R) after the observation was taken up
};
struct Budget {
    BudgetKind kind = BudgetKind::Steps;                          // the schema's default key: budget.refines
    uint64_t count = settingDefault<uint64_t>("budget.refines");  // Steps or Tokens
    double ms = 0.0;                                              // Time

    static Budget steps(uint64_t r) noexcept { return {BudgetKind::Steps, r, 0.0}; }
    static Budget tokens(uint64_t n) noexcept { return {BudgetKind::Tokens, n, 0.0}; }
    static Budget time(double ms) noexcept { return {BudgetKind::Time, 0, ms}; }
    bool deterministic() const noexcept { return kind != BudgetKind::Time; }
};

// What happens when the producer pushes into a full queue. Either way the
// loss is counted and nothing else breaks.
enum class DropPolicy : uint8_t {
    DropNewest,  // the pushed observation is refused (tryPush returns false)
    DropOldest,  // the oldest queued observation not yet taken up by the refiner is
                 // discarded and the new one queued (keeps the freshest frames);
                 // if the refiner is taking up the only candidate, the newest is dropped
};
const char* toString(DropPolicy p) noexcept;
Status parseDropPolicy(const std::string& text, DropPolicy& out);  // "newest" | "oldest"

struct EngineFlags {
    // Compute the instantaneous perplexity of step t just before step t+1 is
    // added (O(words K) per step, on the refiner).
    bool instantaneous_perplexity = settingDefault<bool>("ppx.instantaneous");
    // Compute the newest step's perplexity when publishing (O(words K)).
    bool snapshot_perplexity = settingDefault<bool>("ppx.snapshot");
    // Publish the newest observation's labels and cell histograms.
    bool snapshot_labels = settingDefault<bool>("snapshot.labels");
    // Time budget only: stop refining as soon as a newer observation is
    // queued (paper Algorithm 2, "while no new observation").
    bool stop_on_arrival = settingDefault<bool>("stop-on-arrival");
};

struct EngineConfig {
    Config model;
    StrategyConfig strategy;
    Budget budget;
    int queue_slots = settingDefault<int>("queue.slots");  // observations the queue holds
    DropPolicy drop = settingDefault<DropPolicy>("drop");
    ThreadSettings thread;  // refiner thread scheduling (defaults: none requested)
    EngineFlags flags;

    // Checks everything (Model config included); the message names the field.
    [[nodiscard]] Status validate() const;
};

// One observation as the producer hands it over: it is copied into a queue
// slot, so the spans need only live for the call.
struct ObservationView {
    int64_t timestamp = 0;  // any unit (frame number, microseconds); carried through
    std::span<const uint32_t> words;
    std::span<const Position> positions;  // same length as words
};

// Results of one observation, handed to the observation hook on the thread
// that refined it, after its budget was spent and its snapshot published.
struct ObservationResult {
    uint64_t observation = 0;  // index among ingested observations (Model frame index)
    uint64_t sequence = 0;     // producer sequence number
    int64_t timestamp = 0;
    int64_t step = -1;         // Model's 0-based step (-1 if rejected)
    AddResult add;             // what the model did with the words (error when rejected)
    double surprise = std::numeric_limits<double>::quiet_NaN();
    // Instantaneous perplexity of step `previous_step` (= step - 1), computed
    // just before this observation opened a new step; NaN when this
    // observation did not open a step, for the first step, or when disabled.
    int64_t previous_step = -1;
    double previous_perplexity = std::numeric_limits<double>::quiet_NaN();
    // The same step's plug-in perplexity at the same instant (Model::stepPluginPerplexity,
    // the 2013 ROST code's definition); NaN whenever previous_perplexity is.
    double previous_plugin = std::numeric_limits<double>::quiet_NaN();
    double perplexity = std::numeric_limits<double>::quiet_NaN();  // of `step` after refinement
    uint64_t refinements = 0;  // time-step draws
    uint64_t tokens = 0;       // tokens refined
    uint64_t rounds = 0;       // rounds of refinement (Model::refine; a time budget stops between two)
    int active_topics = 0;     // open topics after refinement (Model::activeTopics; K without growth)
    int64_t elapsed_ns = 0;    // take-up to publish
    int64_t refine_ns = 0;     // spending the budget (refinement only)
    int64_t overrun_ns = 0;    // past the time-budget deadline (0 when met or not a time budget)
};

// An observation still in the ring: handed to the eviction hook just before
// its time step leaves the window (labels still readable from the model),
// and by visitWindow().
struct WindowObservation {
    uint64_t observation = 0;
    uint64_t sequence = 0;
    int64_t timestamp = 0;
    int64_t step = 0;
};

using ObservationHook = std::function<void(const ObservationResult&, const Model&)>;

// Results the engine publishes itself (Engine::publishResults): one record
// per observation taken up, read by any one consumer thread with
// Engine::readResult. Sized once (makeResult); copying one in or out does
// not allocate.
struct PublishedResult {
    ObservationResult result;
    // The observation's time step after its budget (zeros when rejected):
    std::vector<int32_t> histograms;   // cells x K topic counts, cell-major
    std::vector<float> cell_surprise;  // per cell
    // K: the model's slot of each label (Model::slotsInLabelOrder) when the
    // result was published. A topic keeps its slot while it is open, where
    // with topics.grow its label moves as topics below it close and open.
    std::vector<uint16_t> topic_slots;
};

// An observation leaving the window: its final labels (Engine::readFinal).
struct FinalLabels {
    WindowObservation where;
    double perplexity = 0.0;  // of its step, when it left
    uint32_t n = 0;           // words (at most max.words)
    std::vector<uint32_t> words;
    std::vector<Position> positions;
    std::vector<uint16_t> labels;
};

class CheckpointWriter;
using EvictionHook = std::function<void(const WindowObservation&, const Model&)>;

struct EngineMemory {
    std::size_t model = 0;     // Model::memoryBytes()
    std::size_t queue = 0;     // observation slots
    std::size_t snapshot = 0;  // publisher buffers + the refiner's staging snapshot
    std::size_t other = 0;     // per-observation bookkeeping of the window
    std::size_t total() const noexcept { return model + queue + snapshot + other; }
};

// The engine's counters as its state holds them ("engine.counters"): the
// refiner's, the producer's losses as of the last observation taken up, and
// the producer's next sequence number. Twelve little-endian uint64 in a checkpoint.
struct EngineStateCounters {
    uint64_t ingested = 0;
    uint64_t rejected = 0;
    uint64_t words_dropped_cell = 0;
    uint64_t refinements = 0;
    uint64_t tokens = 0;
    uint64_t overruns = 0;
    uint64_t max_overrun_ns = 0;
    uint64_t published = 0;
    uint64_t dropped_newest = 0;
    uint64_t dropped_oldest = 0;
    uint64_t words_truncated = 0;  // at push, in the observations taken up
    uint64_t next_sequence = 0;
};
static_assert(sizeof(EngineStateCounters) == 12 * sizeof(uint64_t));

// The time-budget cost predictors ("engine.predictors").
struct EngineStatePredictors {
    double ns_per_token = 0.0;
    double publish_ns = 0.0;
};
static_assert(sizeof(EngineStatePredictors) == 2 * sizeof(double));

class Engine {
public:
    // Throws std::invalid_argument with validate()'s message on a bad configuration.
    explicit Engine(const EngineConfig& cfg);
    // Non-throwing factory: nullptr and `status` set on a bad configuration.
    static std::unique_ptr<Engine> create(const EngineConfig& cfg, Status& status);
    ~Engine();  // stops the refiner if running: stop(Discard), the budget in hand cut short

    Engine(const Engine&) = delete;
    Engine& operator=(const Engine&) = delete;
    Engine(Engine&&) = delete;
    Engine& operator=(Engine&&) = delete;

    const EngineConfig& config() const noexcept { return cfg_; }
    // Everything allocated, known before start() and never grown.
    EngineMemory memory() const noexcept;
    std::size_t memoryBytes() const noexcept { return memory().total(); }

    // ---- set-up (not while running) -----------------------------------------
    // Called on the refining thread after each observation (see ObservationResult).
    // Publication for a consumer thread (set-up only: before start(); allocates).
    // The refiner copies each observation's results, and each leaving
    // observation's final labels, into engine-owned rings of `slots` records
    // (0: off; the finals' ring holds one leaving step's cell.time more) as
    // part of its publish step: no allocation, no lock. A full ring drops the
    // record and counts it (resultsLost()).
    Status publishResults(std::size_t slots);
    PublishedResult makeResult() const;  // a record sized for readResult (allocates)
    FinalLabels makeFinal() const;       // a record sized for readFinal (allocates)
    // Consumer (one thread at a time): the oldest unread record; false when none.
    bool readResult(PublishedResult& out) noexcept;
    bool readFinal(FinalLabels& out) noexcept;
    uint64_t resultsLost() const noexcept;
    // Periodic checkpoints (set-up only): after every `every`-th observation
    // taken up, the refiner captures its state into `writer` at that
    // observation boundary (CheckpointWriter::captureEvery; its stall bound).
    // nullptr detaches.
    void captureCheckpoints(CheckpointWriter* writer, uint64_t every) noexcept;

    void setObservationHook(ObservationHook hook);
    // Called on the refining thread for each observation of a step about to
    // leave the window, before the observation that evicts it is added.
    void setEvictionHook(EvictionHook hook);
    const ObservationHook& observationHook() const noexcept { return on_observation_; }
    const EvictionHook& evictionHook() const noexcept { return on_evict_; }
    // The model, for set-up (Model::addTopicCounts) and for reading when the
    // engine is not running (after stop(), or in synchronous mode).
    Model& model() noexcept { return *model_; }
    const Model& model() const noexcept { return *model_; }
    // Strategy draws use the model's Rng, so Model::rng() is the engine's whole random state.
    const Strategy& strategy() const noexcept { return strategy_; }

    // ---- threaded mode ------------------------------------------------------
    // Spawns the refiner thread with the configured ThreadSettings (fallbacks
    // logged to stderr once). Error if already running.
    Status start();
    enum class StopMode : uint8_t {
        Drain,    // the refiner first takes up every queued observation, each with its budget
        Discard,  // the observation in hand's refinement is cut short at its next window (it
                  // is still published); queued ones stay queued
    };
    // Signals the refiner and joins it. Idempotent.
    void stop(StopMode mode = StopMode::Drain);
    bool running() const noexcept { return running_.load(std::memory_order_acquire); }
    // True on this engine's refiner thread while it runs (its hooks run
    // there): where the state may be read while running (rost/checkpoint.hpp).
    bool onRefinerThread() const noexcept;

    // ---- producer (one thread at a time) ------------------------------------
    // Copies the observation into a free slot and publishes it. Never blocks,
    // never allocates. Words beyond max_words_per_frame are uniformly
    // subsampled (seeded by the sequence number) and counted. Returns false
    // when the observation itself was dropped (queue full); under DropOldest
    // it is queued and an older one is dropped instead whenever possible.
    [[nodiscard]] bool tryPush(const ObservationView& obs) noexcept;
    // For producers that must not lose data (offline replay through the
    // threads): waits (yield, then 50 us sleeps) until a slot is free, never
    // drops. False on timeout, or when the queue is full and the engine is
    // not running (nothing would free a slot). Before start(), as with
    // tryPush(), an observation with a free slot is queued for the refiner.
    bool pushWait(const ObservationView& obs,
                  std::chrono::nanoseconds timeout = std::chrono::nanoseconds::max()) noexcept;
    // Producer side: a slot is free, so a tryPush() now would not drop.
    bool canPush() noexcept;
    // Observations queued and not yet taken up (approximate while running).
    // A slot being ingested is not counted here but is not free either.
    uint32_t queued() const noexcept;

    // ---- readers (any thread) -----------------------------------------------
    // Copies the newest published results into `out` (sized for this
    // engine's Config by Snapshot::reserve / makeSnapshot). Never blocks the
    // refiner. False when nothing was published yet or `out` was not sized
    // for this engine (its K and cells a step must be this engine's).
    bool readSnapshot(Snapshot& out) const noexcept;
    Snapshot makeSnapshot() const { return Snapshot(cfg_.model); }  // allocates: set-up only
    // Counters right now (each field read atomically; fields may be from
    // slightly different instants while running).
    EngineCounters counters() const noexcept;

    // ---- synchronous mode (engine not running) ------------------------------
    // Pushes `obs` and processes it on the calling thread: ingest, budget,
    // publish, hooks. Same path and results as the refiner thread. Returns
    // the observation's result (add.error set when the model rejected it).
    // Not while the engine runs (tryPush is the way in then): nothing is
    // processed or queued, and the result has step -1 with add.error None.
    ObservationResult processNow(const ObservationView& obs) noexcept;
    // Processes observations queued by tryPush() on the calling thread.
    // Returns how many were taken up.
    uint64_t processPending() noexcept;
    // Spends `budget` (counted or timed) more with the strategy, on the calling
    // thread, without a new observation: e.g. the idle time at the end of a stream.
    uint64_t refineExtra(const Budget& budget) noexcept;
    // Final pass: `sweeps` batch Gibbs sweeps over the whole window (Model::refineAll).
    uint64_t finalPass(int sweeps) noexcept;
    // The same, ending early (between windows of refinement) once *stop
    // reads true: a flag set by a signal handler, for instance.
    uint64_t finalPass(int sweeps, const std::atomic<bool>* stop) noexcept;
    // Calls `visit` for every observation still in the window, oldest first
    // (e.g. to record final labels at the end of a stream).
    void visitWindow(const EvictionHook& visit) const;
    // Same, with the eviction hook: after this, every ingested observation
    // has passed through the eviction hook exactly once. The observations it
    // flushed do not go through the hook again when they later leave the
    // ring (observations added after a flush, a second replay() on the same
    // engine), nor at a second flush; a restored state (applyState) starts
    // this afresh. Not while the engine runs (nothing happens then).
    void flushWindowToEvictionHook();

    // ---- checkpoint support (rost/checkpoint.hpp) ---------------------------
    // The engine's whole state as one layout (rost/state_layout.hpp): the
    // Model's sections (Model::describeState), then the engine's own, of
    // sizes fixed by the Config: "engine.counters" (EngineStateCounters),
    // "engine.predictors" (EngineStatePredictors), "engine.window.timestamp"
    // and "engine.window.sequence" (ring_steps x cell_time int64/uint64).
    // Also copies the counters and predictors into the sections, so reading
    // them right after gives the current state. When the engine is not
    // running, or on the refining thread (in the observation hook): no
    // allocation, no lock.
    void describeState(StateLayout& out) noexcept;
    // After the sections of describeState() were overwritten: puts the
    // counters and predictors back in use. Set-up only: error when running or
    // when observations are queued. The producer's next push gets the saved
    // next sequence number.
    Status applyState();

private:
    struct Refiner;
    bool takeUpOne(ObservationResult* out) noexcept;
    // The parts of takeUpOne: a rejected observation's result and hook; the
    // instantaneous perplexity and eviction hook before an observation opens
    // a step; the budget, publication and timing.
    void reject(ObservationResult& r, ObservationResult* out) noexcept;
    void beforeObservation(ObservationResult& r) noexcept;
    void refineAndPublish(ObservationResult& r, std::chrono::steady_clock::time_point t0,
                          std::chrono::steady_clock::time_point deadline) noexcept;
    void refinerMain() noexcept;
    uint64_t spend(const Budget& budget, std::chrono::steady_clock::time_point deadline, bool newest,
                   uint64_t* tokens_out, uint64_t* rounds_out = nullptr) noexcept;
    class TimeControl;
    // The window's observations from `first` on (the oldest in the window at the earliest).
    void visitWindowFrom(uint64_t first, const EvictionHook& visit) const;
    void publish(const ObservationResult& r) noexcept;

    EngineConfig cfg_;
    std::unique_ptr<Model> model_;
    Strategy strategy_;
    std::unique_ptr<ObservationQueue> queue_;
    std::unique_ptr<SnapshotPublisher> publisher_;
    std::unique_ptr<Refiner> refiner_;  // refiner-side state (staging snapshot, window bookkeeping)
    struct Publication;
    void publishResult(const ObservationResult& r) noexcept;
    void publishFinal(const WindowObservation& w) noexcept;
    void afterObservation(const ObservationResult& r) noexcept;
    std::unique_ptr<Publication> pub_;
    CheckpointWriter* checkpoints_ = nullptr;
    uint64_t checkpoint_every_ = 0;
    ObservationHook on_observation_;
    EvictionHook on_evict_;
    uint64_t evicted_through_ = 0;  // observations before it have been through on_evict_ (flushed)
    std::thread thread_;
    std::atomic<std::thread::id> refiner_thread_{};  // onRefinerThread(): set by the thread as it starts
    std::atomic<bool> running_{false};
    alignas(kCacheLine) std::atomic<int> stop_request_{0};  // 0 none, 1 drain, 2 discard
    std::atomic<bool> cut_short_{false};  // stop(Discard): the refinement in hand starts no further window
};

} // namespace rost
