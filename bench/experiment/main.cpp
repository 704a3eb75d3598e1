// rost_experiment: the paper's section VII on cached word streams
// (bench/experiment/README.md).
//
//   rost_experiment calibrate --dataset DIR [--frames 60] [--tr-ms 40,160] [--out FILE]
//       measures the engine's refinement rate on this machine and converts
//       each T_R into a count budget (tokens per observation).
//   rost_experiment run --dataset DIR --budget 40=tokens:N [--budget 40=time] --seeds 10 --out DIR
//       online runs (every strategy x budget x seed) and their batch
//       references; writes TAG.runs.csv (one row per run), TAG.steps.csv
//       (one row per run and time step) and TAG.info.txt.
//   rost_experiment floor --dataset DIR --sweeps 400 --out DIR
//       the lowest instantaneous/batch ratio an online strategy can reach
//       (batch on each prefix against the full batch); writes NAME-floor.floor.csv.
//   rost_experiment modes --dataset DIR --budget 40=tokens:N --out DIR
//       the online run's final state against batch (perplexity, effective
//       number of topics, before and after more global sweeps).

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "cli.hpp"
#include "dataset.hpp"
#include "harness.hpp"

using namespace rost;
using namespace rost::experiment;

namespace {

using Clock = std::chrono::steady_clock;

std::string joinArgs(int argc, char** argv) {
    std::string s;
    for (int i = 0; i < argc; ++i) s += (i ? " " : "") + std::string(argv[i]);
    return s;
}

// ---- calibrate ---------------------------------------------------------------

struct CalibrateArgs {
    std::string dataset;
    int64_t frames = 60;
    std::string strategies = "now,uniform,uni+now";
    uint64_t lo = 50000, hi = 400000;
    int repeats = 3;
    std::string tr_ms = "40,160";
    std::string out;
};

int doCalibrate(const CalibrateArgs& a, const std::string& command) {
    const Dataset d = load(a.dataset, 0);
    const auto trs = parseDoubles(a.tr_ms, "--tr-ms");
    if (a.hi <= a.lo) fail("--hi must be larger than --lo");
    const auto t0 = Clock::now();
    const Calibration c = calibrate(d, modelParams(), parseStrategies(a.strategies), a.frames, a.lo, a.hi, a.repeats,
                                    [](const std::string& l) { std::fprintf(stderr, "%s\n", l.c_str()); });
    std::string text = "# rost_experiment calibrate: T_R -> tokens per observation on this machine\n";
    text += "command=" + command + "\n";
    text += "date=" + nowText() + "\n";
    text += "dataset=" + d.name + "\n";
    text += "frames=" + std::to_string(std::min<int64_t>(a.frames, d.steps())) + "\n";
    text += "words_per_frame=" + fmt(d.wordsPerFrame(), "%.1f") + "\n";
    text += "tokens_per_second=" + fmt(c.tokens_per_second, "%.0f") + "\n";
    text += "overhead_ms=" + fmt(c.overhead_ms, "%.4f") + "\n";
    text += "wall_tokens_per_second=" + fmt(c.wall_tokens_per_second, "%.0f") + "\n";
    text += "batch_tokens_per_second=" + fmt(c.batch_tokens_per_second, "%.0f") + "\n";
    text += "load_average=" + loadAverage() + "\n";
    for (double tr : trs) text += "tokens_" + fmt(tr, "%g") + "ms=" + std::to_string(c.tokensFor(tr)) + "\n";
    text += "seconds=" + fmt(std::chrono::duration<double>(Clock::now() - t0).count(), "%.1f") + "\n";
    std::fputs(text.c_str(), stdout);
    if (!a.out.empty())
        if (Status s = writeFileAtomic(a.out, text); !s.ok()) fail(s.message());
    return 0;
}

// ---- run ---------------------------------------------------------------------

struct RunArgs {
    std::string dataset;
    std::string tag;
    int64_t frames = 0;
    std::string strategies = "all";
    std::vector<std::string> budgets;
    int seeds = 3;
    uint64_t seed_base = 1;
    std::string eta = "0.5";
    std::string q = "0.1";
    int jobs = 2;
    std::string out;
    bool steps_csv = true;
    bool dry_run = false;
    bool realtime = false;
};

struct OnlineTask {
    StrategyConfig strategy;
    std::size_t budget = 0;  // index into budgets
    uint64_t seed = 0;
    OnlineResult result;
    int batch = -1;  // index into batches
};
struct BatchTask {
    uint64_t seed = 0;
    int sweeps = 0;
    BatchResult result;
};

// What a run does: its budgets, its online runs and their batch references.
struct RunPlan {
    std::vector<BudgetSpec> budgets;
    std::vector<OnlineTask> online;
    std::vector<BatchTask> batches;
    std::map<std::pair<uint64_t, int>, int> batchIndex;
    std::vector<std::size_t> counted, timed;  // online runs with count / time budgets

