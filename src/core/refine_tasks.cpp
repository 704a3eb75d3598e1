// The tasks of a window's rounds (src/core/refine_windows.cpp): a cell
// refined against the round's frozen word-topic counts, its moves logged
// for the merge, and the merge of a round's moves into a copy of n_k^v; two
// such cells at once where the kernel interleaves them
// (src/core/kernel_pair.hpp); or a cell refined live.

#include <cstring>

#include "counter_rng.hpp"
#include "kernel_frozen.hpp"
#include "kernel_pair.hpp"
#include "model_core.hpp"
#include "refine_windows.hpp"

namespace rost {

template <int KP>
void ModelCore::setTaskKernels() noexcept {
    frozen_kernel_[0] = &ModelCore::frozenTask<KP, kernel::Path::Scalar>;
    frozen_kernel_[1] = &ModelCore::frozenTask<KP, kernel::Path::Simd>;
    live_kernel_[0] = &ModelCore::liveTask<KP, kernel::Path::Scalar>;
    live_kernel_[1] = &ModelCore::liveTask<KP, kernel::Path::Simd>;
    // Pairs where the kernel interleaves them; elsewhere a pair would only
    // make the tasks a thief can take coarser.
    pair_kernel_[0] = nullptr;
    pair_kernel_[1] = nullptr;
    if constexpr (kernel::interleavesPairs<KP, kernel::Path::Simd>())
        pair_kernel_[1] = &ModelCore::frozenTaskPair<KP, kernel::Path::Simd>;
}
template void ModelCore::setTaskKernels<kernel::kGrow>() noexcept;
template void ModelCore::setTaskKernels<0>() noexcept;
template void ModelCore::setTaskKernels<16>() noexcept;
template void ModelCore::setTaskKernels<32>() noexcept;
template void ModelCore::setTaskKernels<64>() noexcept;

// G(c): the cell, its spatial neighbours, the same cell at t +- 1..g.time.
// The sums build in a local array (K known: registers) from locals, then
// go to g once: summed in g itself, every add was a store the compiler had to
// assume might change the model's own fields, so each neighbour re-read them
// and no add was a vector one.
template <int KP>
void ModelCore::sumNeighbourhood(const StepSlots& slots, int cell, int32_t* g) const noexcept {
    const int32_t* const counts = nck_.data();
    const std::size_t stride = static_cast<std::size_t>(Kp_), cells = static_cast<std::size_t>(cells_);
    const auto at = [&](std::size_t slot, uint32_t c) { return counts + (slot * cells + c) * stride; };
    const uint32_t b = nbr_begin_[cell], e = nbr_begin_[cell + 1];
#if defined(ROST_KERNEL_SIMD)
    if constexpr (KP > 0) {
        // (Written with the kernel's vectors: GCC keeps a plain array of 16
        // sums in general registers, one scalar add each.)
        constexpr int nb = KP / kernel::kBlock;
        using kernel::v4::load;
        kernel::v4::I acc[nb];
        const int32_t* h = at(slots.self, nbr_cell_[b]);
        for (int q = 0; q < nb; ++q) acc[q] = load(h + kernel::kBlock * q);
        for (uint32_t j = b + 1; j < e; ++j) {
            h = at(slots.self, nbr_cell_[j]);
            for (int q = 0; q < nb; ++q) acc[q] = kernel::v4::add(acc[q], load(h + kernel::kBlock * q));
        }
        for (int j = 0; j < slots.count; ++j) {
            h = at(slots.temporal[j], static_cast<uint32_t>(cell));
            for (int q = 0; q < nb; ++q) acc[q] = kernel::v4::add(acc[q], load(h + kernel::kBlock * q));
        }
        for (int q = 0; q < nb; ++q) kernel::v4::store(g + kernel::kBlock * q, acc[q]);
        return;
    }
#endif
    if constexpr (KP > 0) {
        alignas(64) int32_t acc[KP];
        const int32_t* h = at(slots.self, nbr_cell_[b]);
        for (int k = 0; k < KP; ++k) acc[k] = h[k];
        for (uint32_t j = b + 1; j < e; ++j) {
            h = at(slots.self, nbr_cell_[j]);
            for (int k = 0; k < KP; ++k) acc[k] += h[k];
        }
        for (int j = 0; j < slots.count; ++j) {
            h = at(slots.temporal[j], static_cast<uint32_t>(cell));
            for (int k = 0; k < KP; ++k) acc[k] += h[k];
        }
        std::memcpy(g, acc, sizeof acc);
    } else {
        // With growth only the live blocks can hold counts (every cell's count
        // of a closed topic is 0): the rest is zero, so the cost follows the open topics.
        const int Kp = kernel::liveLanes<KP>(tables_, Kp_);
        for (int k = Kp; k < Kp_; ++k) g[k] = 0;
        const int32_t* h = at(slots.self, nbr_cell_[b]);
        for (int k = 0; k < Kp; ++k) g[k] = h[k];
        for (uint32_t j = b + 1; j < e; ++j) {
            h = at(slots.self, nbr_cell_[j]);
            for (int k = 0; k < Kp; ++k) g[k] += h[k];
        }
        for (int j = 0; j < slots.count; ++j) {
            h = at(slots.temporal[j], static_cast<uint32_t>(cell));
            for (int k = 0; k < Kp; ++k) g[k] += h[k];
        }
    }
}
template void ModelCore::sumNeighbourhood<kernel::kGrow>(const StepSlots&, int, int32_t*) const noexcept;
template void ModelCore::sumNeighbourhood<0>(const StepSlots&, int, int32_t*) const noexcept;
template void ModelCore::sumNeighbourhood<16>(const StepSlots&, int, int32_t*) const noexcept;
template void ModelCore::sumNeighbourhood<32>(const StepSlots&, int, int32_t*) const noexcept;
template void ModelCore::sumNeighbourhood<64>(const StepSlots&, int, int32_t*) const noexcept;

// The next task's cell (its labels, words and counts) on its way to the
// cache while this one refines.
void ModelCore::prefetchTask(uint32_t task) const noexcept {
    const Windows::Plan& plan = win_->plan();
    const std::size_t cell = static_cast<std::size_t>(plan.task_cell[task]);
    const std::size_t at = slotOf(plan.task_step[task]) * cells_ + cell;
    const uint32_t n = cell_n_[at];
    const char* z = reinterpret_cast<const char*>(cell_z_.data() + at * cap_);
    const char* words = reinterpret_cast<const char*>(cell_words_.data() + at * cap_);
    for (std::size_t b = 0; b < n * sizeof(uint16_t); b += kCacheLine) __builtin_prefetch(z + b, 1);
    for (std::size_t b = 0; b < n * sizeof(uint32_t); b += kCacheLine) __builtin_prefetch(words + b, 0);
    __builtin_prefetch(nck(at / cells_, static_cast<int>(cell)), 1);
}

namespace {

// (restrict: vector loops, no call; K known where KP > 0.) The cell's
// counts less its sums.
template <int KP>
void countsLessSums(int32_t* __restrict to, const int32_t* __restrict nc, const int32_t* __restrict g,
                    int Kp) noexcept {
    const int K = KP > 0 ? KP : Kp;
    for (int k = 0; k < K; ++k) to[k] = nc[k] - g[k];
}
// The cell's counts from its sums, and their change added to dnk.
template <int KP>
void countsFromSums(int32_t* __restrict nc, int32_t* __restrict dnk, const int32_t* __restrict less,
                    const int32_t* __restrict g, int Kp) noexcept {
    const int K = KP > 0 ? KP : Kp;
    for (int k = 0; k < K; ++k) {
        const int32_t now = less[k] + g[k];
        dnk[k] += now - nc[k];
        nc[k] = now;
    }
}

} // namespace

// A frozen task's cell, with its round-start labels saved and its
// neighbourhood summed into g. The kernels update g word by word and leave
// the cell's own counts nc alone: g is nc plus counts no task of the round
// writes, so `start` keeps nc - g, and closeFrozenTask sets nc to start + g.
template <int KP>
kernel::FrozenCell ModelCore::openFrozenTask(uint32_t task, int32_t* g, int32_t* start) noexcept {
    Windows& w = *win_;
    const Windows::Plan& plan = w.plan();
    const int cell = plan.task_cell[task];
    StepSlots slots;
    stepSlots(plan.task_step[task], slots);
    const std::size_t at = slots.self * cells_ + static_cast<std::size_t>(cell);
    const uint32_t n = cell_n_[at];
    uint16_t* z = cell_z_.data() + at * cap_;
    uint16_t* z0 = w.z0.data() + plan.task_z0[task];
    std::memcpy(z0, z, n * sizeof(uint16_t));
    int32_t* nc = nck(slots.self, cell);
    sumNeighbourhood<KP>(slots, cell, g);
    countsLessSums<KP>(start, nc, g, Kp_);
    uint64_t* moves = w.logs[w.round & 1].moves.data() + plan.task_z0[task];
    return {g, nc, cell_words_.data() + at * cap_, z, z0, n, moves};
}

// The end of a frozen task: its `moved` moves (listed by the kernels in
// c.moves) counted for the merge after the round, the cell's counts set
// from its sums, and their change added to the worker's part of n_k's
// change (added up after the round).
template <int KP>
void ModelCore::closeFrozenTask(int worker, uint32_t task, const kernel::FrozenCell& c, const int32_t* start,
                                uint32_t moved) noexcept {
    Windows& w = *win_;
    w.logs[w.round & 1].count[task] = moved;
    int32_t* const dnk = w.dnk.data() + static_cast<std::size_t>(worker) * static_cast<std::size_t>(Kp_);
    countsFromSums<KP>(c.nc, dnk, start, c.nG, Kp_);
}

// Adds a round's moves to copy `copy` of n_k^v (integer adds, in any order the same) and
// records that the copy took them. Run by the copy's worker, or by the calling thread between jobs.
void ModelCore::takeMoves(const MoveLog& log, uint32_t copy) noexcept {
    Windows& w = *win_;
    int32_t* const nkv = w.worker_tables[copy].nkv;
    const auto Kp = static_cast<std::size_t>(Kp_);  // a local: a count's store could otherwise change Kp_
    for (uint32_t i = 0; i < log.n; ++i) {
        const uint32_t t = log.task_list[i];
        if (t == Windows::kPlanTask) continue;
        const uint64_t* moves = log.moves.data() + log.task_off[t];
        for (uint32_t c = 0, m = log.count[t]; c < m; ++c) {
            const uint64_t mv = moves[c];
            int32_t* row = nkv + static_cast<std::size_t>(static_cast<uint32_t>(mv)) * Kp;
            --row[static_cast<uint16_t>(mv >> 32)];
            ++row[static_cast<uint16_t>(mv >> 48)];
        }
    }
    w.merged[copy * Windows::kMergedStride] = log.round;
}
template <int KP, kernel::Path P>
void ModelCore::frozenTask(int worker, uint32_t task) noexcept {
    Windows& w = *win_;
    const Windows::Plan& plan = w.plan();
    const kernel::FrozenCell c = openFrozenTask<KP>(task, w.sums(worker, 0), w.startCounts(worker, 0));
    const kernel::Tables& t = w.worker_tables[static_cast<std::size_t>(worker)];
    // The first pick, every word still at its round-start label; then the
    // others. The last pick's list of moves is the task's.
    uint32_t p = plan.task_head[task];
    detail::CounterRng first(plan.key, p);
    uint32_t moved = kernel::refineCellFrozen<KP, P, true>(t, c.nG, c.words, c.topics, c.z0, c.n, first, c.moves);
    for (p = plan.pick_next[p]; p != Windows::kNone; p = plan.pick_next[p]) {
        detail::CounterRng rng(plan.key, p);
        moved = kernel::refineCellFrozen<KP, P>(t, c.nG, c.words, c.topics, c.z0, c.n, rng, c.moves);
    }
    closeFrozenTask<KP>(worker, task, c, w.startCounts(worker, 0), moved);
}

// Tasks a and b of one round on one worker: their picks two by two (each
// task's own in order), each cell with the draws and result it has alone.
template <int KP, kernel::Path P>
void ModelCore::frozenTaskPair(int worker, uint32_t a, uint32_t b) noexcept {
    Windows& w = *win_;
    const Windows::Plan& plan = w.plan();
    const kernel::FrozenCell A = openFrozenTask<KP>(a, w.sums(worker, 0), w.startCounts(worker, 0));
    const kernel::FrozenCell B = openFrozenTask<KP>(b, w.sums(worker, 1), w.startCounts(worker, 1));
    const kernel::Tables& t = w.worker_tables[static_cast<std::size_t>(worker)];
    // The first picks (every word still at its round-start label), then the
    // others. Each task's last pick's list of moves is its own.
    uint32_t pa = plan.task_head[a], pb = plan.task_head[b];
    detail::CounterRng firstA(plan.key, pa), firstB(plan.key, pb);
    kernel::PairMoves moved = kernel::refineCellsFrozenPair<KP, P, true>(t, A, firstA, B, firstB);
    for (pa = plan.pick_next[pa], pb = plan.pick_next[pb]; pa != Windows::kNone && pb != Windows::kNone;
         pa = plan.pick_next[pa], pb = plan.pick_next[pb]) {
        detail::CounterRng ra(plan.key, pa), rb(plan.key, pb);
        moved = kernel::refineCellsFrozenPair<KP, P>(t, A, ra, B, rb);
    }
    for (; pa != Windows::kNone; pa = plan.pick_next[pa]) {
        detail::CounterRng rng(plan.key, pa);
        moved.a = kernel::refineCellFrozen<KP, P>(t, A.nG, A.words, A.topics, A.z0, A.n, rng, A.moves);
    }
    for (; pb != Windows::kNone; pb = plan.pick_next[pb]) {
        detail::CounterRng rng(plan.key, pb);
        moved.b = kernel::refineCellFrozen<KP, P>(t, B.nG, B.words, B.topics, B.z0, B.n, rng, B.moves);
    }
    closeFrozenTask<KP>(worker, a, A, w.startCounts(worker, 0), moved.a);
    closeFrozenTask<KP>(worker, b, B, w.startCounts(worker, 1), moved.b);
}

template <int KP, kernel::Path P>
void ModelCore::liveTask(int worker, uint32_t task) noexcept {
    Windows& w = *win_;
    const Windows::Plan& plan = w.plan();
    const int64_t step = plan.task_step[task];
    const int cell = plan.task_cell[task];
    StepSlots slots;
    stepSlots(step, slots);
    const std::size_t slot = slots.self;
    const uint32_t n = cell_n_[slot * cells_ + static_cast<std::size_t>(cell)];
    const std::size_t base = (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
    int32_t* g = w.sums(worker, 0);
    sumNeighbourhood<KP>(slots, cell, g);
    for (uint32_t p = plan.task_head[task]; p != Windows::kNone; p = plan.pick_next[p]) {
        detail::CounterRng rng(plan.key, p);
        kernel::refineCell<KP, P>(tables_, g, nck(slot, cell), cell_words_.data() + base, cell_z_.data() + base, n,
                                  rng);
    }
}

} // namespace rost
