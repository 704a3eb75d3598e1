#include "rost/engine.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "engine_refiner.hpp"
#include "observation_queue.hpp"
#include "predictor.hpp"
#include "rost/checkpoint.hpp"
#include "rost/settings.hpp"
#include "spsc_ring.hpp"

namespace rost {

using Clock = std::chrono::steady_clock;

namespace {

// Single-writer counter update: a load and a store, no read-modify-write.
inline void bump(std::atomic<uint64_t>& a, uint64_t d = 1) noexcept {
    a.store(a.load(std::memory_order_relaxed) + d, std::memory_order_relaxed);
}

using detail::robustAverage;  // src/core/predictor.hpp

// A step's cell histograms (cells x K) in the output numbering: with growth the
// open topics are 0..A-1 (a closed topic holds no word, so nothing is lost), as
// the labels are. No allocation: the map is on the stack (K <= 1024).
void outputHistograms(const Model& m, int64_t step, std::size_t cells, int32_t* out) noexcept {
    const auto K = static_cast<std::size_t>(m.K());
    uint16_t map[1024];
    m.outputNumbering({map, K});
    for (std::size_t c = 0; c < cells; ++c, out += K) {
        const std::span<const int32_t> h = m.cellHistogram(step, static_cast<int>(c));
        std::fill_n(out, K, 0);
        if (h.size() != K) continue;
        for (std::size_t k = 0; k < K; ++k)
            if (map[k] != 0xFFFF) out[map[k]] = h[k];
    }
}

} // namespace

// ---- configuration --------------------------------------------------------------

// The names are the schema's (the `drop` row's choices, in enum order).
const char* toString(DropPolicy p) noexcept { return choiceName(settingSpec("drop"), static_cast<std::size_t>(p)); }

Status parseDropPolicy(const std::string& text, DropPolicy& out) {
    const int i = choiceIndexOf(settingSpec("drop"), text);
    if (i < 0) return Status::error("unknown drop policy '" + text + "' (" + choiceExpected(settingSpec("drop")) + ")");
    out = static_cast<DropPolicy>(i);
    return {};
}

Status EngineConfig::validate() const {
    // Every field's range from the settings schema, then the model's combinations.
    if (auto p = checkEngineSettings(*this)) return Status::error("invalid configuration: " + p->describe(p->spec->key));
    return {};
}

// ---- Engine -------------------------------------------------------------------

Engine::Engine(const EngineConfig& cfg) : cfg_(cfg) {
    if (Status s = cfg.validate(); !s.ok()) throw std::invalid_argument(s.message());
    model_ = std::make_unique<Model>(cfg.model);
    strategy_ = Strategy(cfg.strategy);
    queue_ = std::make_unique<ObservationQueue>(static_cast<uint32_t>(cfg.queue_slots),
                                                static_cast<uint32_t>(cfg.model.max_words_per_frame),
                                                cfg.model.seed ^ 0x5DEECE66Dull);
    publisher_ = std::make_unique<SnapshotPublisher>(cfg.model);
    refiner_ = std::make_unique<Refiner>(cfg.model);
    // Conservative until the first publication is measured: 0.5 ms, or an
    // eighth of a smaller time budget.
    refiner_->publish_ns = std::min(5e5, cfg.budget.ms * 1e6 / 8);
}

std::unique_ptr<Engine> Engine::create(const EngineConfig& cfg, Status& status) {
    status = cfg.validate();
    if (!status.ok()) return nullptr;
    try {
        return std::make_unique<Engine>(cfg);
    } catch (const std::bad_alloc&) {  // valid settings this machine cannot hold: named, to lower one
        // The queue's slots each hold max.words inputs: named with the tables.
        status = Status::error(StatusKind::OutOfMemory, "engine: not enough memory for the model's tables: " +
                                                            cfg.model.tablesText() + ", queue.slots = " +
                                                            std::to_string(cfg.queue_slots) + "; lower one of them");
        return nullptr;
    } catch (const std::exception& e) {
        status = Status::error(std::string("engine: ") + e.what());
        return nullptr;
    }
}

Engine::~Engine() { stop(StopMode::Discard); }

// ---- publication of results to a consumer thread ------------------------------

struct Engine::Publication {
    Publication(std::size_t slots, const Engine& e)
        : results(slots, [&](PublishedResult& r) { r = e.makeResult(); }),
          // A step that leaves the window hands over cell.time finals at once.
          finals(slots + static_cast<std::size_t>(e.model().config().cell_time),
                 [&](FinalLabels& f) { f = e.makeFinal(); }) {
        const PublishedResult r = e.makeResult();
        const FinalLabels f = e.makeFinal();
        bytes = sizeof(Publication) +
                slots * (sizeof(PublishedResult) + r.histograms.size() * sizeof(int32_t) +
                         r.cell_surprise.size() * sizeof(float) + r.topic_slots.size() * sizeof(uint16_t)) +
                finals.capacity() * (sizeof(FinalLabels) +
                                     f.labels.size() * (sizeof(uint32_t) + sizeof(Position) + sizeof(uint16_t)));
    }
    SpscRing<PublishedResult> results;
    SpscRing<FinalLabels> finals;
    std::atomic<uint64_t> lost{0};
    std::size_t bytes = 0;
};

Status Engine::publishResults(std::size_t slots) {
    if (running()) return Status::error("publishResults: the engine is running (set-up only)");
    try {
        pub_ = slots > 0 ? std::make_unique<Publication>(slots, *this) : nullptr;
    } catch (const std::exception& e) {
        return Status::error(std::string("publishResults: ") + e.what());
    }
    return {};
}

PublishedResult Engine::makeResult() const {
    PublishedResult r;
    const auto cells = static_cast<std::size_t>(model_->cellsPerStep());
    r.histograms.assign(cells * static_cast<std::size_t>(model_->K()), 0);
    r.cell_surprise.assign(cells, 0.f);
    r.topic_slots.assign(static_cast<std::size_t>(model_->K()), 0);
    return r;
}

FinalLabels Engine::makeFinal() const {
    FinalLabels f;
    const auto n = static_cast<std::size_t>(cfg_.model.max_words_per_frame);
    f.words.assign(n, 0);
    f.positions.assign(n, Position{});
    f.labels.assign(n, 0);
    return f;
}

void Engine::captureCheckpoints(CheckpointWriter* writer, uint64_t every) noexcept {
    checkpoints_ = writer;
    checkpoint_every_ = every;
}

uint64_t Engine::resultsLost() const noexcept { return pub_ ? pub_->lost.load(std::memory_order_relaxed) : 0; }

// Refiner side: copies into the next free record, no allocation.
void Engine::publishResult(const ObservationResult& r) noexcept {
    PublishedResult* o = pub_->results.beginPush();
    if (!o) {
        pub_->lost.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    o->result = r;
    if (r.add.ok() && r.step >= 0) {
        const Model& m = *model_;
        const auto cells = o->cell_surprise.size();
        const std::span<const float> cs = m.cellSurprise(r.step);
        for (std::size_t c = 0; c < cells; ++c) o->cell_surprise[c] = c < cs.size() ? cs[c] : 0.f;
        outputHistograms(m, r.step, cells, o->histograms.data());
    } else {  // a reused record: none of its last occupant's content
        std::fill(o->histograms.begin(), o->histograms.end(), 0);
        std::fill(o->cell_surprise.begin(), o->cell_surprise.end(), 0.f);
    }
    model_->slotsInLabelOrder(o->topic_slots);
    pub_->results.commitPush();
}

void Engine::publishFinal(const WindowObservation& w) noexcept {
    FinalLabels* f = pub_->finals.beginPush();
    if (!f) {
        pub_->lost.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    const Model& m = *model_;
    f->where = w;
    f->perplexity = m.stepPerplexity(w.step);
    f->n = std::min<uint32_t>(m.observationSize(w.observation), static_cast<uint32_t>(f->labels.size()));
    m.observationWords(w.observation, {f->words.data(), f->n});
    m.observationPositions(w.observation, {f->positions.data(), f->n});
    m.observationLabels(w.observation, {f->labels.data(), f->n});
    pub_->finals.commitPush();
}

namespace {
template <typename T>
void copyInto(std::vector<T>& to, const std::vector<T>& from) noexcept {
    // Records are sized alike (makeResult/makeFinal): no allocation.
    std::copy_n(from.begin(), std::min(to.size(), from.size()), to.begin());
}
} // namespace

bool Engine::readResult(PublishedResult& out) noexcept {
    if (!pub_) return false;
    PublishedResult* r = pub_->results.front();
    if (!r) return false;
    out.result = r->result;
    copyInto(out.histograms, r->histograms);
    copyInto(out.cell_surprise, r->cell_surprise);
    copyInto(out.topic_slots, r->topic_slots);
    pub_->results.pop();
    return true;
}

bool Engine::readFinal(FinalLabels& out) noexcept {
    if (!pub_) return false;
    FinalLabels* f = pub_->finals.front();
    if (!f) return false;
    out.where = f->where;
    out.perplexity = f->perplexity;
    out.n = std::min<uint32_t>(f->n, static_cast<uint32_t>(out.labels.size()));
    std::copy_n(f->words.begin(), out.n, out.words.begin());
    std::copy_n(f->positions.begin(), out.n, out.positions.begin());
    std::copy_n(f->labels.begin(), out.n, out.labels.begin());
    pub_->finals.pop();
    return true;
}

// After an observation's publish step (ingested or rejected): the results
// to the consumer, the hook, a periodic checkpoint (an observation boundary).
void Engine::afterObservation(const ObservationResult& r) noexcept {
    if (pub_) publishResult(r);
    if (on_observation_) on_observation_(r, *model_);
    if (checkpoints_) checkpoints_->captureEvery(checkpoint_every_, r);
}

EngineMemory Engine::memory() const noexcept {
    EngineMemory m;
    m.model = model_->memoryBytes();
    m.queue = queue_->memoryBytes();
    const Snapshot& s = refiner_->staging;
    m.snapshot = publisher_->memoryBytes() + s.labels_.capacity() * sizeof(uint16_t) +
                 s.words_.capacity() * sizeof(uint32_t) + s.positions_.capacity() * sizeof(Position) +
                 s.hist_.capacity() * sizeof(int32_t) + s.cell_surprise_.capacity() * sizeof(float);
    m.other = refiner_->win_ts.bytes() + refiner_->win_seq.bytes() + sizeof(Refiner) + sizeof(Engine);
    if (pub_) m.other += pub_->bytes;
    return m;
}

void Engine::setObservationHook(ObservationHook hook) { on_observation_ = std::move(hook); }
void Engine::setEvictionHook(EvictionHook hook) { on_evict_ = std::move(hook); }

bool Engine::tryPush(const ObservationView& obs) noexcept {
    return queue_->tryPush(obs.timestamp, obs.words, obs.positions, cfg_.drop == DropPolicy::DropOldest) !=
           ObservationQueue::Push::Dropped;
}

bool Engine::pushWait(const ObservationView& obs, std::chrono::nanoseconds timeout) noexcept {
    const auto start = Clock::now();
    int spins = 0;
    while (!queue_->hasSpace()) {
        if (!running()) return false;
        if (timeout != std::chrono::nanoseconds::max() && Clock::now() - start >= timeout) return false;
        if (++spins < 64)
            std::this_thread::yield();
        else
            std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
    return tryPush(obs);
}

bool Engine::canPush() noexcept { return queue_->hasSpace(); }
uint32_t Engine::queued() const noexcept { return queue_->size(); }

bool Engine::readSnapshot(Snapshot& out) const noexcept { return publisher_->read(out); }

EngineCounters Engine::counters() const noexcept {
    EngineCounters c;
    c.pushed = queue_->pushed();
    c.dropped_newest = queue_->droppedNewest();
    c.dropped_oldest = queue_->droppedOldest();
    c.words_truncated = queue_->wordsTruncated();
    const Refiner& r = *refiner_;
    c.ingested = r.ingested.load(std::memory_order_relaxed);
    c.rejected = r.rejected.load(std::memory_order_relaxed);
    c.words_dropped_cell = r.words_dropped_cell.load(std::memory_order_relaxed);
    c.refinements = r.refinements.load(std::memory_order_relaxed);
    c.tokens = r.tokens.load(std::memory_order_relaxed);
    c.overruns = r.overruns.load(std::memory_order_relaxed);
    c.max_overrun_ns = r.max_overrun_ns.load(std::memory_order_relaxed);
    c.published = r.published.load(std::memory_order_relaxed);
    return c;
}

namespace {

// The strategy's draws, P(t|T) over the window as it stands.
class StrategyPicker final : public StepPicker {
public:
    StrategyPicker(const Strategy& s, const Model& m, Rng& rng) noexcept
        : s_(s), T_(m.steps()), W_(m.steps() - m.oldestStep()), rng_(rng) {}
    int64_t next() noexcept override { return s_.drawStep(T_, W_, rng_); }

private:
    const Strategy& s_;
    int64_t T_, W_;
    Rng& rng_;
};

} // namespace

// A time budget: no round that is predicted to end after `end` starts (the
// prediction learns the wall-clock cost of a token, all threads together),
// and no step is drawn once a newer observation waits (stop on arrival).
class Engine::TimeControl final : public RefineControl {
public:
    TimeControl(Engine& e, Clock::time_point end, bool arrival) noexcept : e_(e), end_(end), arrival_(arrival) {}
    bool beforeStep() noexcept override {
        now_ = Clock::now();
        if (arrival_ && e_.queue_->pending()) return false;
        return now_ < end_;
    }
    bool beforeRound(uint64_t tokens) noexcept override {
        now_ = Clock::now();
        const double ns = 1.5 * e_.refiner_->ns_per_token * static_cast<double>(tokens + 4);
        return now_ + std::chrono::nanoseconds(static_cast<int64_t>(ns)) <= end_;
    }
    uint64_t tokenAllowance() noexcept override {
        const auto left = (end_ - Clock::now()).count();
        if (left <= 0) return 0;
        const double per = 1.5 * e_.refiner_->ns_per_token;
        if (!(per > 0.0)) return UINT64_MAX;
        const double n = static_cast<double>(left) / per;
        return n >= 1e18 ? UINT64_MAX : static_cast<uint64_t>(n);
    }
    void afterRound(uint64_t tokens) noexcept override {
        const auto after = Clock::now();
        Refiner& R = *e_.refiner_;
        R.ns_per_token = robustAverage(R.ns_per_token,
                                       static_cast<double>((after - now_).count()) / static_cast<double>(tokens + 4),
                                       0.05, R.token_samples);
        now_ = after;
    }

private:
    Engine& e_;
    Clock::time_point end_;
    bool arrival_;
    Clock::time_point now_{};
};

// Refines time steps drawn by the strategy until the budget is spent (paper
// Algorithm 2, inner loop), in the model's windows. Returns the number of
// step draws (for a time budget: those of which a cell was refined).
uint64_t Engine::spend(const Budget& budget, Clock::time_point deadline, bool newest, uint64_t* tokens_out,
                       uint64_t* rounds_out) noexcept {
    Model& m = *model_;
    Refiner& R = *refiner_;
    if (tokens_out) *tokens_out = 0;
    if (m.steps() == 0) return 0;
    StrategyPicker picker(strategy_, m, m.rng());
    RefineLimits limits;
    // Stop early enough that the publication also ends by the deadline.
    TimeControl time(*this, deadline - std::chrono::nanoseconds(static_cast<int64_t>(R.publish_ns)),
                     newest && cfg_.flags.stop_on_arrival);
    switch (budget.kind) {
    case BudgetKind::Steps: limits.steps = budget.count; break;
    case BudgetKind::Tokens:
        // At most `count` draws, so a window of empty steps cannot loop forever.
        limits.steps = budget.count;
        limits.tokens = budget.count;
        break;
    case BudgetKind::Time: limits.control = &time; break;
    }
    limits.stop = &cut_short_;  // stop(Discard): a count budget is not waited out
    const RefineCount rc = m.refine(picker, limits);
    const uint64_t draws = budget.kind == BudgetKind::Time ? rc.started : rc.steps;
    bump(R.refinements, draws);
    bump(R.tokens, rc.tokens);
    if (tokens_out) *tokens_out = rc.tokens;
    if (rounds_out) *rounds_out = rc.rounds;
    return draws;
}

void Engine::publish(const ObservationResult& r) noexcept {
    Refiner& R = *refiner_;
    const Model& m = *model_;
    Snapshot& s = R.staging;
    s.observation = r.observation;
    s.sequence = r.sequence;
    s.timestamp = r.timestamp;
    s.step = r.step;
    s.perplexity = r.perplexity;
    s.surprise = r.surprise;
    s.previous_step = r.previous_step;
    s.previous_perplexity = r.previous_perplexity;
    s.previous_plugin = r.previous_plugin;
    s.active_topics = r.active_topics;
    if (cfg_.flags.snapshot_labels) {
        const uint32_t n = std::min<uint32_t>(m.observationSize(r.observation), static_cast<uint32_t>(s.labels_.size()));
        s.n_words_ = n;
        m.observationLabels(r.observation, {s.labels_.data(), n});
        m.observationWords(r.observation, {s.words_.data(), n});
        m.observationPositions(r.observation, {s.positions_.data(), n});
        outputHistograms(m, r.step, static_cast<std::size_t>(m.cellsPerStep()), s.hist_.data());
        const auto cs = m.cellSurprise(r.step);
        if (cs.size() == s.cell_surprise_.size()) std::copy(cs.begin(), cs.end(), s.cell_surprise_.begin());
    } else {
        s.n_words_ = 0;
    }
    bump(R.published);
    s.counters = counters();
    publisher_->publish(s);
}

bool Engine::takeUpOne(ObservationResult* out) noexcept {
    ObservationQueue::Item it;
    if (!queue_->claim(it)) return false;
    refiner_->next_sequence = it.sequence + 1;
    refiner_->truncated_taken += it.truncated;
    const auto t0 = Clock::now();
    const bool timed = cfg_.budget.kind == BudgetKind::Time;
    const auto deadline =
        t0 + std::chrono::nanoseconds(timed ? static_cast<int64_t>(cfg_.budget.ms * 1e6) : int64_t{0});
    Model& m = *model_;
    ObservationResult r;
    r.sequence = it.sequence;
    r.timestamp = it.timestamp;
    r.observation = m.observations();
    const std::span<const uint32_t> words(it.words, it.size);
    const std::span<const Position> positions(it.positions, it.size);

    // Validate first (the model's own checks), so the eviction hook and the
    // instantaneous perplexity run only for an observation that will enter the model.
    AddResult check;
    if (it.size_mismatch) {
        check.error = AddError::SizeMismatch;
        check.index = it.mismatch_index;
    } else {
        check = m.validateObservation(words, positions);
    }
    if (!check.ok()) {
        queue_->release();
        r.add = check;
        r.elapsed_ns = (Clock::now() - t0).count();
        reject(r, out);
        return true;
    }
    beforeObservation(r);
    r.add = m.addObservation(words, positions);
    queue_->release();
    if (!r.add.ok()) {  // not reached: validated above
        reject(r, out);
        return true;
    }
    const std::size_t w = r.observation % refiner_->win_cap;
    refiner_->win_ts[w] = it.timestamp;
    refiner_->win_seq[w] = it.sequence;
    r.step = m.stepOfObservation(r.observation);
    r.surprise = m.observationSurprise(r.observation);
    bump(refiner_->ingested);
    bump(refiner_->words_dropped_cell, r.add.dropped_cell + r.add.dropped_frame);
    // The producer subsampled the words past max_words_per_frame (counters().words_truncated):
    // the observation's own result says so too.
    r.add.dropped_frame += it.truncated;
    refineAndPublish(r, t0, deadline);
    afterObservation(r);
    if (out) *out = r;
    return true;
}

void Engine::reject(ObservationResult& r, ObservationResult* out) noexcept {
    bump(refiner_->rejected);
    r.step = -1;
    afterObservation(r);
    if (out) *out = r;
}

void Engine::beforeObservation(ObservationResult& r) noexcept {
    const Model& m = *model_;
    const uint64_t frame = r.observation;
    const auto ct = static_cast<uint64_t>(m.config().cell_time);
    if (frame % ct != 0 || frame == 0) return;
    const auto newStep = static_cast<int64_t>(frame / ct);
    // Instantaneous perplexity of the step just completed: one step after
    // its arrival, before the next observation touches the model.
    if (cfg_.flags.instantaneous_perplexity) {
        r.previous_step = newStep - 1;
        r.previous_perplexity = m.stepPerplexity(newStep - 1);
        r.previous_plugin = m.stepPluginPerplexity(newStep - 1);
    }
    const int64_t ring = m.config().ring_steps;
    if ((!on_evict_ && !pub_) || newStep < ring) return;
    const Refiner& R = *refiner_;
    const int64_t gone = newStep - ring;
    for (uint64_t f = static_cast<uint64_t>(gone) * ct; f < static_cast<uint64_t>(gone + 1) * ct; ++f) {
        const std::size_t w = f % R.win_cap;
        const WindowObservation leaving{f, R.win_seq[w], R.win_ts[w], gone};
        if (on_evict_ && f >= evicted_through_) on_evict_(leaving, m);
        if (pub_) publishFinal(leaving);
    }
}

void Engine::refineAndPublish(ObservationResult& r, Clock::time_point t0, Clock::time_point deadline) noexcept {
    Refiner& R = *refiner_;
    const auto ts = Clock::now();
    r.refinements = spend(cfg_.budget, deadline, true, &r.tokens, &r.rounds);
    const auto tp = Clock::now();
    r.refine_ns = (tp - ts).count();

    if (cfg_.flags.snapshot_perplexity) r.perplexity = model_->stepPerplexity(r.step);
    r.active_topics = model_->activeTopics();
    publish(r);
    const auto t1 = Clock::now();
    if (cfg_.budget.kind == BudgetKind::Time) {
        // Publishing costs about the same for observations of similar size: a faster average.
        R.publish_ns = std::min(robustAverage(R.publish_ns, static_cast<double>((t1 - tp).count()), 0.25,
                                              R.publish_samples),
                                cfg_.budget.ms * 1e6 / 2);
        const int64_t over = (t1 - deadline).count();
        if (over > 0) {
            r.overrun_ns = over;
            bump(R.overruns);
            if (over > R.max_overrun_ns.load(std::memory_order_relaxed))
                R.max_overrun_ns.store(over, std::memory_order_relaxed);
        }
    }
    r.elapsed_ns = (t1 - t0).count();
}

// The refiner thread's id, set as it starts and cleared once it is joined
// (no thread-local: in a shared library its access after a dlopen may allocate).
static_assert(std::atomic<std::thread::id>::is_always_lock_free, "the refiner's id is read on the realtime path");
bool Engine::onRefinerThread() const noexcept {
    return refiner_thread_.load(std::memory_order_acquire) == std::this_thread::get_id();
}

void Engine::refinerMain() noexcept {
    refiner_thread_.store(std::this_thread::get_id(), std::memory_order_release);
    applyToCurrentThread(cfg_.thread);  // set-up: may allocate, logs fallbacks once
    refiner_->ready.store(true, std::memory_order_release);
    refiner_->ready.notify_all();  // start() waits on it (set-up: one futex wake)
    int idle = 0;
    for (;;) {
        const int req = stop_request_.load(std::memory_order_acquire);
        if (req == 2 || cut_short_.load(std::memory_order_relaxed)) break;  // cut_short_ is stored first
        if (takeUpOne(nullptr)) {
            idle = 0;
            continue;
        }
        if (req == 1) break;  // drained: nothing left after the stop request
        // Nothing to do: yield a while, then sleep in short steps.
        if (++idle < 64)
            std::this_thread::yield();
        else
            std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
}

Status Engine::start() {
    if (running()) return Status::error("engine: start() called while already running");
    if (cfg_.thread.lock_memory) lockProcessMemory();
    if (model_->threads() > 1) {
        try {
            model_->applyWorkerSettings(cfg_.thread);
        } catch (const std::exception& e) {
            return Status::error(std::string("engine: could not start the refinement workers: ") + e.what());
        }
    }
    stop_request_.store(0, std::memory_order_release);
    refiner_->ready.store(false, std::memory_order_release);
    running_.store(true, std::memory_order_release);
    try {
        thread_ = std::thread([this] { refinerMain(); });
    } catch (const std::exception& e) {
        running_.store(false, std::memory_order_release);
        return Status::error(std::string("engine: could not start the refiner thread: ") + e.what());
    }
    // Return only once the thread has applied its settings, so every set-up
    // allocation has happened by the time start() returns.
    refiner_->ready.wait(false, std::memory_order_acquire);  // not a yield spin: a higher-priority caller
    return {};
}

void Engine::stop(StopMode mode) {
    if (!thread_.joinable()) return;
    if (mode == StopMode::Discard) cut_short_.store(true, std::memory_order_relaxed);
    stop_request_.store(mode == StopMode::Drain ? 1 : 2, std::memory_order_release);
    thread_.join();
    cut_short_.store(false, std::memory_order_relaxed);
    refiner_thread_.store(std::thread::id(), std::memory_order_release);
    running_.store(false, std::memory_order_release);
}

ObservationResult Engine::processNow(const ObservationView& obs) noexcept {
    ObservationResult r;
    if (running()) return r;  // step -1: not processed
    while (!queue_->hasSpace()) takeUpOne(nullptr);  // observations queued earlier go first
    if (!tryPush(obs)) return r;
    while (takeUpOne(&r)) {
    }
    return r;
}

uint64_t Engine::processPending() noexcept {
    if (running()) return 0;
    uint64_t n = 0;
    while (takeUpOne(nullptr)) ++n;
    return n;
}

uint64_t Engine::refineExtra(const Budget& budget) noexcept {
    if (running()) return 0;
    const auto deadline = Clock::now() + std::chrono::nanoseconds(static_cast<int64_t>(budget.ms * 1e6));
    return spend(budget, deadline, false, nullptr);
}

uint64_t Engine::finalPass(int sweeps) noexcept { return finalPass(sweeps, nullptr); }

uint64_t Engine::finalPass(int sweeps, const std::atomic<bool>* stop) noexcept {
    if (running()) return 0;
    const uint64_t t = model_->refineAll(sweeps, stop);
    bump(refiner_->tokens, t);
    return t;
}

void Engine::visitWindow(const EvictionHook& visit) const { if (visit) visitWindowFrom(0, visit); }

void Engine::flushWindowToEvictionHook() {
    if (!on_evict_ || running()) return;  // the refiner reads evicted_through_ while it runs
    visitWindowFrom(evicted_through_, on_evict_);
    evicted_through_ = model_->observations();
}

void Engine::visitWindowFrom(uint64_t first, const EvictionHook& visit) const {
    const Model& m = *model_;
    const uint64_t frames = m.observations();
    if (frames == 0) return;
    const auto ct = static_cast<uint64_t>(m.config().cell_time);
    for (uint64_t f = std::max(static_cast<uint64_t>(m.oldestStep()) * ct, first); f < frames; ++f) {
        const std::size_t w = f % refiner_->win_cap;
        visit(WindowObservation{f, refiner_->win_seq[w], refiner_->win_ts[w], m.stepOfObservation(f)}, m);
    }
}

} // namespace rost