    // The batch reference with this seed and sweeps (shared by every run with
    // the same), added if new; its index into batches.
    int batchFor(uint64_t seed, int sweeps) {
        const auto key = std::make_pair(seed, sweeps);
        const auto it = batchIndex.find(key);
        if (it != batchIndex.end()) return it->second;
        batches.push_back(BatchTask{seed, sweeps, {}});
        return batchIndex[key] = static_cast<int>(batches.size() - 1);
    }
    const BudgetSpec& budgetOf(const OnlineTask& t) const { return budgets[t.budget]; }
};

// The online runs: every budget x strategy x eta x q x seed (eta and q only
// for the strategies that use them).
void planOnline(const RunArgs& a, RunPlan& p) {
    for (const auto& b : a.budgets) p.budgets.push_back(parseBudget(b));
    if (p.budgets.empty()) fail("run: give at least one --budget TR_MS=tokens:N or TR_MS=time");
    if (a.seeds < 1) fail("--seeds must be >= 1");
    const auto kinds = parseStrategies(a.strategies);
    const auto etas = parseDoubles(a.eta, "--eta");
    const auto qs = parseDoubles(a.q, "--q");
    for (std::size_t b = 0; b < p.budgets.size(); ++b)
        for (StrategyKind k : kinds)
            for (double eta : usesEta(k) ? etas : std::vector<double>{etas.front()})
                for (double q : usesQ(k) ? qs : std::vector<double>{qs.front()})
                    for (int s = 0; s < a.seeds; ++s) {
                        OnlineTask t;
                        t.strategy.kind = k;
                        t.strategy.eta = eta;
                        t.strategy.q = q;
                        if (Status st = t.strategy.validate(); !st.ok()) fail(st.message());
                        t.budget = b;
                        t.seed = a.seed_base + static_cast<uint64_t>(s);
                        p.online.push_back(t);
                    }
}

// The batch references of the count-budget runs (those of the time-budget
// runs follow their runs); returns the estimated core-seconds of refinement.
double planBatches(const Dataset& d, RunPlan& p) {
    double estimate = 0.0;
    for (auto& t : p.online) {
        const BudgetSpec& b = p.budgetOf(t);
        if (b.budget.kind == BudgetKind::Steps) fail("run: step budgets are not supported here; use tokens:N");
        // A run and its batch each cost about T x T_R of refinement.
        estimate += static_cast<double>(d.steps()) * b.tr_ms * 1e-3;
        const std::size_t before = p.batches.size();
        if (b.budget.kind == BudgetKind::Tokens)
            t.batch = p.batchFor(t.seed, sweepsFor(b.budget.count * static_cast<uint64_t>(d.steps()), d.words));
        if (p.batches.size() != before || b.budget.kind == BudgetKind::Time)
            estimate += static_cast<double>(d.steps()) * b.tr_ms * 1e-3;
    }
    for (std::size_t i = 0; i < p.online.size(); ++i)
        (p.budgetOf(p.online[i]).budget.kind == BudgetKind::Time ? p.timed : p.counted).push_back(i);
    return estimate;
}

// Progress of a run's tasks on stderr, from any thread: "[done/total
// elapsed] what (seconds)".
struct RunLog {
    const Clock::time_point t0 = Clock::now();
    std::mutex mutex;
    std::size_t done = 0;
    std::size_t total = 0;

