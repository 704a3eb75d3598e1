#pragma once

// The state of ModelCore::refine's windows (internal; src/core/refine_windows.cpp).

#include <cstddef>
#include <cstdint>

#include "aligned_buffer.hpp"
#include "rost/kernel_types.hpp"
#include "model_core.hpp"
#include "worker_pool.hpp"

namespace rost {

// A step picker over every step of a window in order, round and round.
class SweepPicker final : public StepPicker {
public:
    SweepPicker(int64_t first, int64_t end) noexcept : first_(first), end_(end), t_(first) {}
    int64_t next() noexcept override {
        const int64_t t = t_;
        t_ = t_ + 1 < end_ ? t_ + 1 : first_;
        return t;
    }

private:
    int64_t first_, end_, t_;
};

// A window's plan: its picks, its tasks (cells) and rounds, its key.
// Two plans: with workers and a budget known in advance, the next
// window is planned by a task of the current window's last round while
// the others refine (refine(); docs/design.md, "Refinement on every core").
struct ModelCore::WindowPlan {
    // Picks, in draw order.
    uint32_t picks = 0;
    AlignedBuffer<int64_t> pick_step;
    AlignedBuffer<int32_t> pick_cell;
    AlignedBuffer<uint64_t> pick_ord;    // which step pick it came from (1, 2, ...)
    AlignedBuffer<uint32_t> pick_next;   // the task's next pick, or kNone
    AlignedBuffer<uint8_t> pick_done;
    // Tasks: one per distinct cell of the window, in order of first pick.
    uint32_t tasks = 0;
    AlignedBuffer<int64_t> task_step;
    AlignedBuffer<int32_t> task_cell;
    AlignedBuffer<uint32_t> task_head;   // first pick
    AlignedBuffer<uint32_t> task_tail;   // last pick
    AlignedBuffer<uint32_t> task_mult;   // picks
    AlignedBuffer<uint32_t> task_words;  // its cell's words
    AlignedBuffer<uint32_t> task_key;    // colour * L + length key (order, below)
    AlignedBuffer<std::size_t> task_z0;  // offset of its labels at the round's start
    // Tasks ordered by colour and, where a worker refines two tasks at once
    // (kernel_pair.hpp), within a colour by their cell's words (L =
    // kLengthKeys keys: 0..L - 2 words, then more; else L = 1), so that the
    // two have cells about as long; round c is order[colour_begin[c],
    // colour_begin[c + 1]).
    static constexpr uint32_t kLengthKeys = 64;
    AlignedBuffer<uint32_t> order;
    AlignedBuffer<uint32_t> colour_begin;
    AlignedBuffer<uint32_t> key_begin;  // the counting sort's, colours * kLengthKeys + 1
    // Laid out with the grouping (ModelCore::layoutRounds), so that whoever plans
    // the window does it, not the caller between rounds: each round's tokens
    // and, with workers, its tasks by owner (owned[owned_begin[c], ...)) and
    // the owners' ranges (round_cuts[c * (workers + 1), ...)). With planning
    // ahead, the last round of more than one cell also holds the task that
    // plans the next window.
    AlignedBuffer<uint64_t> round_tokens;
    AlignedBuffer<uint32_t> owned;
    AlignedBuffer<uint32_t> owned_begin;
    AlignedBuffer<uint32_t> round_cuts;  // sized with the workers (Windows::sizeWorkers)
    uint64_t key = 0;      // of the counter-based draws
    bool grouped = false;  // key drawn and tasks grouped (planned ahead)

