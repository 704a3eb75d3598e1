// Refinement on every core (issue 13, bench/RESULTS.md "Every core"): token
// updates per second of batch refinement (Model::refineAll, windows of W cell
// picks, rounds on `threads` threads) on a real word stream, against the
// number of threads and W; and the rest of a command on 1 and 2 threads
// (reading, set-up, the final pass). Wall-clock time (UseRealTime): the
// point of threads is the time a sweep takes, not its CPU time.
//
//   build/bench/bench_parallel WORDS.csv POSITIONS.csv --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
// (without arguments it reads $ROST_BENCH_WORDS and $ROST_BENCH_POSITIONS.)

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <cstdlib>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <span>
#include <string>
#include <vector>

#include "rost/model.hpp"
#include "rost/word_stream.hpp"

namespace {

rost::WordStream g_stream;
int g_width = 0, g_height = 0, g_V = 0;

// K topics (16 unless given) over the stream's vocabulary and frame, a ring that holds it all.
rost::Config streamConfig(int threads, int window, int K = 16) {
    rost::Config c;
    c.K = K;
    c.V = g_V;
    c.frame_width = g_width;
    c.frame_height = g_height;
    c.ring_steps = static_cast<int>(g_stream.observations.size()) + 1;
    c.threads = threads;
    c.refine_window = window;
    return c;
}

std::unique_ptr<rost::Model> loadedModel(int threads, int window, int K = 16) {
    auto m = std::make_unique<rost::Model>(streamConfig(threads, window, K));
    for (const auto& o : g_stream.observations) (void)m->addObservation(o.words, o.positions);
    m->refineAll(2);  // past the random start
    return m;
}

void BM_RefineAll(benchmark::State& state) {
    const auto threads = static_cast<int>(state.range(0));
    const auto window = static_cast<int>(state.range(1));
    const auto K = static_cast<int>(state.range(2));
    auto m = loadedModel(threads, window, K);
    uint64_t tokens = 0;
    for (auto _ : state) tokens += m->refineAll(1);
    state.SetItemsProcessed(static_cast<int64_t>(tokens));
    state.counters["threads"] = threads;
    state.counters["W"] = window;
}
BENCHMARK(BM_RefineAll)
    ->ArgNames({"threads", "W", "K"})
    ->Args({1, 1, 16})
    ->Args({1, 256, 16})
    ->Args({2, 256, 16})
    ->Args({1, 1024, 16})
    ->Args({2, 1024, 16})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
// Scaling past two cores (issue 32, item 2; bench/RESULTS.md "Every core past
// eight threads"): 1 to 16 threads at K = 16, 32 and 64. On fewer cores than
// threads the workers take turns: select these with --benchmark_filter=Scaling
// on a machine with 16 cores.
BENCHMARK(BM_RefineAll)
    ->Name("BM_RefineAllScaling")
    ->ArgNames({"threads", "W", "K"})
    ->ArgsProduct({{1, 2, 4, 8, 16}, {256}, {16, 32, 64}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The rest of `rost refine` on `threads` threads (bench/RESULTS.md, "Every
// core: the rest of the command"): reading the word stream, constructing
// the model (its ring's tables zeroed, so faulted in), and the final pass's
// measurements, in one pool job (Model::finalMeasurements) or one
// observation at a time (stepPerplexity and observationLabels, as before).
std::string g_words, g_positions;

void BM_ReadWordStream(benchmark::State& state) {
    rost::WordStreamLimits limits;
    limits.threads = static_cast<int>(state.range(0));
    for (auto _ : state) {
        rost::WordStream ws;
        if (!rost::readWordStream(g_words, g_positions, limits, ws).ok()) state.SkipWithError("read failed");
        benchmark::DoNotOptimize(ws.observations.data());
    }
}
BENCHMARK(BM_ReadWordStream)->ArgNames({"threads"})->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// Each model's tables are fresh pages, as in a new process: tables of 2 MiB
// and more are mappings of their own, and glibc's mmap threshold is pinned
// (main), so the smaller large ones are mapped anew too and faulted in at
// set-up, not taken from memory the last model freed.
void BM_ModelSetUp(benchmark::State& state) {
    const rost::Config c = streamConfig(static_cast<int>(state.range(0)), 256);
    for (auto _ : state) {
        rost::Model m(c);
        benchmark::DoNotOptimize(&m);
    }
}
BENCHMARK(BM_ModelSetUp)->ArgNames({"threads"})->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ModelSetUp)
    ->Name("BM_ModelSetUpScaling")
    ->ArgNames({"threads"})
    ->Arg(4)
    ->Arg(8)
    ->Arg(16)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_FinalPass(benchmark::State& state) {
    const auto threads = static_cast<int>(state.range(0));
    const bool batch = state.range(1) != 0;
    auto m = loadedModel(threads, 256);
    const std::size_t n = static_cast<std::size_t>(m->observations()), stride = static_cast<std::size_t>(m->config().max_words_per_frame);
    std::vector<double> ppx(n);
    std::vector<uint16_t> labels(n * stride);
    for (auto _ : state) {
        if (batch) {
            m->finalMeasurements(0, ppx, labels, stride);
        } else {
            for (std::size_t f = 0; f < n; ++f) {
                ppx[f] = m->stepPerplexity(m->stepOfObservation(f));
                m->observationLabels(f, std::span<uint16_t>(labels).subspan(f * stride, std::min<std::size_t>(stride, m->observationSize(f))));
            }
        }
        benchmark::DoNotOptimize(ppx.data());
    }
}
BENCHMARK(BM_FinalPass)
    ->ArgNames({"threads", "batch"})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({2, 1})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FinalPass)
    ->Name("BM_FinalPassScaling")
    ->ArgNames({"threads", "batch"})
    ->Args({4, 1})
    ->Args({8, 1})
    ->Args({16, 1})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

} // namespace

int main(int argc, char** argv) {
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, 1 << 20);  // BM_ModelSetUp: large tables mapped anew each time
#endif
    benchmark::Initialize(&argc, argv);
    const char* w = argc > 1 ? argv[1] : std::getenv("ROST_BENCH_WORDS");
    const char* p = argc > 2 ? argv[2] : std::getenv("ROST_BENCH_POSITIONS");
    if (!w) {
        std::fprintf(stderr, "usage: bench_parallel WORDS.csv [POSITIONS.csv] [benchmark options]\n");
        return 2;
    }
    g_words = w;
    g_positions = p ? p : "";
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
