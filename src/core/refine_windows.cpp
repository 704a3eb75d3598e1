// Refinement in windows of cell picks, coloured into rounds and refined on
// every core with the same result for any number of threads
// (rost/model.hpp, ModelCore::refine; docs/design.md, "Refinement on every core").

#include <algorithm>
#include <atomic>
#include <cstring>
#include <string>

#include "counter_rng.hpp"
#include "kernel_frozen.hpp"
#include "measure.hpp"
#include "refine_windows.hpp"
#include "model_core.hpp"
#include "rost/realtime.hpp"
#include "worker_pool.hpp"

namespace rost {

// One round on the pool: a task per cell of the round. With merges
// deferred, each worker first adds the previous round's moves to its own
// copy of n_k^v (begin(): only a worker that takes part reads its copy).
struct ModelCore::WindowJob final : detail::WorkerPool::Job {
    ModelCore* model = nullptr;
    const uint32_t* tasks = nullptr;
    TaskKernel kernel = nullptr;
    const MoveLog* pending = nullptr;

    void begin(int worker) noexcept override {
        if (pending) model->takeMoves(*pending, static_cast<uint32_t>(worker));
        kernel::Tables& t = model->win_->worker_tables[static_cast<std::size_t>(worker)];
        if (t.left) kernel::fillLeft(t);  // the round's reciprocals hold still from here
    }
    uint32_t count = 0;  // tasks in the list: the one after a task is prefetched

    void task(int worker, uint32_t index) noexcept override {
        const uint32_t t = tasks[index];
        if (index + 1 < count && tasks[index + 1] != Windows::kPlanTask) model->prefetchTask(tasks[index + 1]);
        if (t == Windows::kPlanTask)
            model->planNextWindow();
        else
            (model->*kernel)(worker, t);
    }
    PairKernel pair = nullptr;  // set: pairs (src/core/kernel_pair.hpp)
    void taskPair(int worker, uint32_t index) noexcept override {
        const uint32_t a = tasks[index], b = tasks[index + 1];
        if (a == Windows::kPlanTask || b == Windows::kPlanTask) {
            task(worker, index);
            task(worker, index + 1);
            return;
        }
        for (uint32_t j = index + 2; j < index + 4 && j < count; ++j)
            if (tasks[j] != Windows::kPlanTask) model->prefetchTask(tasks[j]);
        (model->*pair)(worker, a, b);
    }
};

// The merge of a round on the pool (merges not deferred): task r adds the
// round's moves to copy r of n_k^v (0: the model's), whoever runs it
// (worker r first).
struct ModelCore::MergeJob final : detail::WorkerPool::Job {
    ModelCore* model = nullptr;
    const MoveLog* log = nullptr;

    void task(int /*worker*/, uint32_t copy) noexcept override { model->takeMoves(*log, copy); }
};

// A round's moves given to the copies that have not taken them: task r for
// copy r, whoever runs it (many copies behind: a round of fewer cells than
// workers, or a live round after a deferred one).
struct ModelCore::CatchUpJob final : detail::WorkerPool::Job {
    ModelCore* model = nullptr;
    const MoveLog* log = nullptr;

    void task(int /*worker*/, uint32_t copy) noexcept override {
        if (model->win_->merged[copy * Windows::kMergedStride] != log->round) model->takeMoves(*log, copy);
    }
};

// The copies of n_k^v made equal to the model's: task r copies into copy r (task 0: nothing to do).
struct ModelCore::CopyJob final : detail::WorkerPool::Job {
    ModelCore* model = nullptr;

