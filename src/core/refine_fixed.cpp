// Refinement in windows with a fixed topic model (Config::fixed; docs/design.md,
// "A fixed topic model"): n_k^v and n_k are never written, so a round's
// tasks refine against them as they are and leave no moves to merge; a
// task's cell counts are its own, as in every round.

#include "counter_rng.hpp"
#include "kernel_fixed.hpp"
#include "model_core.hpp"
#include "refine_windows.hpp"

namespace rost {

void ModelCore::setFixedTaskKernels() noexcept {
    frozen_kernel_[0] = frozen_kernel_[1] = &ModelCore::fixedTask;
    live_kernel_[0] = live_kernel_[1] = &ModelCore::fixedTask;
    pair_kernel_[0] = pair_kernel_[1] = nullptr;
}

void ModelCore::fixedTask(int worker, uint32_t task) noexcept {
    Windows& w = *win_;
    const Windows::Plan& plan = w.plan();
    const int64_t step = plan.task_step[task];
    const int cell = plan.task_cell[task];
    const std::size_t slot = slotOf(step);
    const uint32_t n = cell_n_[slot * cells_ + static_cast<std::size_t>(cell)];
    const std::size_t base = (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
    int32_t* g = w.sums(worker, 0);
    neighbourhood(step, cell, g, false);
    for (uint32_t p = plan.task_head[task]; p != Windows::kNone; p = plan.pick_next[p]) {
        detail::CounterRng rng(plan.key, p);
        kernel::refineCellFixed(tables_, g, nck(slot, cell), cell_words_.data() + base, cell_z_.data() + base, n, rng);
    }
    w.logs[w.round & 1].count[task] = 0;  // nothing to merge
}

} // namespace rost
