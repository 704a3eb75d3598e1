// summary.png at the end of `rost refine`: drawing the 1600 x 650 canvas and
// writing it as PNG, as the summary's thread does after the last
// observation (issue 32, item 1: the end of the command is serial). The
// rows are synthetic, the size of the diver stream's (351 observations,
// K = 16). glibc's mmap threshold is pinned, so every large buffer is fresh
// pages, as in a new process (its dynamic threshold would otherwise hand the
// freed canvas back, already faulted in).
//
//   build/bench/bench_summary --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>
#include <malloc.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "png_file.hpp"

namespace {

std::vector<rost::tool::FrameRow> diverSizedRows() {
    std::vector<rost::tool::FrameRow> rows(351);
    for (std::size_t i = 0; i < rows.size(); ++i) {
        auto& r = rows[i];
        const double t = static_cast<double>(i);
        r.timestamp = static_cast<int64_t>(i);
        r.surprise = 50.0 + 30.0 * std::sin(0.1 * t) + (i % 37 == 0 ? 200.0 : 0.0);
        r.instantaneous = 300.0 + 20.0 * std::cos(0.05 * t);
        r.final = 280.0 + 10.0 * std::sin(0.07 * t);
        r.topic_share.assign(16, 1.0f / 16.0f);
        r.topic_share[i % 16] += 0.2f;
    }
    return rows;
}

rost::tool::SummaryInput input(const std::vector<rost::tool::FrameRow>& rows) {
    rost::tool::SummaryInput in;
    in.title = "rost refine: words.csv";
    in.subtitle = "K = 16, V = 5436, uni+now, 40 refines per observation, 351 observations";
    in.K = 16;
    in.rows = rows;
    return in;
}

void BM_SummaryDraw(benchmark::State& state) {
    const auto rows = diverSizedRows();
    const auto in = input(rows);
    for (auto _ : state) {
        const rost::tool::Picture p = rost::tool::drawSummary(in);
        benchmark::DoNotOptimize(p.image.data);
    }
}
BENCHMARK(BM_SummaryDraw)->Unit(benchmark::kMillisecond);

void BM_SummaryDrawAndWrite(benchmark::State& state) {
    const auto rows = diverSizedRows();
    const auto in = input(rows);
    const std::string path = "/tmp/rost-bench-summary-" + std::to_string(::getpid()) + ".png";
    for (auto _ : state) {
        if (!rost::tool::writePng(path, rost::tool::drawSummary(in).image).ok()) state.SkipWithError("write failed");
    }
    std::remove(path.c_str());
}
BENCHMARK(BM_SummaryDrawAndWrite)->Unit(benchmark::kMillisecond);

} // namespace

int main(int argc, char** argv) {
    mallopt(M_MMAP_THRESHOLD, 1 << 20);  // fresh pages for every large buffer, as in a new process
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
