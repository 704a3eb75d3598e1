// Scaling of the realtime path (issue 6, bench/RESULTS.md "Scaling"): the
// cost of one observation through the engine (ingest, instantaneous
// perplexity, refinement under a count budget, perplexity, publication of
// labels and histograms: Engine::processNow, the same code the refiner
// thread runs) and the refinement rate, as
//
//   BM_TopicsK/K            the number of topics grows, 16 -> 128
//                           (2,000 words a frame, budget 20 tokens a word);
//   BM_WordsPerFrame/W      the words per frame grow, 500 -> 10,000
//                           (K = 16, budget 10 time steps: tokens grow with W);
//   BM_StreamLength/N/S     the stream grows, 1,000 -> 1,000,000 observations
//                           (K = 16, 500 words a frame, fixed 256-step window,
//                           2,000 tokens an observation; S: uni+now or uniform).
//                           The engine is advanced to N observations outside
//                           the timed loop, then the next observations are
//                           timed: the realtime path must not grow with N.
//
//   build/bench/bench_scaling --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// One pinned core, fixed seeds, synthetic frames with spatial structure
// (each region of the frame draws from its own group of words). Times are
// CPU time of the thread (the machine these run on is shared, and wall time
// there measures the neighbours); wall time is in the JSON as real_time, and
// worst_ms is the worst wall-clock cost of one observation.

#include <benchmark/benchmark.h>

#include <sched.h>

#include <map>
#include <memory>
#include <vector>

#include "rost/engine.hpp"

namespace {

constexpr int kV = 5436;
constexpr int kWidth = 640, kHeight = 480;
constexpr int kDistinctFrames = 32;  // cycled

struct Frames {
    std::vector<std::vector<uint32_t>> words;
    std::vector<std::vector<rost::Position>> pos;
    Frames(int perFrame, uint64_t seed) {
        rost::Rng r(seed);
        for (int f = 0; f < kDistinctFrames; ++f) {
            std::vector<uint32_t> w(static_cast<std::size_t>(perFrame));
            std::vector<rost::Position> p(w.size());
            for (std::size_t i = 0; i < w.size(); ++i) {
                p[i] = {static_cast<int32_t>(r.below(kWidth)), static_cast<int32_t>(r.below(kHeight))};
                // Regions of 160 px drifting with time, each with its own Zipf-like word group.
                const uint32_t region = static_cast<uint32_t>((p[i].x / 160 + p[i].y / 160 + f / 8) % 6);
                const uint32_t rank = r.below(r.below(900) + 1);
                w[i] = (region * 900 + rank) % kV;
            }
            words.push_back(std::move(w));
            pos.push_back(std::move(p));
        }
    }
    rost::ObservationView view(uint64_t i) const noexcept {
        const std::size_t f = i % kDistinctFrames;
        return rost::ObservationView{static_cast<int64_t>(i), words[f], pos[f]};
    }
};

const Frames& framesOf(int perFrame) {
    static std::map<int, std::unique_ptr<Frames>> cache;
    auto& f = cache[perFrame];
    if (!f) f = std::make_unique<Frames>(perFrame, 42);
    return *f;
}

rost::EngineConfig engineConfig(int K, int perFrame, int ring, rost::Budget budget, rost::StrategyKind kind) {
    rost::EngineConfig ec;
    ec.model.K = K;
    ec.model.V = kV;
    ec.model.frame_width = kWidth;
    ec.model.frame_height = kHeight;
    ec.model.ring_steps = ring;
    // Uniform positions: 80 cells; room for the busiest cell without subsampling.
    ec.model.cell_capacity = perFrame / 80 * 2 + 64;
    ec.model.max_words_per_frame = perFrame;
    ec.model.seed = 7;
    ec.strategy.kind = kind;
    ec.budget = budget;
    ec.queue_slots = 2;
    return ec;
}

// Times processNow() of observations `from` onwards; reports ns per
// observation (the benchmark's time) and the refinement rate.
void timeObservations(benchmark::State& state, rost::Engine& e, const Frames& frames, uint64_t from) {
    uint64_t i = from;
    const uint64_t tokens0 = e.counters().tokens;
    int64_t worst = 0;
    for (auto _ : state) {
        const rost::ObservationResult r = e.processNow(frames.view(i++));
        worst = std::max(worst, r.elapsed_ns);
    }
    const uint64_t tokens = e.counters().tokens - tokens0;
    state.SetItemsProcessed(static_cast<int64_t>(tokens));  // items/s = tokens refined per second
    state.counters["tokens_per_obs"] = static_cast<double>(tokens) / static_cast<double>(i - from);
    state.counters["worst_ms"] = static_cast<double>(worst) * 1e-6;
    state.counters["memory_MB"] = static_cast<double>(e.memoryBytes()) / (1024.0 * 1024.0);
}

void BM_TopicsK(benchmark::State& state) {
    const int K = static_cast<int>(state.range(0));
    constexpr int W = 2000;
    const Frames& f = framesOf(W);
    rost::Engine e(engineConfig(K, W, 64, rost::Budget::tokens(20 * W), rost::StrategyKind::UniformNow));
    for (uint64_t i = 0; i < 64; ++i) e.processNow(f.view(i));  // fill the window
    timeObservations(state, e, f, 64);
}

void BM_WordsPerFrame(benchmark::State& state) {
    const int W = static_cast<int>(state.range(0));
    const Frames& f = framesOf(W);
    rost::Engine e(engineConfig(16, W, 64, rost::Budget::steps(10), rost::StrategyKind::UniformNow));
    for (uint64_t i = 0; i < 64; ++i) e.processNow(f.view(i));
    timeObservations(state, e, f, 64);
}

// One engine per strategy, advanced monotonically across the arguments (and
// repetitions), so reaching 1,000,000 observations is paid once.
void BM_StreamLength(benchmark::State& state) {
    const auto N = static_cast<uint64_t>(state.range(0));
    const auto kind = state.range(1) == 0 ? rost::StrategyKind::UniformNow : rost::StrategyKind::Uniform;
    constexpr int W = 500;
    const Frames& f = framesOf(W);
    static std::map<int, std::unique_ptr<rost::Engine>> engines;
    auto& e = engines[static_cast<int>(kind)];
    if (!e) e = std::make_unique<rost::Engine>(engineConfig(16, W, 256, rost::Budget::tokens(2000), kind));
    uint64_t at = e->model().observations();
    while (at < N) e->processNow(f.view(at++));
    timeObservations(state, *e, f, at);
    state.counters["observations"] = static_cast<double>(e->model().observations());
    state.SetLabel(rost::toString(kind));
}

} // namespace

BENCHMARK(BM_TopicsK)->ArgName("K")->Arg(16)->Arg(32)->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WordsPerFrame)
    ->ArgName("words")
    ->Arg(500)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(5000)
    ->Arg(10000)
    
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StreamLength)
    ->ArgNames({"observations", "uniform"})
    ->ArgsProduct({{1000, 10000, 100000, 1000000}, {0, 1}})
    ->Iterations(2000)
    
    ->Unit(benchmark::kMicrosecond);

int main(int argc, char** argv) {
    // One pinned core, as the refiner thread runs.
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(0, &set);
    sched_setaffinity(0, sizeof(set), &set);
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
