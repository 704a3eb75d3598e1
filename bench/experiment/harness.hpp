#pragma once

// The paper's section VII experiment, run through the library's own engine:
//
//  * online: the realtime engine (rost/engine.hpp) takes the stream one
//    observation at a time with a strategy P(t|T) and a refinement budget
//    per observation. A count budget (tokens) runs in synchronous mode
//    (Engine::processNow), as fast as the machine allows and bit for bit
//    reproducible; a time budget (T_R ms) runs through the threaded engine,
//    as it would on a robot.
//  * instantaneous perplexity of step t: the engine's, computed just before
//    step t+1 is added (ObservationResult::previous_perplexity); for the last
//    step, after its own budget, which is the same instant.
//  * final perplexity of step t: after the whole stream and its last budget.
//  * batch: paper Algorithm 1 over the whole stream (Model::refineAll) with
//    the same total refinement as the online run it is compared with, in
//    whole sweeps: sweeps = round(online tokens / words in the stream).
//  * every perplexity is Model::stepPerplexity (word left out of its own
//    counts, docs/design.md), so the three compare like with like; each is
//    also taken as the plug-in perplexity of the 2013 ROST code
//    (Model::stepPluginPerplexity: word kept, the cell's own topic mix) at
//    the same instant, so the paper's definition stands beside ours.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dataset.hpp"
#include "rost/engine.hpp"
#include "rost/strategy.hpp"

namespace rost::experiment {

// True when the strategy's formula uses eta / q.
bool usesEta(StrategyKind k) noexcept;
bool usesQ(StrategyKind k) noexcept;
// The eight strategies in the order of the paper's tables.
const std::vector<StrategyKind>& paperOrder();

struct OnlineResult {
    std::vector<double> instantaneous;  // per step
    std::vector<double> final_ppx;      // per step
    std::vector<double> instantaneous_plugin;  // per step, plug-in (Model::stepPluginPerplexity)
    std::vector<double> final_plugin;          // per step, plug-in
    std::vector<uint64_t> tokens;       // refined in each observation's budget
    uint64_t total_tokens = 0;          // all refinement of the run
    double seconds = 0.0;               // wall time of the run
    uint64_t overruns = 0;              // time budget: observations past their deadline
    int64_t max_overrun_ns = 0;
    uint64_t dropped = 0;               // observations lost to a full queue (must be 0)
};

struct BatchResult {
    std::vector<double> ppx;     // per step
    std::vector<double> plugin;  // per step, plug-in
    uint64_t tokens = 0;
    int sweeps = 0;
    double seconds = 0.0;
};

// Runs the stream online. Budget::Time runs threaded (start, pushWait every
// observation so none is dropped, stop(Drain)); the other kinds run in
// synchronous mode. Errors (rejected observation, words subsampled away,
// dropped observations) go to `status`.
// `thread` schedules the refiner thread of a time-budget run.
OnlineResult runOnline(const Dataset& d, const Config& model, const StrategyConfig& strategy, const Budget& budget,
                       Status& status, const ThreadSettings& thread = {});

// What `s` achieves on this system for a thread (tried on a short-lived
// thread): e.g. "SCHED_FIFO 80, CPU 1" or "default scheduler (...why...)".
std::string describeThreadSettings(const ThreadSettings& s);

// Batch Gibbs over the whole stream with `sweeps` sweeps.
BatchResult runBatch(const Dataset& d, const Config& model, int sweeps);
// The number of whole sweeps closest to `tokens` token refinements (at least 1).
int sweepsFor(uint64_t tokens, uint64_t words) noexcept;

// Mean over steps of a[t] / b[t], skipping steps where either is not finite
// (an empty step has no perplexity).
double meanRatio(const std::vector<double>& a, const std::vector<double>& b) noexcept;
double meanFinite(const std::vector<double>& a) noexcept;

// exp of the entropy of the topic totals n_k: the number of topics the model
// effectively uses (K when all are used equally, 1 when one holds every word).
double effectiveTopics(const Model& m) noexcept;

// ---- calibration: T_R (ms) -> tokens per observation ------------------------

// Costs are measured in CPU time of the refining thread, so the rate is what
// one core of this machine does even while other work shares the machine
// (wall-clock rates are reported alongside).
struct Calibration {
    double tokens_per_second = 0.0;  // marginal refinement rate on the engine's path (CPU time)
    double overhead_ms = 0.0;        // per observation besides refinement (ingest, perplexity, publish)
    double wall_tokens_per_second = 0.0;   // the same slope in wall-clock time
    double batch_tokens_per_second = 0.0;  // Model::refineAll on the same stream (CPU time), for reference
    // tokens per observation that fill `tr_ms` of the engine's time per observation
    [[nodiscard]] uint64_t tokensFor(double tr_ms) const noexcept;
};

// Measures the engine's cost per observation (Engine::processNow: ingest,
// refinement, perplexity, publication) at two count budgets on the first `frames`
// frames, `repeats` times, for each strategy; the rate is the slope, the
// overhead the intercept (medians over observations, then over repeats and
// strategies). `log` receives one line per measurement.
Calibration calibrate(const Dataset& d, const ModelParams& p, const std::vector<StrategyKind>& strategies,
                      int64_t frames, uint64_t budget_lo, uint64_t budget_hi, int repeats,
                      const std::function<void(const std::string&)>& log);

// Runs fn(i) for i in [0, n) on `jobs` threads (set-up code, not realtime).
void parallelFor(std::size_t n, int jobs, const std::function<void(std::size_t)>& fn);

} // namespace rost::experiment
