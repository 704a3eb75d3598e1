#pragma once

// The eight refinement strategies P(t|T) of the paper's section VI. A
// strategy draws the time step to refine next, given the current time T and
// the refinable window (the ring holds only the last W steps).
//
// Time steps: the paper's t and T count from 1 (t = 1..T); Model's step
// indices count from 0. Strategy works in the paper's 1-based convention and
// Strategy::drawStep() converts to Model's 0-based steps.

#include <cstdint>
#include <string>

#include "rost/random.hpp"
#include "rost/settings_schema.hpp"
#include "rost/status.hpp"

namespace rost {

enum class StrategyKind : uint8_t {
    Now,                  // P(t|T) = [t = T]
    Uniform,              // P(t|T) = 1/T
    AgeProportional,      // P(t|T) = t / sum_{i=1..T} i
    Exponential,          // P(t|T) = q (1-q)^(T-t)
    UniformNow,           // eta at t = T, (1-eta)/(T-1) elsewhere
    AgeProportionalNow,   // eta at t = T, (1-eta) t / sum_{i=1..T-1} i elsewhere
    UniformExponential,   // eta q (1-q)^(T-t) + (1-eta)/T
    AgeProportionalExponential,  // eta q (1-q)^(T-t) + (1-eta) t / sum_{i=1..T} i
};

// Names used on command lines: now, uniform, agep, exp, uni+now, agep+now,
// uni+exp, agep+exp.
const char* toString(StrategyKind k) noexcept;
// Parses one of the names above; the error message lists the valid names.
Status parseStrategy(const std::string& name, StrategyKind& out);

struct StrategyConfig {
    StrategyKind kind = settingDefault<StrategyKind>("sampler");
    // Defaults from the eta/q sweep (bench/RESULTS.md, "Tuning sweep"): the
    // best setting of the mixtures averaged over budgets of 4, 31 and 437
    // step refinements per observation. Larger budgets favour a smaller eta,
    // smaller budgets a larger one (docs/engine.md).
    double eta = settingDefault<double>("eta");  // mixing proportion of the local part (the paper's 0.5; the sweep agrees)
    double q = settingDefault<double>("q");      // geometric parameter of the exponential part (the paper gives none)
    // Checks eta and q; the message names the field, its value and the range.
    [[nodiscard]] Status validate() const;
};

// Draws t from P(t|T) restricted to the window [T-W+1, T] and renormalised
// there: P_W(t) = P(t|T) / sum_{t' in window} P(t'|T), where P(t|T) is the
// paper's formula as written. Each part (uniform, age-proportional,
// geometric) is drawn by an exact inverse CDF over the window; a mixture picks
// its part with probability proportional to that part's mass in the window.
// O(1) per draw, no allocation, for any T (T < 6e9 steps). See docs/engine.md.
class Strategy {
public:
    Strategy() = default;
    explicit Strategy(const StrategyConfig& cfg) noexcept;

    const StrategyConfig& config() const noexcept { return cfg_; }

    // 1-based t in [T-W+1, T]; T >= 1, 1 <= W <= T (W is clamped to that range).
    int64_t draw(int64_t T, int64_t W, Rng& rng) const noexcept;
    // 0-based step for a Model with `steps` steps of which the last `window`
    // are refinable: draw(steps, window) - 1.
    int64_t drawStep(int64_t steps, int64_t window, Rng& rng) const noexcept {
        return draw(steps, window, rng) - 1;
    }
    // P_W(t) (1-based t), the probability draw() realises; 0 outside the window.
    double probability(int64_t t, int64_t T, int64_t W) const noexcept;

private:
    StrategyConfig cfg_{};
    double log1mq_ = 0.0;  // log(1 - q), precomputed
};

} // namespace rost
