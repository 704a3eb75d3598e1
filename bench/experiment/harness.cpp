#include "harness.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>
#include <time.h>

namespace rost::experiment {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
    if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
    const std::size_t m = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
    const double hi = v[m];
    if (v.size() % 2 == 1) return hi;
    return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m)));
}

int64_t threadCpuNs() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

ObservationView viewOf(const StreamObservation& f) noexcept {
    return ObservationView{f.timestamp, f.words, f.positions};
}

} // namespace

bool usesEta(StrategyKind k) noexcept {
    return k == StrategyKind::UniformNow || k == StrategyKind::AgeProportionalNow ||
           k == StrategyKind::UniformExponential || k == StrategyKind::AgeProportionalExponential;
}

bool usesQ(StrategyKind k) noexcept {
    return k == StrategyKind::Exponential || k == StrategyKind::UniformExponential ||
           k == StrategyKind::AgeProportionalExponential;
}

const std::vector<StrategyKind>& paperOrder() {
    static const std::vector<StrategyKind> order = {
        StrategyKind::Uniform,           StrategyKind::AgeProportional,    StrategyKind::Exponential,
        StrategyKind::Now,               StrategyKind::UniformNow,         StrategyKind::AgeProportionalNow,
        StrategyKind::UniformExponential, StrategyKind::AgeProportionalExponential,
    };
    return order;
}

OnlineResult runOnline(const Dataset& d, const Config& model, const StrategyConfig& strategy, const Budget& budget,
                       Status& status, const ThreadSettings& thread) {
    status = {};
    OnlineResult res;
    const auto T = static_cast<std::size_t>(d.steps());
    res.instantaneous.assign(T, std::numeric_limits<double>::quiet_NaN());
    res.final_ppx.assign(T, std::numeric_limits<double>::quiet_NaN());
    res.instantaneous_plugin.assign(T, std::numeric_limits<double>::quiet_NaN());
    res.final_plugin.assign(T, std::numeric_limits<double>::quiet_NaN());
    res.tokens.assign(T, 0);

    EngineConfig ec;
    ec.model = model;
    ec.strategy = strategy;
    ec.budget = budget;
    ec.queue_slots = budget.kind == BudgetKind::Time ? 8 : 2;
    ec.drop = DropPolicy::DropNewest;
    ec.flags.instantaneous_perplexity = true;
    ec.flags.snapshot_perplexity = false;  // not needed here; keeps the budget for refinement
    ec.flags.snapshot_labels = false;
    ec.flags.stop_on_arrival = false;
    ec.thread = thread;
    Engine engine(ec);

    // The hook runs on the refining thread; each observation writes its own slots.
    std::atomic<uint64_t> problems{0};
    std::atomic<uint64_t> firstProblem{std::numeric_limits<uint64_t>::max()};
    engine.setObservationHook([&](const ObservationResult& r, const Model&) {
        if (!r.add.ok() || r.add.dropped_cell != 0 || r.add.dropped_frame != 0) {
            problems.fetch_add(1, std::memory_order_relaxed);
            uint64_t expected = std::numeric_limits<uint64_t>::max();
            firstProblem.compare_exchange_strong(expected, r.observation, std::memory_order_relaxed);
            return;
        }
        if (r.previous_step >= 0 && static_cast<std::size_t>(r.previous_step) < T) {
            res.instantaneous[static_cast<std::size_t>(r.previous_step)] = r.previous_perplexity;
            res.instantaneous_plugin[static_cast<std::size_t>(r.previous_step)] = r.previous_plugin;
        }
        if (r.observation < T) res.tokens[r.observation] = r.tokens;
    });

    const auto t0 = Clock::now();
    if (budget.kind == BudgetKind::Time) {
        if (Status s = engine.start(); !s.ok()) {
            status = s;
            return res;
        }
        for (const auto& f : d.frames) {
            if (!engine.pushWait(viewOf(f))) {
                status = Status::error("engine stopped while the stream was pushed");
                break;
            }
        }
        engine.stop(Engine::StopMode::Drain);
    } else {
        for (const auto& f : d.frames) engine.processNow(viewOf(f));
    }
    res.seconds = secondsSince(t0);
    if (!status.ok()) return res;

    const Model& m = engine.model();
    const EngineCounters c = engine.counters();
    res.total_tokens = c.tokens;
    res.overruns = c.overruns;
    res.max_overrun_ns = c.max_overrun_ns;
    res.dropped = c.dropped();
    if (problems.load() != 0) {
        status = Status::error(std::to_string(problems.load()) + " observations rejected or subsampled, first #" +
                               std::to_string(firstProblem.load()));
        return res;
    }
    if (res.dropped != 0 || m.observations() != T) {
        status = Status::error("engine took up " + std::to_string(m.observations()) + " of " + std::to_string(T) +
                               " observations (" + std::to_string(res.dropped) + " dropped)");
        return res;
    }
    // The last step's instantaneous perplexity: one step after its arrival is
    // now, after its budget (no later observation exists).
    if (T > 0) {
        res.instantaneous[T - 1] = m.stepPerplexity(static_cast<int64_t>(T) - 1);
        res.instantaneous_plugin[T - 1] = m.stepPluginPerplexity(static_cast<int64_t>(T) - 1);
    }
    for (std::size_t t = 0; t < T; ++t) {
        res.final_ppx[t] = m.stepPerplexity(static_cast<int64_t>(t));
        res.final_plugin[t] = m.stepPluginPerplexity(static_cast<int64_t>(t));
    }
    return res;
}