    void size(std::size_t w, std::size_t colours) {
        pick_step.reset(w);
        pick_cell.reset(w);
        pick_ord.reset(w);
        pick_next.reset(w);
        pick_done.reset(w);
        task_step.reset(w);
        task_cell.reset(w);
        task_head.reset(w);
        task_tail.reset(w);
        task_mult.reset(w);
        task_words.reset(w);
        task_key.reset(w);
        task_z0.reset(w);
        order.reset(w);
        colour_begin.reset(colours + 1);
        key_begin.reset(colours * kLengthKeys + 1);
        round_tokens.reset(colours);
        owned.reset(w + 1);  // + the task that plans the next window
        owned_begin.reset(colours + 1);
    }
    std::size_t bytes() const noexcept {
        return pick_step.bytes() + pick_cell.bytes() + pick_ord.bytes() + pick_next.bytes() + pick_done.bytes() +
               task_step.bytes() + task_cell.bytes() + task_head.bytes() + task_tail.bytes() + task_mult.bytes() +
               task_words.bytes() + task_key.bytes() + task_z0.bytes() + order.bytes() + colour_begin.bytes() +
               key_begin.bytes() + round_tokens.bytes() +
               owned.bytes() + owned_begin.bytes();
    }
};

// The moves of a round's tasks, listed by each task: word | from << 32 |
// to << 48 (a compact list the merge reads on every core).
struct ModelCore::MoveLog {
    AlignedBuffer<uint64_t> moves;
    AlignedBuffer<uint32_t> count;  // by task: how many
    // The round's n tasks (and the planning task) and, by task, its first
    // move: the window plan's own arrays when the moves are taken at once,
    // else a copy here (the plan may be filled again before they are taken).
    const uint32_t* task_list = nullptr;
    const std::size_t* task_off = nullptr;
    AlignedBuffer<std::size_t> off;
    AlignedBuffer<uint32_t> tasks;
    uint32_t n = 0;
    uint64_t round = 0;  // the round's number (Windows::round)
    void size(std::size_t movesCap, std::size_t W) {
        moves.reset(movesCap);
        off.reset(W);
        count.reset(W);
        tasks.reset(W + 1);
    }
    std::size_t bytes() const noexcept { return moves.bytes() + off.bytes() + count.bytes() + tasks.bytes(); }
};

// The windows: their two plans, the grouping table, the rounds' labels and moves, the workers' tables.
// Sized at construction: nothing here allocates afterwards.
struct ModelCore::Windows {
    uint32_t W = 1;
    std::size_t colours = 1;
    using Plan = WindowPlan;
    Plan plans[2];
    uint32_t current = 0;
    Plan& plan() noexcept { return plans[current]; }
    const Plan& plan() const noexcept { return plans[current]; }
    Plan& spare() noexcept { return plans[current ^ 1]; }
    // Planning ahead: what the next window is drawn with (set by refine()),
    // whether the current window's last round plans it, and whether it did.
    StepPicker* picker = nullptr;
    const RefineLimits* limits = nullptr;
    RefineCount* count = nullptr;
    bool plan_ahead = false;
    bool planned = false;
    static constexpr uint32_t kPlanTask = 0xFFFFFFFEu;  // the task that plans the next window
    // (step, cell) -> task, open addressing, cleared lazily by stamp.
    AlignedBuffer<int64_t> hash_key;
    AlignedBuffer<uint32_t> hash_task;
    AlignedBuffer<uint32_t> hash_stamp;
    uint32_t stamp = 0;
    // Labels of a round's cells when it began (frozen view of n_k^v).
    AlignedBuffer<uint16_t> z0;
    // The rounds' moves, in two logs by round parity: with merges deferred,
    // a round's moves are added to each copy of n_k^v by its worker at the
    // start of the next round, while that round's tasks list theirs in the
    // other log.
    MoveLog logs[2];
    uint64_t round = 0;              // frozen rounds run so far (the current one lists its moves in logs[round & 1])
    bool defer = false;              // merges deferred to the next round's job (no RefineControl)
    uint64_t pending = 0;            // a round whose moves some copy has not taken yet (0: none)
    AlignedBuffer<uint64_t> merged;  // per copy (a cache line each): the last round taken
    static constexpr std::size_t kMergedStride = kCacheLine / sizeof(uint64_t);
    // Per worker: neighbourhood sums and the kernel's tables. With workers,
    // each worker w > 0 reads its own copy of n_k^v (replica w - 1; worker 0
    // reads the model's), so the rows a round reads are in its core's cache:
    // the copies are made equal when a refinement starts, and each round's
    // moves are added to every copy (docs/design.md, "Refinement on every core").
    AlignedBuffer<int32_t> worker_g;  // two sums and start counts per worker (a pair: src/core/kernel_pair.hpp)
    std::size_t g_stride = 0;
    AlignedBuffer<kernel::Tables> worker_tables;
    AlignedBuffer<int32_t> replicas;
    AlignedBuffer<int32_t> dnk;  // a round's change to n_k, one part per worker (its tasks' moves)
    // Per worker, at K 16 or 32 without growth: kernel::Tables::left, Kp x Kp,
    // filled by the worker itself as it starts its part of a frozen round, so
    // the lines stay in its core's cache (one table written by the caller
    // every round moved 4 KiB at K = 32 from core to core each round).
    AlignedBuffer<float> left;
    bool copies_synced = false;  // inside a refinement: the copies are kept equal
    // The step being expanded into cell picks.
    int64_t cur_step = -1;
    int next_cell = 0;
    uint64_t cur_ord = 0;
    uint64_t counted_ord = 0;
    static constexpr uint32_t kNone = 0xFFFFFFFFu;

    // Worker `worker`'s neighbourhood sums: j = 0, or 1 for the second task of a pair.
    int32_t* sums(int worker, int j) noexcept {
        return worker_g.data() + (2 * static_cast<std::size_t>(worker) + static_cast<std::size_t>(j)) * 2 * g_stride;
    }
    // Beside them, the task's cell counts when it started (its change to n_k at the end).
    int32_t* startCounts(int worker, int j) noexcept { return sums(worker, j) + g_stride; }
    std::size_t workerBytes() const noexcept {
        return worker_g.bytes() + worker_tables.bytes() + replicas.bytes() + dnk.bytes() + left.bytes() + merged.bytes() +
               plans[0].round_cuts.bytes() + plans[1].round_cuts.bytes();
    }
    // Sized for n workers over a V x Kp table (set-up code); `lefts`: with the tables of kernel::Tables::left.
    void sizeWorkers(std::size_t n, std::size_t V, std::size_t Kp, bool lefts) {
        g_stride = Kp;
        worker_g.reset(4 * n * Kp);
        worker_tables.reset(n);
        replicas.reset(W > 1 ? (n - 1) * V * Kp : 0);
        dnk.reset(n * Kp);
        left.reset(lefts ? n * Kp * Kp : 0);
        merged.reset(n * kMergedStride);
        for (Plan& P : plans) P.round_cuts.reset(colours * (n + 1));
    }

    std::size_t bytes() const noexcept {
        return plans[0].bytes() + plans[1].bytes() + hash_key.bytes() + hash_task.bytes() + hash_stamp.bytes() +
               z0.bytes() + logs[0].bytes() + logs[1].bytes() + workerBytes() + sizeof(Windows);
    }
};

} // namespace rost
