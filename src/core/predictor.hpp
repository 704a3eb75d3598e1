#pragma once

// The time-budget predictors' average (src/core/engine.cpp: nanoseconds a
// token of refinement, nanoseconds a publication), in its own header so
// tests reach it.

#include <algorithm>
#include <cstdint>

namespace rost::detail {

// Exponential average that a single outlier (the thread preempted in the
// middle of a cell) moves by a bounded amount: each sample is clamped to
// [0.5, 3] times the current average first. The first sample replaces the
// prior, within [1/8, 8] times it: a first round preempted for 10 ms would
// otherwise set a cost a thousand times the true one, and a refiner that
// then predicts no round fits its budget runs none, so no later sample could
// ever bring the average back. At the refiner's weight (0.05), true samples
// bring an average 8 times too high within 2 times of the truth in 55 rounds,
// one 8 times too low in 16.
inline double robustAverage(double avg, double sample, double weight, uint64_t& samples) noexcept {
    if (samples++ == 0) return std::clamp(sample, avg / 8.0, avg * 8.0);
    const double s = std::clamp(sample, 0.5 * avg, 3.0 * avg);
    return avg + weight * (s - avg);
}

} // namespace rost::detail