std::string describeThreadSettings(const ThreadSettings& s) {
    ThreadSettingsReport report;
    std::thread([&] { report = applyToCurrentThread(s); }).join();
    std::string out;
    if (report.fifo) out = "SCHED_FIFO " + std::to_string(s.priority);
    else out = "default scheduler";
    if (report.pinned) out += " pinned to CPU " + std::to_string(s.cpu);
    if (!report.message.empty()) {
        std::string m = report.message;
        for (char& c : m)
            if (c == '\n' || c == ',') c = ';';
        out += " (" + m + ")";
    }
    return out;
}

int sweepsFor(uint64_t tokens, uint64_t words) noexcept {
    if (words == 0) return 1;
    const double s = std::round(static_cast<double>(tokens) / static_cast<double>(words));
    return static_cast<int>(std::clamp(s, 1.0, 1e9));
}

BatchResult runBatch(const Dataset& d, const Config& model, int sweeps) {
    BatchResult res;
    Model m(model);
    for (const auto& f : d.frames) m.addObservation(f.words, f.positions);
    const auto t0 = Clock::now();
    res.tokens = m.refineAll(sweeps);
    res.seconds = secondsSince(t0);
    res.sweeps = sweeps;
    res.ppx.resize(static_cast<std::size_t>(m.steps()));
    res.plugin.resize(static_cast<std::size_t>(m.steps()));
    for (int64_t t = 0; t < m.steps(); ++t) {
        res.ppx[static_cast<std::size_t>(t)] = m.stepPerplexity(t);
        res.plugin[static_cast<std::size_t>(t)] = m.stepPluginPerplexity(t);
    }
    return res;
}

double meanRatio(const std::vector<double>& a, const std::vector<double>& b) noexcept {
    double sum = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
        if (!std::isfinite(a[i]) || !std::isfinite(b[i]) || b[i] <= 0.0) continue;
        sum += a[i] / b[i];
        ++n;
    }
    return n ? sum / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
}

double meanFinite(const std::vector<double>& a) noexcept {
    double sum = 0.0;
    std::size_t n = 0;
    for (double x : a)
        if (std::isfinite(x)) {
            sum += x;
            ++n;
        }
    return n ? sum / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
}

double effectiveTopics(const Model& m) noexcept {
    double n = 0.0, h = 0.0;
    for (int k = 0; k < m.K(); ++k) n += m.topicCount(k);
    if (n <= 0.0) return 0.0;
    for (int k = 0; k < m.K(); ++k) {
        const double p = m.topicCount(k) / n;
        if (p > 0.0) h -= p * std::log(p);
    }
    return std::exp(h);
}

uint64_t Calibration::tokensFor(double tr_ms) const noexcept {
    const double t = std::max(0.0, tr_ms - overhead_ms) * 1e-3;
    return static_cast<uint64_t>(std::llround(tokens_per_second * t));
}