    void progress(const std::string& what, double secs) {
        std::lock_guard<std::mutex> lock(mutex);
        ++done;
        const double el = std::chrono::duration<double>(Clock::now() - t0).count();
        std::fprintf(stderr, "[%zu/%zu %.0fs] %s (%.1fs)\n", done, total, el, what.c_str(), secs);
    }
    [[noreturn]] void fatal(const std::string& m) {
        std::lock_guard<std::mutex> lock(mutex);
        fail(m);
    }
};

// One batch reference.
void runBatchTask(const Dataset& d, const Config& base, BatchTask& bt, RunLog& log) {
    Config c = base;
    c.seed = bt.seed;
    bt.result = runBatch(d, c, bt.sweeps);
    log.progress("batch seed=" + std::to_string(bt.seed) + " sweeps=" + std::to_string(bt.sweeps), bt.result.seconds);
}

// One online run; `thread` schedules the refiner of a time-budget run.
void runOnlineTask(const Dataset& d, const Config& base, const BudgetSpec& b, OnlineTask& t, RunLog& log,
                   const ThreadSettings& thread = {}) {
    Config c = base;
    c.seed = t.seed;
    Status st;
    t.result = runOnline(d, c, t.strategy, b.budget, st, thread);
    if (!st.ok()) log.fatal(d.name + " " + toString(t.strategy.kind) + ": " + st.message());
    std::string what = std::string(toString(t.strategy.kind)) + " " + b.text + " seed=" + std::to_string(t.seed);
    if (b.budget.kind == BudgetKind::Time)
        what += " tokens/obs=" +
                fmt(static_cast<double>(t.result.total_tokens) / static_cast<double>(d.steps()), "%.0f");
    log.progress(what, t.result.seconds);
}

// Runs the plan: count-budget runs and their batches in parallel, then the
// time-budget runs one at a time through the threaded engine (each needs a
// core of its own for its deadlines to mean anything), then their batches
// (same total refinement as each run). Returns how the refiner thread of the
// time-budget runs was scheduled.
std::string execute(const Dataset& d, const Config& base, const RunArgs& a, RunPlan& p, RunLog& log) {
    const std::size_t nb = p.batches.size();
    parallelFor(nb + p.counted.size(), a.jobs, [&](std::size_t i) {
        if (i < nb) {
            runBatchTask(d, base, p.batches[i], log);
        } else {
            OnlineTask& t = p.online[p.counted[i - nb]];
            runOnlineTask(d, base, p.budgetOf(t), t, log);
        }
    });
    ThreadSettings thread;
    std::string sched = "default scheduler";
    if (a.realtime) {
        thread = ThreadSettings::onboard();
        thread.lock_memory = false;
    }
    if (!p.timed.empty()) {
        sched = describeThreadSettings(thread);
        std::fprintf(stderr, "time budgets: refiner thread %s\n", sched.c_str());
    }
    for (std::size_t i : p.timed) runOnlineTask(d, base, p.budgetOf(p.online[i]), p.online[i], log, thread);
    const std::size_t nb0 = p.batches.size();
    for (std::size_t i : p.timed)
        p.online[i].batch = p.batchFor(p.online[i].seed, sweepsFor(p.online[i].result.total_tokens, d.words));
    parallelFor(p.batches.size() - nb0, a.jobs, [&](std::size_t j) { runBatchTask(d, base, p.batches[nb0 + j], log); });
    return sched;
}

// The rows of the online run `t`: one of TAG.runs.csv (against its batch
// reference) and, with `withSteps`, one of TAG.steps.csv per time step.
void appendRunRows(const Dataset& d, const RunPlan& p, const OnlineTask& t, const std::string& sched, bool withSteps,
                   std::string& runs, std::string& steps) {
    const BudgetSpec& b = p.budgetOf(t);
    const BatchResult& br = p.batches[static_cast<std::size_t>(t.batch)].result;
    const OnlineResult& r = t.result;
    const std::string eta = usesEta(t.strategy.kind) ? fmt(t.strategy.eta) : "";
    const std::string q = usesQ(t.strategy.kind) ? fmt(t.strategy.q) : "";
    const char* kind = b.budget.kind == BudgetKind::Time ? "time" : "tokens";
    uint64_t tmin = UINT64_MAX, tmax = 0;
    for (uint64_t x : r.tokens) {
        tmin = std::min(tmin, x);
        tmax = std::max(tmax, x);
    }
    runs += d.name + "," + std::to_string(d.steps()) + "," + std::to_string(d.words) + "," +
            toString(t.strategy.kind) + "," + eta + "," + q + "," + fmt(b.tr_ms, "%g") + "," + kind + "," +
            (b.budget.kind == BudgetKind::Tokens ? std::to_string(b.budget.count) : "") + "," +
            std::to_string(t.seed) + "," + fmt(meanRatio(r.instantaneous, br.ppx)) + "," +
            fmt(meanRatio(r.final_ppx, br.ppx)) + "," + fmt(meanFinite(r.instantaneous)) + "," +
            fmt(meanFinite(r.final_ppx)) + "," + fmt(meanFinite(br.ppx)) + "," + std::to_string(r.total_tokens) +
            "," + fmt(static_cast<double>(r.total_tokens) / static_cast<double>(d.steps()), "%.0f") + "," +
            std::to_string(tmin) + "," + std::to_string(tmax) + "," + std::to_string(br.sweeps) + "," +
            std::to_string(br.tokens) + "," + fmt(r.seconds, "%.3f") + "," + fmt(br.seconds, "%.3f") + "," +
            std::to_string(r.overruns) + "," + fmt(static_cast<double>(r.max_overrun_ns) * 1e-6, "%.3f") + "," +
            (b.budget.kind == BudgetKind::Time ? sched : std::string("synchronous")) + "," +
            fmt(meanRatio(r.instantaneous_plugin, br.plugin)) + "," + fmt(meanRatio(r.final_plugin, br.plugin)) +
            "," + fmt(meanFinite(r.instantaneous_plugin)) + "," + fmt(meanFinite(r.final_plugin)) + "," +
            fmt(meanFinite(br.plugin)) + "\n";
    if (!withSteps) return;
    for (std::size_t s = 0; s < r.final_ppx.size(); ++s)
        steps += d.name + "," + toString(t.strategy.kind) + "," + eta + "," + q + "," + fmt(b.tr_ms, "%g") + "," +
                 kind + "," + std::to_string(t.seed) + "," + std::to_string(s) + "," +
                 std::to_string(d.frames[s].words.size()) + "," + fmt(r.instantaneous[s]) + "," +
                 fmt(r.final_ppx[s]) + "," + fmt(br.ppx[s]) + "," + fmt(r.instantaneous_plugin[s]) + "," +
                 fmt(r.final_plugin[s]) + "," + fmt(br.plugin[s]) + "\n";
}

// Writes TAG.runs.csv, TAG.steps.csv (unless --no-steps) and TAG.info.txt.
void writeRunOutputs(const Dataset& d, const Config& base, const RunArgs& a, const RunPlan& p,
                     const std::string& tag, const std::string& sched, double seconds, const std::string& command) {
    std::string runs =
        "dataset,frames,words,strategy,eta,q,tr_ms,budget_kind,budget_tokens,seed,inst_ratio,final_ratio,inst_ppx,"
        "final_ppx,batch_ppx,online_tokens,tokens_per_obs_mean,tokens_per_obs_min,tokens_per_obs_max,batch_sweeps,"
        "batch_tokens,online_s,batch_s,overruns,max_overrun_ms,refiner,inst_ratio_plugin,final_ratio_plugin,"
        "inst_plugin,final_plugin,batch_plugin\n";
    std::string steps =
        "dataset,strategy,eta,q,tr_ms,budget_kind,seed,step,words,inst_ppx,final_ppx,batch_ppx,inst_plugin,"
        "final_plugin,batch_plugin\n";
    for (const auto& t : p.online) appendRunRows(d, p, t, sched, a.steps_csv, runs, steps);
    const std::string prefix = a.out + "/" + tag;
    if (Status s = writeFileAtomic(prefix + ".runs.csv", runs); !s.ok()) fail(s.message());
    if (a.steps_csv)
        if (Status s = writeFileAtomic(prefix + ".steps.csv", steps); !s.ok()) fail(s.message());
    std::string info = "command=" + command + "\n";
    info += "finished=" + nowText() + "\n";
    info += "dataset=" + d.name + "\nframes=" + std::to_string(d.steps()) + "\nwords=" + std::to_string(d.words) +
            "\nwords_per_frame=" + fmt(d.wordsPerFrame(), "%.1f") + "\n";
    info += "cell_capacity=" + std::to_string(base.cell_capacity) + "\nmax_words_per_frame=" +
            std::to_string(base.max_words_per_frame) + "\n";
    info += "online_runs=" + std::to_string(p.online.size()) + "\nbatch_runs=" + std::to_string(p.batches.size()) +
            "\n";
    if (!p.timed.empty()) info += "refiner_thread=" + sched + "\n";
    info += "jobs=" + std::to_string(a.jobs) + "\nseconds=" + fmt(seconds, "%.1f") + "\n";
    if (Status s = writeFileAtomic(prefix + ".info.txt", info); !s.ok()) fail(s.message());
    std::fprintf(stderr, "run %s: done in %.1f s; wrote %s.runs.csv%s\n", tag.c_str(), seconds, prefix.c_str(),
                 a.steps_csv ? " and .steps.csv" : "");
}

int doRun(const RunArgs& a, const std::string& command) {
    const Dataset d = load(a.dataset, a.frames);
    const std::string tag = a.tag.empty() ? d.name : a.tag;
    RunPlan p;
    planOnline(a, p);
    const ModelParams params = modelParams();
    const double estimate = planBatches(d, p);  // core-seconds of refinement the runs are budgeted
    std::fprintf(stderr,
                 "run %s: %lld frames, %.0f words/frame, %zu online runs, %zu batch runs (more for time budgets), "
                 "about %.0f core-seconds of refinement\n",
                 tag.c_str(), static_cast<long long>(d.steps()), d.wordsPerFrame(), p.online.size(), p.batches.size(),
                 estimate);
    if (a.dry_run) return 0;

    RunLog log;
    log.total = p.online.size() + p.batches.size();
    const Config base = modelConfig(d, params, 1);
    const std::string sched = execute(d, base, a, p, log);
    const double seconds = std::chrono::duration<double>(Clock::now() - log.t0).count();
    writeRunOutputs(d, base, a, p, tag, sched, seconds, command);
    return 0;
}

// ---- floor --------------------------------------------------------------------
// The best instantaneous perplexity any online strategy could reach: a model
// converged on the prefix 0..t of the stream (batch Gibbs on it, as many
// sweeps as the full batch reference), its perplexity of step t, against the
// full batch's perplexity of step t. What remains above 1 is the value of the
// data after t (the step t+1 in t's neighbourhood, a topic model trained on
// the whole stream), which no online strategy has one step after t.

struct FloorArgs {
    std::string dataset;
    std::string tag;
    int64_t frames = 0;
    int points = 10;
    int sweeps = 400;
    int seeds = 3;
    uint64_t seed_base = 1;
    int jobs = 2;
    std::string out;
};

int doFloor(const FloorArgs& a, const std::string& command) {
    const Dataset d = load(a.dataset, a.frames);
    const std::string tag = a.tag.empty() ? d.name + "-floor" : a.tag;
    const Config base = modelConfig(d, modelParams(), 1);
    std::vector<int64_t> points;
    for (int i = 1; i <= a.points; ++i) points.push_back(d.steps() * i / (a.points + 1));
    struct Task {
        uint64_t seed;
        int64_t t;  // -1: the full batch
        double ppx = 0.0;
        std::vector<double> full;
    };
    std::vector<Task> tasks;
    for (int s = 0; s < a.seeds; ++s) {
        tasks.push_back({a.seed_base + static_cast<uint64_t>(s), -1, 0.0, {}});
        for (int64_t t : points) tasks.push_back({a.seed_base + static_cast<uint64_t>(s), t, 0.0, {}});
    }
    const auto t0 = Clock::now();
    std::mutex logMutex;
    parallelFor(tasks.size(), a.jobs, [&](std::size_t i) {
        Task& k = tasks[i];
        Config c = base;
        c.seed = k.seed;
        Dataset prefix;
        const Dataset* use = &d;
        if (k.t >= 0) {
            prefix.width = d.width;
            prefix.height = d.height;
            prefix.V = d.V;
            prefix.frames.assign(d.frames.begin(), d.frames.begin() + k.t + 1);
            use = &prefix;
        }
        const BatchResult b = runBatch(*use, c, a.sweeps);
        if (k.t >= 0) k.ppx = b.ppx.back();
        else k.full = b.ppx;
        std::lock_guard<std::mutex> lock(logMutex);
        std::fprintf(stderr, "floor %s seed=%llu t=%lld (%.1fs)\n", d.name.c_str(),
                     static_cast<unsigned long long>(k.seed), static_cast<long long>(k.t), b.seconds);
    });
    std::string csv = "dataset,frames,seed,step,sweeps,prefix_ppx,full_ppx,ratio\n";
    std::map<uint64_t, const std::vector<double>*> full;
    for (const auto& k : tasks)
        if (k.t < 0) full[k.seed] = &k.full;
    for (const auto& k : tasks) {
        if (k.t < 0) continue;
        const double f = (*full[k.seed])[static_cast<std::size_t>(k.t)];
        csv += d.name + "," + std::to_string(d.steps()) + "," + std::to_string(k.seed) + "," + std::to_string(k.t) +
               "," + std::to_string(a.sweeps) + "," + fmt(k.ppx) + "," + fmt(f) + "," + fmt(k.ppx / f) + "\n";
    }
    if (Status s = writeFileAtomic(a.out + "/" + tag + ".floor.csv", csv); !s.ok()) fail(s.message());
    std::fprintf(stderr, "floor %s: done in %.1f s (%s)\n", d.name.c_str(),
                 std::chrono::duration<double>(Clock::now() - t0).count(), command.c_str());
    return 0;
}

// ---- modes --------------------------------------------------------------------
// Where an online run ends up against batch Gibbs: perplexity and effective
// number of topics of the online run's final state, then after more global
// sweeps of it (Engine::finalPass), against batch Gibbs with the same total
// refinement and with more. If extra sweeps do not close the gap, the online
// run sits in another mode of the posterior than the batch, not short of
// refinement.

struct ModesArgs {
    std::string dataset;
    std::string tag;
    int64_t frames = 0;
    std::string strategies = "uniform,uni+now";
    std::string budget;
    int seeds = 2;
    int extra = 2;  // extra global sweeps, in multiples of the batch reference's sweeps
    int jobs = 2;
    std::string out;
};

int doModes(const ModesArgs& a, const std::string& command) {
    const Dataset d = load(a.dataset, a.frames);
    const std::string tag = a.tag.empty() ? d.name + "-modes" : a.tag;
    const BudgetSpec b = parseBudget(a.budget);
    if (b.budget.kind != BudgetKind::Tokens) fail("modes: --budget must be TR_MS=tokens:N");
    const Config base = modelConfig(d, modelParams(), 1);
    const int sweeps = sweepsFor(b.budget.count * static_cast<uint64_t>(d.steps()), d.words);
    struct Task {
        StrategyKind kind;
        uint64_t seed;
        std::string line;
    };
    std::vector<Task> tasks;
    for (StrategyKind k : parseStrategies(a.strategies))
        for (int s = 1; s <= a.seeds; ++s) tasks.push_back({k, static_cast<uint64_t>(s), {}});
    std::mutex logMutex;
    const auto t0 = Clock::now();
    parallelFor(tasks.size(), a.jobs, [&](std::size_t i) {
        Task& k = tasks[i];
        Config c = base;
        c.seed = k.seed;
        EngineConfig ec;
        ec.model = c;
        ec.strategy.kind = k.kind;
        ec.budget = b.budget;
        ec.flags.snapshot_labels = false;
        ec.flags.snapshot_perplexity = false;
        Engine e(ec);
        for (const auto& f : d.frames) e.processNow(ObservationView{f.timestamp, f.words, f.positions});
        auto meanPpx = [](const Model& m) {
            std::vector<double> p(static_cast<std::size_t>(m.steps()));
            for (int64_t t = 0; t < m.steps(); ++t) p[static_cast<std::size_t>(t)] = m.stepPerplexity(t);
            return meanFinite(p);
        };
        const double online = meanPpx(e.model()), onlineTopics = effectiveTopics(e.model());
        e.finalPass(a.extra * sweeps);
        const double after = meanPpx(e.model()), afterTopics = effectiveTopics(e.model());
        Model bm(c);
        for (const auto& f : d.frames) bm.addObservation(f.words, f.positions);
        bm.refineAll(sweeps);
        const double batch = meanPpx(bm), batchTopics = effectiveTopics(bm);
        bm.refineAll(a.extra * sweeps);
        const double batchMore = meanPpx(bm), batchMoreTopics = effectiveTopics(bm);
        k.line = d.name + "," + std::to_string(d.steps()) + "," + toString(k.kind) + "," + fmt(b.tr_ms, "%g") + "," +
                 std::to_string(b.budget.count) + "," + std::to_string(k.seed) + "," + std::to_string(sweeps) + "," +
                 std::to_string(a.extra * sweeps) + "," + fmt(online) + "," + fmt(onlineTopics, "%.3f") + "," +
                 fmt(after) + "," + fmt(afterTopics, "%.3f") + "," + fmt(batch) + "," + fmt(batchTopics, "%.3f") +
                 "," + fmt(batchMore) + "," + fmt(batchMoreTopics, "%.3f") + "\n";
        std::lock_guard<std::mutex> lock(logMutex);
        std::fprintf(stderr, "modes %s %s seed=%llu: online %.1f (%.2f topics), +%d sweeps %.1f (%.2f), batch %.1f "
                             "(%.2f), batch +%d %.1f (%.2f)\n",
                     d.name.c_str(), toString(k.kind), static_cast<unsigned long long>(k.seed), online, onlineTopics,
                     a.extra * sweeps, after, afterTopics, batch, batchTopics, a.extra * sweeps, batchMore,
                     batchMoreTopics);
    });
    std::string csv = "dataset,frames,strategy,tr_ms,budget_tokens,seed,batch_sweeps,extra_sweeps,online_ppx,"
                      "online_topics,online_extra_ppx,online_extra_topics,batch_ppx,batch_topics,batch_extra_ppx,"
                      "batch_extra_topics\n";
    for (const auto& k : tasks) csv += k.line;
    if (Status s = writeFileAtomic(a.out + "/" + tag + ".modes.csv", csv); !s.ok()) fail(s.message());
    std::fprintf(stderr, "modes %s: done in %.1f s (%s)\n", d.name.c_str(),
                 std::chrono::duration<double>(Clock::now() - t0).count(), command.c_str());
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"rost_experiment: the paper's section VII (strategies x budgets x seeds against batch Gibbs)"};
    app.require_subcommand(1);
    app.fallthrough();
    std::string configFile;
    std::vector<std::string> sets;
    app.add_option("--config", configFile, "settings file (rost config prints one); model parameters K, alpha, beta, "
                                           "cell.space, g.space, g.time are taken from it")
        ->type_name("FILE");
    app.add_option("--set", sets, "KEY=VALUE: one setting of the schema (e.g. --set K=32); repeat")->type_name("KEY=VALUE");

