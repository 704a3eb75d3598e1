// Refinement throughput of the Gibbs kernel, in token refinements per second
// on one pinned core, against a straightforward implementation of the same
// conditional (topic-major counts, std::discrete_distribution per word).
// items_per_second counts token refinements per CPU second of the benchmark
// thread, so time the thread spends descheduled on a shared machine does not
// count against it (contention for caches and the core's other hyperthread
// still does).
//
// BM_Refine/K:k/scalar:s refines one step at a time with the live kernel (the
// realtime refiner's Model::refineStep); BM_Refine/K:k/scalar:s/W:256 runs
// batch sweeps in windows of 256 picks (refine.window's default, what `rost
// refine` runs) with the frozen kernels, two cells at once at K = 13 to 16.
//
//   build/bench/bench_kernel --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <sched.h>
#include <vector>

#include "rost/model.hpp"

namespace {

constexpr int kV = 5436;
constexpr int kFrames = 24;
constexpr int kWordsPerFrame = 2000;  // 80 cells of 64 px in 640x480: 25 words a cell

// A word stream with some structure: each frame mixes a few Zipf-like word groups.
struct Stream {
    std::vector<std::vector<uint32_t>> words;
    std::vector<std::vector<rost::Position>> pos;
    explicit Stream(uint64_t seed) {
        rost::Rng r(seed);
        for (int f = 0; f < kFrames; ++f) {
            std::vector<uint32_t> w(kWordsPerFrame);
            std::vector<rost::Position> p(kWordsPerFrame);
            for (int i = 0; i < kWordsPerFrame; ++i) {
                p[i] = {static_cast<int32_t>(r.below(640)), static_cast<int32_t>(r.below(480))};
                const uint32_t region = static_cast<uint32_t>((p[i].x / 160 + p[i].y / 160 + f / 8) % 6);
                const uint32_t rank = r.below(r.below(900) + 1);
                w[i] = (region * 900 + rank) % kV;
            }
            words.push_back(std::move(w));
            pos.push_back(std::move(p));
        }
    }
};

rost::Config benchConfig(int K, int window = 1) {
    rost::Config c;
    c.K = K;
    c.refine_window = window;
    c.V = kV;
    c.ring_steps = kFrames;
    c.cell_capacity = 64;
    return c;
}

void BM_Refine(benchmark::State& state) {
    const int K = static_cast<int>(state.range(0));
    const bool scalar = state.range(1) != 0;
    static const Stream stream(42);
    rost::Model m(benchConfig(K));
    if (scalar) m.setKernelPath(rost::kernel::Path::Scalar);
    for (int f = 0; f < kFrames; ++f) m.addObservation(stream.words[f], stream.pos[f]);
    m.refineAll(5);  // past the random start
    const uint64_t before = m.tokensRefined();
    int64_t t = 0;
    for (auto _ : state) {
        m.refineStep(t);
        t = (t + 1) % kFrames;
    }
    state.SetItemsProcessed(static_cast<int64_t>(m.tokensRefined() - before));
    state.counters["words_per_cell"] = static_cast<double>(kWordsPerFrame) / m.cellsPerStep();
}

// Batch refinement in windows (refine.window W > 1, the default of `rost
// refine`): one sweep of the ring a benchmark iteration, in rounds of cells
// refined by the frozen kernels against n_k^v as it stood when the round began
// (include/rost/model.hpp, refine). One thread.
void BM_RefineWindows(benchmark::State& state) {
    const int K = static_cast<int>(state.range(0));
    const int window = static_cast<int>(state.range(2));
    static const Stream stream(42);
    rost::Model m(benchConfig(K, window));
    if (state.range(1) != 0) m.setKernelPath(rost::kernel::Path::Scalar);
    for (int f = 0; f < kFrames; ++f) m.addObservation(stream.words[f], stream.pos[f]);
    m.refineAll(5);  // past the random start
    const uint64_t before = m.tokensRefined();
    for (auto _ : state) m.refineAll(1);
    state.SetItemsProcessed(static_cast<int64_t>(m.tokensRefined() - before));
    state.counters["words_per_cell"] = static_cast<double>(kWordsPerFrame) / m.cellsPerStep();
}

// The straightforward kernel: topic-major n_k^v, neighbourhood summed per
// word, a std::discrete_distribution built for every word, std::mt19937.
class NaiveModel {
public:
    NaiveModel(int K, const Stream& s) : K_(K), nkv_(static_cast<std::size_t>(K) * kV, 0), nk_(K, 0) {
        std::mt19937 init(1);
        for (int f = 0; f < kFrames; ++f) {
            std::vector<Cell> cells(80);
            for (std::size_t i = 0; i < s.words[f].size(); ++i) {
                const int c = s.pos[f][i].y / 64 * 10 + s.pos[f][i].x / 64;
                const int z = static_cast<int>(init() % static_cast<unsigned>(K));
                cells[c].words.push_back(s.words[f][i]);
                cells[c].z.push_back(z);
                cells[c].nck.resize(K, 0);
                ++cells[c].nck[z];
                ++nkv_[static_cast<std::size_t>(z) * kV + s.words[f][i]];
                ++nk_[z];
            }
            for (auto& c : cells) c.nck.resize(K, 0);
            steps_.push_back(std::move(cells));
        }
    }
    uint64_t refineStep(int t) {
        uint64_t n = 0;
        for (int c = 0; c < 80; ++c) {
            Cell& cell = steps_[t][c];
            for (std::size_t i = 0; i < cell.words.size(); ++i) {
                const uint32_t v = cell.words[i];
                const int z = cell.z[i];
                --nkv_[static_cast<std::size_t>(z) * kV + v];
                --nk_[z];
                --cell.nck[z];
                std::vector<double> weights(K_);
                for (int k = 0; k < K_; ++k) {
                    int g = neighbourCount(t, c, k);
                    weights[k] = (nkv_[static_cast<std::size_t>(k) * kV + v] + 0.5) / (nk_[k] + kV * 0.5) * (g + 0.1);
                }
                std::discrete_distribution<int> d(weights.begin(), weights.end());
                const int k = d(rng_);
                ++nkv_[static_cast<std::size_t>(k) * kV + v];
                ++nk_[k];
                ++cell.nck[k];
                cell.z[i] = k;
                ++n;
            }
        }
        return n;
    }

private:
    struct Cell {
        std::vector<uint32_t> words;
        std::vector<int> z;
        std::vector<int> nck;
    };
    int neighbourCount(int t, int c, int k) const {
        const int cx = c % 10, cy = c / 10;
        int g = steps_[t][c].nck[k];
        if (cx > 0) g += steps_[t][c - 1].nck[k];
        if (cx < 9) g += steps_[t][c + 1].nck[k];
        if (cy > 0) g += steps_[t][c - 10].nck[k];
        if (cy < 7) g += steps_[t][c + 10].nck[k];
        if (t > 0) g += steps_[t - 1][c].nck[k];
        if (t + 1 < kFrames) g += steps_[t + 1][c].nck[k];
        return g;
    }
    int K_;
    std::vector<int> nkv_, nk_;
    std::vector<std::vector<Cell>> steps_;
    std::mt19937 rng_{7};
};

void BM_RefineNaive(benchmark::State& state) {
    const int K = static_cast<int>(state.range(0));
    static const Stream stream(42);
    NaiveModel m(K, stream);
    uint64_t tokens = 0;
    int t = 0;
    for (auto _ : state) {
        tokens += m.refineStep(t);
        t = (t + 1) % kFrames;
    }
    state.SetItemsProcessed(static_cast<int64_t>(tokens));
}

// The plain dense scalar loop, the yardstick for large K: per token, K
// products (n_wk + beta) * inv_k * (n_G^k + alpha) with inv_k = 1 / (n_k + V
// beta) cached and updated on change, a running sum, a linear search; int32
// counts, word-major n_k^v, the cell's neighbourhood sums kept per cell as the
// kernel keeps them. Same stream, cells and neighbourhood as BM_Refine.
class DenseModel {
public:
    DenseModel(int K, const Stream& s)
        : K_(K), nkv_(static_cast<std::size_t>(K) * kV, 0), nk_(K, 0), inv_(K), cum_(K), g_(K) {
        rost::Rng init(1);
        for (int f = 0; f < kFrames; ++f) {
            std::vector<Cell> cells(80);
            for (auto& c : cells) c.nck.assign(K, 0);
            for (std::size_t i = 0; i < s.words[f].size(); ++i) {
                const int c = s.pos[f][i].y / 64 * 10 + s.pos[f][i].x / 64;
                const int z = static_cast<int>(init.below(static_cast<uint32_t>(K)));
                cells[c].words.push_back(s.words[f][i]);
                cells[c].z.push_back(z);
                ++cells[c].nck[z];
                ++nkv_[static_cast<std::size_t>(s.words[f][i]) * K + z];
                ++nk_[z];
            }
            steps_.push_back(std::move(cells));
        }
        for (int k = 0; k < K; ++k) inv_[k] = 1.0f / (static_cast<float>(nk_[k]) + kV * 0.5f);
    }
    uint64_t refineStep(int t) {
        uint64_t n = 0;
        for (int c = 0; c < 80; ++c) {
            Cell& cell = steps_[t][c];
            neighbourhood(t, c);
            for (std::size_t i = 0; i < cell.words.size(); ++i) {
                int32_t* row = nkv_.data() + static_cast<std::size_t>(cell.words[i]) * K_;
                const int z = cell.z[i];
                --row[z];
                --nk_[z];
                --g_[z];
                --cell.nck[z];
                inv_[z] = 1.0f / (static_cast<float>(nk_[z]) + kV * 0.5f);
                float sum = 0.f;
                for (int k = 0; k < K_; ++k) {
                    sum += (static_cast<float>(row[k]) + 0.5f) * inv_[k] * (static_cast<float>(g_[k]) + 0.1f);
                    cum_[k] = sum;
                }
                const float u = rng_.uniformFloat() * sum;
                int k = 0;
                while (k < K_ - 1 && cum_[k] <= u) ++k;
                ++row[k];
                ++nk_[k];
                ++g_[k];
                ++cell.nck[k];
                inv_[k] = 1.0f / (static_cast<float>(nk_[k]) + kV * 0.5f);
                cell.z[i] = k;
                ++n;
            }
        }
        return n;
    }

private:
    struct Cell {
        std::vector<uint32_t> words;
        std::vector<int> z;
        std::vector<int32_t> nck;
    };
    void neighbourhood(int t, int c) {
        const int cx = c % 10, cy = c / 10;
        auto add = [&](const Cell& o) {
            for (int k = 0; k < K_; ++k) g_[k] += o.nck[k];
        };
        std::fill(g_.begin(), g_.end(), 0);
        add(steps_[t][c]);
        if (cx > 0) add(steps_[t][c - 1]);
        if (cx < 9) add(steps_[t][c + 1]);
        if (cy > 0) add(steps_[t][c - 10]);
        if (cy < 7) add(steps_[t][c + 10]);
        if (t > 0) add(steps_[t - 1][c]);
        if (t + 1 < kFrames) add(steps_[t + 1][c]);
    }
    int K_;
    std::vector<int32_t> nkv_, nk_;
    std::vector<float> inv_, cum_;
    std::vector<int32_t> g_;
    std::vector<std::vector<Cell>> steps_;
    rost::Rng rng_{7};
};

void BM_RefineDenseScalar(benchmark::State& state) {
    const int K = static_cast<int>(state.range(0));
    static const Stream stream(42);
    DenseModel m(K, stream);
    for (int s = 0; s < 5; ++s)
        for (int t = 0; t < kFrames; ++t) m.refineStep(t);  // past the random start, as BM_Refine
    uint64_t tokens = 0;
    int t = 0;
    for (auto _ : state) {
        tokens += m.refineStep(t);
        t = (t + 1) % kFrames;
    }
    state.SetItemsProcessed(static_cast<int64_t>(tokens));
}

// Growing topics under a cap of K: the cost follows the open topics
// (counter "open"), not the cap.
void BM_RefineGrow(benchmark::State& state) {
    const int K = static_cast<int>(state.range(0));
    static const Stream stream(42);
    rost::Config c = benchConfig(K);
    c.grow = true;
    c.gamma = std::pow(10.0, -static_cast<double>(state.range(1)));
    rost::Model m(c);
    for (int f = 0; f < kFrames; ++f) m.addObservation(stream.words[f], stream.pos[f]);
    m.refineAll(5);
    const uint64_t before = m.tokensRefined();
    int64_t t = 0;
    for (auto _ : state) {
        m.refineStep(t);
        t = (t + 1) % kFrames;
    }
    state.SetItemsProcessed(static_cast<int64_t>(m.tokensRefined() - before));
    state.counters["open"] = m.activeTopics();
}

} // namespace

BENCHMARK(BM_RefineDenseScalar)->ArgNames({"K"})->Arg(16)->Arg(64)->Arg(100);
BENCHMARK(BM_RefineGrow)->ArgNames({"K", "gamma10"})->ArgsProduct({{100}, {3, 4, 5}});
BENCHMARK(BM_Refine)->ArgNames({"K", "scalar"})->ArgsProduct({{8}, {0}});
BENCHMARK(BM_Refine)->ArgNames({"K", "scalar"})->ArgsProduct({{16, 32, 64, 100}, {0}});
BENCHMARK(BM_Refine)->ArgNames({"K", "scalar"})->ArgsProduct({{16, 64}, {1}});
BENCHMARK(BM_RefineWindows)->Name("BM_Refine")->ArgNames({"K", "scalar", "W"})->ArgsProduct({{16, 32, 64}, {0}, {256}});
BENCHMARK(BM_RefineNaive)->ArgNames({"K"})->Arg(16)->Arg(64);

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
