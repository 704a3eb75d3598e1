// Refinement of the model's cells (rost/model.hpp, "refinement"): the
// kernels chosen for K, a step's ring slots and its cells refined in turn.
// Windows of picks on every core: refine_windows.cpp.


#include "model_core.hpp"

#include "kernel.hpp"
#include "kernel_fixed.hpp"
#include "refine_windows.hpp"

namespace rost {

void ModelCore::selectKernels() noexcept {
    if (cfg_.fixed) {  // one kernel for every K (src/core/refine_fixed.cpp)
        simd_kernel_ = scalar_kernel_ = &ModelCore::refineCells<0, kernel::Path::Scalar>;
        return setFixedTaskKernels();
    }
    // Compile-time K for the common sizes (unrolled blocks, registers);
    // growing topics take the runtime kernels that look at active topics only.
    if (cfg_.grow) {
        simd_kernel_ = &ModelCore::refineCells<kernel::kGrow, kernel::Path::Simd>;
        scalar_kernel_ = &ModelCore::refineCells<kernel::kGrow, kernel::Path::Scalar>;
        setTaskKernels<kernel::kGrow>();
        return;
    }
    switch (Kp_) {
    case 16:
        simd_kernel_ = &ModelCore::refineCells<16, kernel::Path::Simd>;
        scalar_kernel_ = &ModelCore::refineCells<16, kernel::Path::Scalar>;
        setTaskKernels<16>();
        break;
    case 32:
        simd_kernel_ = &ModelCore::refineCells<32, kernel::Path::Simd>;
        scalar_kernel_ = &ModelCore::refineCells<32, kernel::Path::Scalar>;
        setTaskKernels<32>();
        break;
    case 64:
        simd_kernel_ = &ModelCore::refineCells<64, kernel::Path::Simd>;
        scalar_kernel_ = &ModelCore::refineCells<64, kernel::Path::Scalar>;
        setTaskKernels<64>();
        break;
    default:
        simd_kernel_ = &ModelCore::refineCells<0, kernel::Path::Simd>;
        scalar_kernel_ = &ModelCore::refineCells<0, kernel::Path::Scalar>;
        setTaskKernels<0>();
        break;
    }
}

void ModelCore::stepSlots(int64_t step, StepSlots& out) const noexcept {
    // One division: a step in the window is less than ring_ steps from this
    // one, so its slot is this one's moved by dt and wrapped once.
    const std::size_t self = slotOf(step), ring = static_cast<std::size_t>(ring_);
    out.self = self;
    out.count = 0;
    for (int dt = 1; dt <= cfg_.g_time; ++dt) {
        const auto d = static_cast<std::size_t>(dt);
        if (inWindow(step - dt)) out.temporal[out.count++] = self >= d ? self - d : self + ring - d;
        if (inWindow(step + dt)) out.temporal[out.count++] = self + d < ring ? self + d : self + d - ring;
    }
}

template <int KP, kernel::Path P>
uint32_t ModelCore::refineCells(const StepSlots& slots, int c0, int c1) noexcept {
    const std::size_t slot = slots.self;
    int32_t* g = scratch_g_.data();
    uint32_t total = 0;
    for (int cell = c0; cell < c1; ++cell) {
        const uint32_t n = cell_n_[slot * cells_ + cell];
        if (n == 0) continue;
        sumNeighbourhood<KP>(slots, cell, g);  // G(c)
        const std::size_t base = (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
        if (cfg_.fixed)
            kernel::refineCellFixed(tables_, g, nck(slot, cell), cell_words_.data() + base, cell_z_.data() + base, n, rng_);
        else
            kernel::refineCell<KP, P>(tables_, g, nck(slot, cell), cell_words_.data() + base, cell_z_.data() + base, n,
                                      rng_);
        total += n;
    }
    tokens_refined_ += total;
    return total;
}

uint32_t ModelCore::refineCell(int64_t step, int cell) noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return 0;
    StepSlots slots;
    stepSlots(step, slots);
    return (this->*(path_ == kernel::Path::Simd ? simd_kernel_ : scalar_kernel_))(slots, cell, cell + 1);
}

uint32_t ModelCore::refineStep(int64_t step) noexcept {
    if (!inWindow(step)) return 0;
    StepSlots slots;
    stepSlots(step, slots);
    return (this->*(path_ == kernel::Path::Simd ? simd_kernel_ : scalar_kernel_))(slots, 0, cells_);
}

uint32_t ModelCore::wordsInStep(int64_t step) const noexcept {
    if (!inWindow(step)) return 0;
    const std::size_t slot = slotOf(step);
    uint32_t total = 0;
    for (int c = 0; c < cells_; ++c) total += cell_n_[slot * cells_ + c];
    return total;
}

// With growth, the moves of growth from the data follow refinement each time
// it crosses a multiple of the window's words (a sweep's worth of tokens:
// src/core/growth.cpp), so a realtime refiner grows its topics too. Under a
// control (a time budget) the move waits for the start of the next call and
// takes a quarter of what that call can afford: its split moves the tokens
// of as many steps as that share allows (the whole window when it fits).
RefineCount ModelCore::refine(StepPicker& picker, const RefineLimits& limits) noexcept {
    const bool growing = cfg_.grow && !cfg_.fixed;
    if (growing && move_due_ && limits.control) {
        // Not when a quarter of the allowance is less than a step's words on
        // average (a call with no time left): the move waits for a call that has it.
        const uint64_t allowance = limits.control->tokenAllowance();
        const uint64_t stepsIn = static_cast<uint64_t>(steps_ - oldestStep());
        if (allowance == UINT64_MAX || (stepsIn > 0 && allowance / 4 >= windowTokens() / stepsIn)) {
            move_due_ = false;
            growthMoves(allowance == UINT64_MAX ? UINT64_MAX : allowance / 4);
        }
    }
    const uint64_t before = tokens_refined_;
    const RefineCount rc = refineWindows(picker, limits);
    if (!growing) return rc;
    const uint64_t every = windowTokens();
    if (every > 0 && before / every != tokens_refined_ / every) {
        if (limits.control) {
            move_due_ = true;
        } else {
            growthMoves();
        }
    }
    return rc;
}

// Whole sweeps of the window; with growth, the moves follow every sweep.
uint64_t ModelCore::refineAll(int sweeps, const std::atomic<bool>* stop) noexcept {
    if (sweeps <= 0 || steps_ == 0) return 0;
    const uint64_t stepsPerSweep = static_cast<uint64_t>(steps_ - oldestStep());
    SweepPicker picker(oldestStep(), steps_);
    RefineLimits limits;
    limits.stop = stop;
    if (!cfg_.grow || cfg_.fixed) {
        limits.steps = static_cast<uint64_t>(sweeps) * stepsPerSweep;
        return refineWindows(picker, limits).tokens;
    }
    uint64_t tokens = 0;
    limits.steps = stepsPerSweep;
    for (int i = 0; i < sweeps && !(stop && stop->load(std::memory_order_relaxed)); ++i) {
        tokens += refineWindows(picker, limits).tokens;
        growthMoves();
    }
    return tokens;
}

} // namespace rost