    void task(int /*worker*/, uint32_t copy) noexcept override {
        if (copy == 0) return;
        const Windows& w = *model->win_;
        const std::size_t table = static_cast<std::size_t>(model->V_) * static_cast<std::size_t>(model->Kp_);
        std::memcpy(w.worker_tables[copy].nkv, model->nkv_.data(), table * sizeof(int32_t));
    }
};

ModelCore::~ModelCore() = default;

int ModelCore::threads() const noexcept { return pool_ ? pool_->workers() : 1; }

void ModelCore::setThreads(int n) {
    n = std::clamp(n, 1, static_cast<int>(settingSpec("threads").hi));
    if (n == threads() && n == cfg_.threads) return;
    Windows& w = *win_;
    pool_.reset();
    const auto size = [&](int threads) {
        memory_bytes_ -= w.workerBytes();
        w.sizeWorkers(static_cast<std::size_t>(threads), static_cast<std::size_t>(V_), static_cast<std::size_t>(Kp_),
                      leftTables());
        memory_bytes_ += w.workerBytes();
        cfg_.threads = threads;
    };
    try {
        size(n);
        if (n > 1 && w.W > 1) pool_ = std::make_unique<detail::WorkerPool>(n);
        sizeMeasure();
    } catch (...) {
        // No thread or no memory to be had: the model is left whole, on one thread.
        pool_.reset();
        size(1);
        sizeMeasure();
        throw;
    }
}

void ModelCore::applyWorkerSettings(const ThreadSettings& settings) {
    if (pool_) pool_->applySettings(settings);
}

void ModelCore::chooseColours() noexcept {
    // The smallest M (and stride b) with (dt + dx + b dy) mod M != 0 for every
    // neighbour offset: same cell at 0 < |dt| <= g.time, or same step at
    // 0 < |dx| + |dy| <= g.space inside the grid. Radius 1 in space and time
    // gives M = 2, b = 1: (t + x + y) mod 2.
    const int gt = cfg_.g_time, gs = cfg_.g_space;
    for (int m = std::max(1, gt + 1);; ++m)
        for (int b = 0; b < m; ++b) {
            bool ok = true;
            for (int dy = -gs; dy <= gs && ok; ++dy)
                for (int dx = -gs; dx <= gs && ok; ++dx) {
                    if ((dx == 0 && dy == 0) || std::abs(dx) + std::abs(dy) > gs) continue;
                    if (std::abs(dx) >= gw_ || std::abs(dy) >= gh_) continue;
                    ok = ((dx + b * dy) % m + m) % m != 0;
                }
            if (ok) {
                colours_ = m;
                colour_b_ = b;
                return;
            }
        }
}

void ModelCore::allocateWindows() {
    chooseColours();
    win_ = std::make_unique<Windows>();
    Windows& w = *win_;
    const auto W = static_cast<std::size_t>(cfg_.refine_window);
    w.W = static_cast<uint32_t>(W);
    // The second plan is used only with workers (planning ahead), but sized
    // alike so that setThreads() never allocates one.
    for (Windows::Plan& P : w.plans) P.size(W, static_cast<std::size_t>(colours_));
    std::size_t h = 1;
    while (h < 2 * W) h <<= 1;
    w.hash_key.reset(h);
    w.hash_task.reset(h);
    w.hash_stamp.reset(h);
    // A round holds distinct cells of the ring, each at most cell.capacity words.
    const std::size_t cellsInRing = static_cast<std::size_t>(ring_) * static_cast<std::size_t>(cells_);
    if (W > 1) {
        w.z0.reset(std::min(W, cellsInRing) * static_cast<std::size_t>(cap_));
        for (MoveLog& log : w.logs) log.size(w.z0.size(), W);
    }
    w.colours = static_cast<std::size_t>(colours_);
    w.sizeWorkers(static_cast<std::size_t>(cfg_.threads), static_cast<std::size_t>(V_), static_cast<std::size_t>(Kp_),
                  leftTables());
    if (cfg_.threads > 1 && W > 1) pool_ = std::make_unique<detail::WorkerPool>(cfg_.threads);
    memory_bytes_ += w.bytes();
}

// Adds the step's next non-empty cells to the window until it is full,
// drawing steps as needed. False when the window stays empty (no more picks).
bool ModelCore::fillWindow(Windows::Plan& P, StepPicker& picker, const RefineLimits& limits, RefineCount& rc) noexcept {
    Windows& w = *win_;
    P.grouped = false;
    P.picks = 0;
    // A token budget also bounds the window, so the budget is passed by less
    // than one cell, as by a serial sampler; so does the control's allowance.
    uint64_t bound = limits.tokens;
    if (limits.control) {
        const uint64_t allowance = limits.control->tokenAllowance();
        bound = std::min(bound, allowance > UINT64_MAX - rc.tokens ? UINT64_MAX : rc.tokens + allowance);
    }
    uint64_t tokens = rc.tokens;
    while (P.picks < w.W && tokens < bound) {
        if (w.cur_step < 0 || w.next_cell >= cells_) {
            if (rc.steps >= limits.steps || rc.tokens >= limits.tokens ||
                (limits.control && !limits.control->beforeStep()))
                break;
            w.cur_step = picker.next();
            w.next_cell = 0;
            w.cur_ord = ++rc.steps;
            if (!inWindow(w.cur_step)) {
                w.cur_step = -1;
                continue;
            }
        }
        const std::size_t row = slotOf(w.cur_step) * static_cast<std::size_t>(cells_);
        while (w.next_cell < cells_ && cell_n_[row + static_cast<std::size_t>(w.next_cell)] == 0) ++w.next_cell;
        if (w.next_cell >= cells_) continue;
        P.pick_step[P.picks] = w.cur_step;
        P.pick_cell[P.picks] = w.next_cell++;
        P.pick_ord[P.picks] = w.cur_ord;
        P.pick_done[P.picks] = 0;
        tokens += cell_n_[row + static_cast<std::size_t>(P.pick_cell[P.picks])];
        ++P.picks;
    }
    return P.picks > 0;
}

bool ModelCore::refineSerialWindow(const RefineLimits& limits, RefineCount& rc) noexcept {
    Windows::Plan& P = win_->plan();
    const int64_t step = P.pick_step[0];
    const int cell = P.pick_cell[0];
    const uint32_t n = cellWordCount(step, cell);
    if (rc.tokens >= limits.tokens || (limits.control && !limits.control->beforeRound(n))) return false;
    rc.tokens += refineCell(step, cell);
    ++rc.rounds;
    P.pick_done[0] = 1;
    countStarted(rc);
    if (limits.control) limits.control->afterRound(n);
    return true;
}

// Groups the window's picks into tasks (one per distinct cell) and the tasks
// into rounds by colour.
void ModelCore::groupWindow(Windows::Plan& P) noexcept {
    Windows& w = *win_;
    if (++w.stamp == 0) {
        std::fill_n(w.hash_stamp.data(), w.hash_stamp.size(), 0u);
        w.stamp = 1;
    }
    const std::size_t mask = w.hash_key.size() - 1;
    // Tasks sorted by colour and, where a worker refines two at once, length (first-pick
    // order within a key; without pairs it keeps neighbouring cells close in the caches).
    const bool pairs = pair_kernel_[path_ == kernel::Path::Simd ? 1 : 0] != nullptr;
    const uint32_t L = pairs ? Windows::Plan::kLengthKeys : 1;
    P.tasks = 0;
    for (uint32_t p = 0; p < P.picks; ++p) {
        const int64_t key = P.pick_step[p] * cells_ + P.pick_cell[p];
        std::size_t h = detail::mix64(static_cast<uint64_t>(key)) & mask;
        while (w.hash_stamp[h] == w.stamp && w.hash_key[h] != key) h = (h + 1) & mask;
        P.pick_next[p] = Windows::kNone;
        if (w.hash_stamp[h] != w.stamp) {
            const uint32_t t = P.tasks++;
            w.hash_stamp[h] = w.stamp;
            w.hash_key[h] = key;
            w.hash_task[h] = t;
            P.task_step[t] = P.pick_step[p];
            P.task_cell[t] = P.pick_cell[p];
            P.task_head[t] = P.task_tail[t] = p;
            P.task_mult[t] = 1;
            P.task_words[t] = cellWordCount(P.pick_step[p], P.pick_cell[p]);
            P.task_key[t] = static_cast<uint32_t>(colourOf(P.pick_step[p], P.pick_cell[p])) * L +
                            std::min(P.task_words[t], L - 1);
        } else {
            const uint32_t t = w.hash_task[h];
            P.pick_next[P.task_tail[t]] = p;
            P.task_tail[t] = p;
            ++P.task_mult[t];
        }
    }
    const std::size_t keys = static_cast<std::size_t>(colours_) * L;
    uint32_t* begin = P.key_begin.data();
    std::fill_n(begin, keys + 1, 0u);
    for (uint32_t t = 0; t < P.tasks; ++t) ++begin[P.task_key[t] + 1];
    for (std::size_t k = 0; k < keys; ++k) begin[k + 1] += begin[k];
    for (int c = 0; c <= colours_; ++c) P.colour_begin[c] = begin[static_cast<std::size_t>(c) * L];
    for (uint32_t t = 0; t < P.tasks; ++t) P.order[begin[P.task_key[t]]++] = t;
}

// Lays the window's rounds out: each task's offset in its round's labels
// and moves, each round's tokens and, with workers, each round's tasks by
// owner: the band of rows of cells a worker refines whenever it can, so a
// cell's words, labels and counts stay in one core's cache from round to
// round. The order of a round's tasks changes nothing in its result (frozen
// counts, draws keyed by pick). With planning ahead, the task that plans the
// next window goes first in worker 1's range of the window's last round, when
// that round has more than one cell (one cell is refined live by the caller,
// and the next window is then planned after it): worker 1 plans while the
// others refine, and if it is late, the first to run out of its own tasks
// takes the planning.
void ModelCore::layoutRounds(Windows::Plan& P) noexcept {
    Windows& w = *win_;
    const uint32_t n = pool_ ? static_cast<uint32_t>(pool_->workers()) : 1;
    int last = colours_ - 1;  // the last non-empty round
    while (last > 0 && P.colour_begin[last] == P.colour_begin[last + 1]) --last;
    uint32_t o = 0;
    for (int c = 0; c < colours_; ++c) {
        const uint32_t b = P.colour_begin[c], e = P.colour_begin[c + 1];
        P.owned_begin[c] = o;
        uint64_t tokens = 0;
        std::size_t off = 0;
        for (uint32_t i = b; i < e; ++i) {
            const uint32_t t = P.order[i];
            const uint32_t words = P.task_words[t];
            P.task_z0[t] = off;
            off += words;
            tokens += static_cast<uint64_t>(words) * P.task_mult[t];
        }
        P.round_tokens[c] = tokens;
        if (!pool_ || e - b < 2) continue;  // one cell: refined live, on the caller
        uint32_t* owned = P.owned.data() + o;
        uint32_t* cuts = P.round_cuts.data() + static_cast<std::size_t>(c) * (n + 1);
        std::fill_n(cuts, n + 1, 0u);
        const auto ownerOf = [&](uint32_t t) {
            return static_cast<uint32_t>(static_cast<uint64_t>(P.task_cell[t]) * n / static_cast<uint64_t>(cells_));
        };
        for (uint32_t i = b; i < e; ++i) ++cuts[ownerOf(P.order[i]) + 1];
        for (uint32_t k = 0; k < n; ++k) cuts[k + 1] += cuts[k];
        for (uint32_t i = b; i < e; ++i) {
            const uint32_t t = P.order[i];
            owned[cuts[ownerOf(t)]++] = t;
        }
        for (uint32_t k = n; k > 0; --k) cuts[k] = cuts[k - 1];
        cuts[0] = 0;
        o += e - b;
        if (!(w.plan_ahead && c == last)) continue;
        const uint32_t at = cuts[1];
        std::memmove(owned + at + 1, owned + at, (e - b - at) * sizeof(uint32_t));
        owned[at] = Windows::kPlanTask;
        for (uint32_t k = 2; k <= n; ++k) ++cuts[k];
        ++o;
    }
    P.owned_begin[colours_] = o;
}

void ModelCore::runRound(int c) noexcept {
    Windows& w = *win_;
    Windows::Plan& P = w.plan();
    const uint32_t b = P.colour_begin[c], e = P.colour_begin[c + 1];
    const int path = path_ == kernel::Path::Simd ? 1 : 0;
    if (e - b == 1) {  // one cell: refined against live counts, exactly as a serial sampler
        runLiveRound(P.order[b]);
        return;
    }
    ++w.round;
    MoveLog& log = w.logs[w.round & 1];
    log.round = w.round;
    log.task_off = P.task_z0.data();
    WindowJob job;
    job.model = this;
    job.kernel = frozen_kernel_[path];
    job.pair = pair_kernel_[path];
    job.pairs = job.pair != nullptr;
    if (pool_) {
        const auto n = static_cast<std::size_t>(pool_->workers());
        log.n = P.owned_begin[c + 1] - P.owned_begin[c];
        job.count = log.n;
        job.tasks = log.task_list = P.owned.data() + P.owned_begin[c];
        if (w.defer) {  // taken during the next round: keep the round's own list and offsets
            std::memcpy(log.tasks.data(), job.tasks, log.n * sizeof(uint32_t));
            for (uint32_t i = b; i < e; ++i) log.off[P.order[i]] = P.task_z0[P.order[i]];
            log.task_list = log.tasks.data();
            log.task_off = log.off.data();
        }
        job.pending = w.pending != 0 ? &w.logs[w.pending & 1] : nullptr;
        pool_->run(job, log.n, P.round_cuts.data() + static_cast<std::size_t>(c) * (n + 1));
        if (w.defer) {
            // The copies whose workers took no part take the previous round's
            // moves now, before its log is written again.
            if (job.pending) takeMovesEverywhere(*job.pending);
            w.pending = w.round;
            ++w.count->deferred;
        } else {
            MergeJob merge;
            merge.model = this;
            merge.log = &log;
            pool_->run(merge, static_cast<uint32_t>(pool_->workers()));
        }
    } else {
        log.n = e - b;
        job.count = log.n;
        job.tasks = log.task_list = P.order.data() + b;
        job.begin(0);
        detail::WorkerPool::runInTurn(job, log.n);
        takeMoves(log, 0);
    }
    finishRound();
}

// The live kernel refines one cell against the model's n_k^v: its moves go to the workers' copies.
void ModelCore::runLiveRound(uint32_t task) noexcept {
    Windows& w = *win_;
    const Windows::Plan& P = w.plan();
    const int path = path_ == kernel::Path::Simd ? 1 : 0;
    if (!pool_) {
        (this->*live_kernel_[path])(0, task);
        return;
    }
    takePendingMoves();  // every copy up to date before the live counts move
    const std::size_t base = (slotOf(P.task_step[task]) * cells_ + static_cast<std::size_t>(P.task_cell[task])) * cap_;
    const uint32_t n = cellWordCount(P.task_step[task], P.task_cell[task]);
    const uint16_t* z = cell_z_.data() + base;
    const uint32_t* words = cell_words_.data() + base;
    std::memcpy(w.z0.data(), z, n * sizeof(uint16_t));
    (this->*live_kernel_[path])(0, task);
    for (std::size_t r = 1; r < static_cast<std::size_t>(pool_->workers()); ++r) {
        int32_t* nkv = w.worker_tables[r].nkv;
        for (uint32_t j = 0; j < n; ++j) {
            if (z[j] == w.z0[j]) continue;
            int32_t* row = nkv + static_cast<std::size_t>(words[j]) * Kp_;
            --row[w.z0[j]];
            ++row[z[j]];
        }
    }
    syncWorkerTables(false);  // n_k and the open topics moved with the cell
}

// The copies that have not taken the round's moves take them: on the
// calling thread when one or two are behind, else on the pool, a copy a task.
void ModelCore::takeMovesEverywhere(const MoveLog& log) noexcept {
    Windows& w = *win_;
    const auto copies = static_cast<uint32_t>(w.worker_tables.size());
    uint32_t behind = 0;
    for (uint32_t c = 0; c < copies; ++c) behind += w.merged[c * Windows::kMergedStride] != log.round ? 1 : 0;
    if (w.count) w.count->caught_up += behind;
    if (behind > 2 && pool_) {
        CatchUpJob job;
        job.model = this;
        job.log = &log;
        pool_->run(job, copies);
        return;
    }
    for (uint32_t c = 0; c < copies && behind > 0; ++c)
        if (w.merged[c * Windows::kMergedStride] != log.round) {
            takeMoves(log, c);
            --behind;
        }
}

// A deferred merge done now: every copy takes the last round's moves.
void ModelCore::takePendingMoves() noexcept {
    Windows& w = *win_;
    if (w.pending == 0) return;
    takeMovesEverywhere(w.logs[w.pending & 1]);
    w.pending = 0;
}

// After the merge: n_k, the reciprocals, the open topics, and the workers' tables.
void ModelCore::finishRound() noexcept {
    Windows& w = *win_;
    int32_t* dnk = w.dnk.data();
    for (std::size_t r = 0; r < w.worker_tables.size(); ++r, dnk += Kp_)
        for (int k = 0; k < Kp_; ++k) {
            nk_[k] += dnk[k];
            dnk[k] = 0;
        }
    kernel::refreshReciprocals(tables_);
    // Topics closed and opened (every task that opened one opened the same).
    kernel::updateTopics(tables_);
    syncWorkerTables(false);
}

bool ModelCore::workerCopiesAgree(std::string* why) const {
    const Windows& w = *win_;
    if (!w.copies_synced) return true;
    const std::size_t table = static_cast<std::size_t>(V_) * static_cast<std::size_t>(Kp_);
    for (std::size_t r = 0; r < w.worker_tables.size(); ++r) {
        const kernel::Tables& t = w.worker_tables[r];
        if (t.nk != nk_.data() || t.inv != inv_.data() || t.active != tables_.active || t.hi != tables_.hi ||
            t.slot != tables_.slot) {
            if (why) *why = "worker " + std::to_string(r) + "'s tables are stale";
            return false;
        }
        if (std::memcmp(t.nkv, nkv_.data(), table * sizeof(int32_t)) != 0) {
            if (why) *why = "worker " + std::to_string(r) + "'s copy of n_k^v differs from the model's";
            return false;
        }
    }
    return true;
}

// The workers' tables are the model's, each with its own n_k^v; with `copy`
// the copies are made equal to the model's (when a refinement starts), on
// the pool: worker r copies its own first, so the copy starts in its cache,
// and the time is one copy's whatever the number of workers.
void ModelCore::syncWorkerTables(bool copy) noexcept {
    Windows& w = *win_;
    const std::size_t n = w.worker_tables.size(), table = static_cast<std::size_t>(V_) * static_cast<std::size_t>(Kp_);
    for (std::size_t r = 0; r < n; ++r) {
        w.worker_tables[r] = tables_;
        w.worker_tables[r].nkv = r == 0 || w.replicas.size() == 0 ? nkv_.data() : w.replicas.data() + (r - 1) * table;
        w.worker_tables[r].left = w.left.size() ? w.left.data() + r * static_cast<std::size_t>(Kp_ * Kp_) : nullptr;
    }
    if (!copy || !pool_ || w.replicas.size() == 0) return;
    CopyJob job;
    job.model = this;
    pool_->run(job, static_cast<uint32_t>(n));
}

void ModelCore::countStarted(RefineCount& rc) noexcept {
    Windows& w = *win_;
    const Windows::Plan& P = w.plan();
    for (uint32_t p = 0; p < P.picks; ++p)
        if (P.pick_done[p] && P.pick_ord[p] != w.counted_ord) {
            w.counted_ord = P.pick_ord[p];
            ++rc.started;
        }
}

// Draws the window's key and groups its picks (the model's generator, in
// the serial order: the picks, then the key).
void ModelCore::prepareWindow(Windows::Plan& P) noexcept {
    P.key = (static_cast<uint64_t>(rng_.next()) << 32) | rng_.next();
    groupWindow(P);
    layoutRounds(P);
    P.grouped = true;
}

// The task of the current window's last round that plans the next window
// (run by one worker while the others refine): the same draws, in the same
// order, as planning it after the round.
void ModelCore::planNextWindow() noexcept {
    Windows& w = *win_;
    Windows::Plan& next = w.spare();
    if (fillWindow(next, *w.picker, *w.limits, *w.count)) prepareWindow(next);
    w.planned = true;
}

bool ModelCore::refineParallelWindow(const RefineLimits& limits, RefineCount& rc) noexcept {
    Windows& w = *win_;
    Windows::Plan& P = w.plan();
    if (!P.grouped) prepareWindow(P);
    bool go = true;
    for (int c = 0; c < colours_ && go; ++c) {
        const uint32_t b = P.colour_begin[c], e = P.colour_begin[c + 1];
        if (b == e) continue;
        const uint64_t tokens = P.round_tokens[c];
        if (rc.tokens >= limits.tokens || (limits.control && !limits.control->beforeRound(tokens))) {
            go = false;
            break;
        }
        runRound(c);
        rc.tokens += tokens;
        tokens_refined_ += tokens;
        ++rc.rounds;
        for (uint32_t i = b; i < e; ++i)
            for (uint32_t p = P.task_head[P.order[i]]; p != Windows::kNone; p = P.pick_next[p]) P.pick_done[p] = 1;
        if (limits.control) limits.control->afterRound(tokens);
    }
    countStarted(rc);
    return go;
}

RefineCount ModelCore::refineWindows(StepPicker& picker, const RefineLimits& limits) noexcept {
    RefineCount rc;
    if (steps_ == 0) return rc;
    Windows& w = *win_;
    w.cur_step = -1;
    w.next_cell = 0;
    w.counted_ord = 0;
    if (w.W > 1) syncWorkerTables(true);
    w.copies_synced = w.W > 1;
    // With workers and a budget that does not depend on the rounds (no time
    // control, no token limit), the next window is planned by a task of the
    // current window's last round.
    w.picker = &picker;
    w.limits = &limits;
    w.count = &rc;
    w.plan_ahead = pool_ && w.W > 1 && !limits.control && limits.tokens == UINT64_MAX;
    w.planned = false;
    // Without a control (nothing looks at the counts between rounds), each
    // round's merge is deferred to the next round's job: every worker adds
    // the moves to its own copy of n_k^v before its first task, and the
    // round's end is one barrier instead of two.
    w.defer = pool_ && w.W > 1 && !limits.control;
    w.pending = 0;
    bool more = fillWindow(w.plan(), picker, limits, rc);
    while (more && !(limits.stop && limits.stop->load(std::memory_order_relaxed))) {
        const bool go = w.W == 1 ? refineSerialWindow(limits, rc) : refineParallelWindow(limits, rc);
        if (!go) break;
        if (w.planned) {
            w.planned = false;
            w.current ^= 1;
            more = w.plan().picks > 0;
            if (more) ++rc.planned;
        } else {
            more = fillWindow(w.plan(), picker, limits, rc);
        }
    }
    // The model's own table takes the last round's moves; the workers'
    // copies are made equal again when the next refinement starts.
    if (w.pending != 0) {
        takeMoves(w.logs[w.pending & 1], 0);  // no round after it: no worker has taken it
        w.pending = 0;
    }
    w.defer = false;
    w.copies_synced = false;  // the model's table may change before the next refinement
    w.picker = nullptr;
    w.limits = nullptr;
    w.count = nullptr;
    return rc;
}

} // namespace rost
