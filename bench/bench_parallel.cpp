// Refinement on every core (issue 13, bench/RESULTS.md "Every core"): token
// updates per second of batch refinement (Model::refineAll, windows of W cell
// picks, rounds on `threads` threads) on a real word stream, against the
// number of threads and W. Wall-clock time (UseRealTime): the point of
// threads is the time a sweep takes, not its CPU time.
//
//   build/bench/bench_parallel WORDS.csv POSITIONS.csv --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
// (without arguments it reads $ROST_BENCH_WORDS and $ROST_BENCH_POSITIONS.)

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <cstdlib>
#include <string>

#include "rost/model.hpp"
#include "rost/word_stream.hpp"

namespace {

rost::WordStream g_stream;
int g_width = 0, g_height = 0, g_V = 0;

std::unique_ptr<rost::Model> loadedModel(int threads, int window) {
    rost::Config c;
    c.K = 16;
    c.V = g_V;
    c.frame_width = g_width;
    c.frame_height = g_height;
    c.ring_steps = static_cast<int>(g_stream.observations.size()) + 1;
    c.threads = threads;
    c.refine_window = window;
    auto m = std::make_unique<rost::Model>(c);
    for (const auto& o : g_stream.observations) (void)m->addObservation(o.words, o.positions);
    m->refineAll(2);  // past the random start
    return m;
}

void BM_RefineAll(benchmark::State& state) {
    const auto threads = static_cast<int>(state.range(0));
    const auto window = static_cast<int>(state.range(1));
    auto m = loadedModel(threads, window);
    uint64_t tokens = 0;
    for (auto _ : state) tokens += m->refineAll(1);
    state.SetItemsProcessed(static_cast<int64_t>(tokens));
    state.counters["threads"] = threads;
    state.counters["W"] = window;
}
BENCHMARK(BM_RefineAll)
    ->ArgNames({"threads", "W"})
    ->Args({1, 1})
    ->Args({1, 256})
    ->Args({2, 256})
    ->Args({1, 1024})
    ->Args({2, 1024})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

} // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    const char* w = argc > 1 ? argv[1] : std::getenv("ROST_BENCH_WORDS");
    const char* p = argc > 2 ? argv[2] : std::getenv("ROST_BENCH_POSITIONS");
    if (!w) {
        std::fprintf(stderr, "usage: bench_parallel WORDS.csv [POSITIONS.csv] [benchmark options]\n");
        return 2;
    }
    rost::WordStreamLimits limits;
    if (rost::Status st = rost::readWordStream(w, p ? p : "", limits, g_stream); !st.ok()) {
        std::fprintf(stderr, "bench_parallel: %s\n", st.message().c_str());
        return 2;
    }
    for (auto& o : g_stream.observations) {
        if (o.positions.size() != o.words.size()) o.positions.assign(o.words.size(), rost::Position{0, 0});
        for (const uint32_t v : o.words) g_V = std::max(g_V, static_cast<int>(v) + 1);
        for (const auto& q : o.positions) {
            g_width = std::max(g_width, q.x + 1);
            g_height = std::max(g_height, q.y + 1);
        }
    }
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