    CalibrateArgs ca;
    auto* cal = app.add_subcommand("calibrate", "measure tokens/s on this machine and convert T_R to count budgets");
    cal->add_option("--dataset", ca.dataset, "dataset directory (dataset.txt, words.csv, positions.csv)")->required();
    cal->add_option("--frames", ca.frames, "frames to calibrate on")->capture_default_str();
    cal->add_option("--strategies", ca.strategies, "strategies measured (rate: median over them)")->capture_default_str();
    cal->add_option("--lo", ca.lo, "smaller token budget")->capture_default_str();
    cal->add_option("--hi", ca.hi, "larger token budget")->capture_default_str();
    cal->add_option("--repeats", ca.repeats, "repetitions")->capture_default_str()->check(CLI::Range(1, 100));
    cal->add_option("--tr-ms", ca.tr_ms, "T_R values to convert (ms, comma-separated)")->capture_default_str();
    cal->add_option("--out", ca.out, "also write the result (key=value) to this file");

    RunArgs ra;
    auto* run = app.add_subcommand("run", "online runs against batch references");
    run->add_option("--dataset", ra.dataset, "dataset directory")->required();
    run->add_option("--tag", ra.tag, "output file prefix (default: the dataset's name)");
    run->add_option("--frames", ra.frames, "use the first N frames (0: all)")->capture_default_str();
    run->add_option("--strategies", ra.strategies, "all | mixed | comma-separated names (now,uniform,agep,exp,...)")
        ->capture_default_str();
    run->add_option("--budget", ra.budgets, "TR_MS=tokens:N (count budget) or TR_MS=time (threaded, timed); repeat")
        ->required();
    run->add_option("--seeds", ra.seeds, "random restarts (seeds seed-base .. seed-base+N-1)")->capture_default_str();
    run->add_option("--seed-base", ra.seed_base, "first seed")->capture_default_str();
    run->add_option("--eta", ra.eta, "eta values for the mixed strategies (comma-separated)")->capture_default_str();
    run->add_option("--q", ra.q, "q values for the exponential strategies (comma-separated)")->capture_default_str();
    run->add_option("--jobs", ra.jobs, "runs in parallel (count budgets)")->capture_default_str()->check(CLI::Range(1, 64));
    run->add_option("--out", ra.out, "output directory")->required();
    run->add_flag("!--no-steps", ra.steps_csv, "do not write the per-step CSV");
    run->add_flag("--dry-run", ra.dry_run, "print the plan and its estimated cost only");
    run->add_flag("--realtime", ra.realtime,
                  "time budgets: run the refiner thread SCHED_FIFO 80 pinned to the last CPU, as onboard "
                  "(ThreadSettings::onboard without mlockall); falls back, and says so, where not permitted");