Calibration calibrate(const Dataset& full, const ModelParams& p, const std::vector<StrategyKind>& strategies,
                      int64_t frames, uint64_t budget_lo, uint64_t budget_hi, int repeats,
                      const std::function<void(const std::string&)>& log) {
    Dataset d;
    d.name = full.name;
    d.width = full.width;
    d.height = full.height;
    d.V = full.V;
    d.frames.assign(full.frames.begin(),
                    full.frames.begin() + std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(full.frames.size()),
                                                                   static_cast<std::ptrdiff_t>(frames)));
    for (const auto& f : d.frames) {
        d.words += f.words.size();
        d.max_words_frame = std::max<uint32_t>(d.max_words_frame, static_cast<uint32_t>(f.words.size()));
    }
    const Config cfg = modelConfig(d, p, 1);

    // Median cost per observation (ns) under a count budget: CPU time of the
    // calling thread (what the machine can do, even while others share it)
    // and wall time from the engine's take-up to publication.
    struct Cost {
        double cpu = 0.0, wall = 0.0;
    };
    auto cost = [&](StrategyKind k, uint64_t budget) {
        EngineConfig ec;
        ec.model = cfg;
        ec.strategy.kind = k;
        ec.budget = Budget::tokens(budget);
        ec.queue_slots = 2;
        ec.flags.snapshot_perplexity = false;
        ec.flags.snapshot_labels = false;
        Engine e(ec);
        std::vector<double> wall, cpu;
        wall.reserve(d.frames.size());
        cpu.reserve(d.frames.size());
        e.setObservationHook([&](const ObservationResult& r, const Model&) {
            wall.push_back(static_cast<double>(r.elapsed_ns));
        });
        for (const auto& f : d.frames) {
            const int64_t c0 = threadCpuNs();
            e.processNow(viewOf(f));
            cpu.push_back(static_cast<double>(threadCpuNs() - c0));
        }
        return Cost{median(cpu), median(wall)};
    };

    std::vector<double> rates, overheads, wallRates;
    for (int rep = 0; rep < repeats; ++rep) {
        for (StrategyKind k : strategies) {
            const Cost lo = cost(k, budget_lo), hi = cost(k, budget_hi);
            const double n = static_cast<double>(budget_hi - budget_lo);
            const double rate = n / (hi.cpu - lo.cpu) * 1e9;  // tokens/s
            const double over = (lo.cpu - static_cast<double>(budget_lo) / rate * 1e9) * 1e-6;  // ms
            const double wallRate = n / (hi.wall - lo.wall) * 1e9;
            rates.push_back(rate);
            overheads.push_back(over);
            wallRates.push_back(wallRate);
            char line[320];
            std::snprintf(line, sizeof line,
                          "calibrate repeat=%d strategy=%s cpu(%llu)=%.3f ms cpu(%llu)=%.3f ms rate=%.4g tokens/s "
                          "overhead=%.3f ms | wall %.3f / %.3f ms, rate %.4g tokens/s",
                          rep, toString(k), static_cast<unsigned long long>(budget_lo), lo.cpu * 1e-6,
                          static_cast<unsigned long long>(budget_hi), hi.cpu * 1e-6, rate, over, lo.wall * 1e-6,
                          hi.wall * 1e-6, wallRate);
            if (log) log(line);
        }
    }
    Calibration c;
    c.tokens_per_second = median(rates);
    c.overhead_ms = std::max(0.0, median(overheads));
    c.wall_tokens_per_second = median(wallRates);

    // Batch refinement rate on the same stream, for reference.
    std::vector<double> batch;
    for (int rep = 0; rep < std::max(1, repeats); ++rep) {
        Model m(cfg);
        for (const auto& f : d.frames) m.addObservation(f.words, f.positions);
        m.refineAll(2);
        const int64_t c0 = threadCpuNs();
        const uint64_t n = m.refineAll(8);
        batch.push_back(static_cast<double>(n) / (static_cast<double>(threadCpuNs() - c0) * 1e-9));
    }
    c.batch_tokens_per_second = median(batch);
    return c;
}

void parallelFor(std::size_t n, int jobs, const std::function<void(std::size_t)>& fn) {
    std::atomic<std::size_t> next{0};
    auto worker = [&] {
        for (;;) {
            const std::size_t i = next.fetch_add(1);
            if (i >= n) return;
            fn(i);
        }
    };
    const int extra = std::max(0, std::min<int>(jobs, static_cast<int>(n)) - 1);
    std::vector<std::thread> threads;
    threads.reserve(static_cast<std::size_t>(extra));
    for (int j = 0; j < extra; ++j) threads.emplace_back(worker);
    worker();
    for (auto& t : threads) t.join();
}

} // namespace rost::experiment