    FloorArgs fa;
    auto* floor = app.add_subcommand("floor", "instantaneous-perplexity floor: batch on each prefix 0..t against the "
                                              "full batch, at sampled steps t");
    floor->add_option("--dataset", fa.dataset, "dataset directory")->required();
    floor->add_option("--tag", fa.tag, "output file prefix (default: NAME-floor)");
    floor->add_option("--frames", fa.frames, "use the first N frames (0: all)")->capture_default_str();
    floor->add_option("--points", fa.points, "steps t sampled evenly")->capture_default_str()->check(CLI::Range(1, 1000));
    floor->add_option("--sweeps", fa.sweeps, "batch sweeps (prefix and full)")->capture_default_str()->check(CLI::Range(1, 1000000));
    floor->add_option("--seeds", fa.seeds, "seeds")->capture_default_str()->check(CLI::Range(1, 1000));
    floor->add_option("--seed-base", fa.seed_base, "first seed")->capture_default_str();
    floor->add_option("--jobs", fa.jobs, "runs in parallel")->capture_default_str()->check(CLI::Range(1, 64));
    floor->add_option("--out", fa.out, "output directory")->required();

    ModesArgs ma;
    auto* modes = app.add_subcommand("modes", "online final state against batch: perplexity and effective topics, "
                                              "before and after more global sweeps");
    modes->add_option("--dataset", ma.dataset, "dataset directory")->required();
    modes->add_option("--tag", ma.tag, "output file prefix (default: NAME-modes)");
    modes->add_option("--frames", ma.frames, "use the first N frames (0: all)")->capture_default_str();
    modes->add_option("--strategies", ma.strategies, "strategies")->capture_default_str();
    modes->add_option("--budget", ma.budget, "TR_MS=tokens:N")->required();
    modes->add_option("--seeds", ma.seeds, "seeds 1..N")->capture_default_str()->check(CLI::Range(1, 1000));
    modes->add_option("--extra", ma.extra, "extra global sweeps, in multiples of the batch reference's")
        ->capture_default_str()
        ->check(CLI::Range(1, 100));
    modes->add_option("--jobs", ma.jobs, "runs in parallel")->capture_default_str()->check(CLI::Range(1, 64));
    modes->add_option("--out", ma.out, "output directory")->required();

    CLI11_PARSE(app, argc, argv);
    const std::string command = joinArgs(argc, argv);
    applySettings(configFile, sets);
    if (cal->parsed()) return doCalibrate(ca, command);
    if (floor->parsed()) return doFloor(fa, command);
    if (modes->parsed()) return doModes(ma, command);
    return doRun(ra, command);
}
