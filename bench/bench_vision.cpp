// Speed of visual words: quantising ORB descriptors to the 5000-word default
// vocabulary (exact linear scan against the coarse-to-fine tree at several
// probe counts, with the tree's agreement with the exact word), ORB
// detection alone, and whole-frame extraction (ORB + quantisation +
// intensity and hue words), on real footage (diver.mov, fetched by
// scripts/fetch-footage.sh) when available, else on synthetic frames.
//
//   build/bench/bench_vision --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   build/bench/bench_vision --dump-descriptors FILE   (raw 32-byte descriptors, for quantize_count)
//
// CPU time is the figure to read on a shared machine (wall time includes
// waiting for the core). per_descriptor / per_frame are CPU seconds.
//
// Pinned to the last CPU; aggregates include the worst repetition ("max").

#include <benchmark/benchmark.h>
#include <sched.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "rost/random.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/words.hpp"

using namespace rost;
using namespace rost::vision;

namespace {

constexpr int kFrames = 12;  // frames of footage the descriptors come from (every 20th of the first 240)

struct Footage {
    std::vector<cv::Mat> frames;  // 640x480 BGR
    std::vector<Descriptor> descriptors;
    std::string source;
};

const Footage& footage() {
    static const Footage f = [] {
        Footage out;
        const std::string dir = std::getenv("ROST_DATA_DIR") ? std::getenv("ROST_DATA_DIR") : ROST_SOURCE_DIR "/data";
        const std::string diver = dir + "/pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov";
        if (!std::filesystem::exists(diver))
            std::system((std::string(ROST_SOURCE_DIR "/scripts/fetch-footage.sh --dir '") + dir +
                         "' pd-extendedview >/dev/null 2>&1")
                            .c_str());
        Status st;
        SourceOptions so;
        so.width = 640;
        so.height = 480;
        if (auto src = openFrameSource(diver, so, st)) {
            Frame fr;
            for (int i = 0; i < 20 * kFrames && src->read(fr) == ReadStatus::Ok; ++i)
                if (i % 20 == 0) out.frames.push_back(fr.image.clone());
            out.source = "diver.mov";
        } else {
            // Synthetic stand-in: noise with shapes (ORB still finds corners).
            Rng rng(7);
            for (int i = 0; i < kFrames; ++i) {
                cv::Mat m(480, 640, CV_8UC3);
                cv::randu(m, 0, 60);
                for (int k = 0; k < 80; ++k)
                    cv::circle(m, {static_cast<int>(rng.below(640)), static_cast<int>(rng.below(480))},
                               5 + static_cast<int>(rng.below(40)),
                               cv::Scalar(rng.below(256), rng.below(256), rng.below(256)), -1);
                out.frames.push_back(m);
            }
            out.source = "synthetic frames (diver.mov not available)";
        }
        auto orb = cv::ORB::create(1000, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
        cv::Mat grey, desc;
        std::vector<cv::KeyPoint> kps;
        for (const auto& m : out.frames) {
            cv::cvtColor(m, grey, cv::COLOR_BGR2GRAY);
            orb->detectAndCompute(grey, cv::noArray(), kps, desc);
            for (int r = 0; r < desc.rows; ++r) out.descriptors.push_back(Descriptor::fromBytes(desc.ptr<uint8_t>(r)));
        }
        return out;
    }();
    return f;
}

std::shared_ptr<const Vocabulary> vocabulary() {
    Status st;
    auto v = defaultVocabulary(st);
    if (!v) {
        std::fprintf(stderr, "bench_vision: %s\n", st.message().c_str());
        std::exit(1);
    }
    return v;
}

void BM_QuantizeLinear(benchmark::State& state) {
    const auto v = vocabulary();
    const auto& d = footage().descriptors;
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(v->quantize(d[i], Search{SearchMethod::Linear, 0}));
        if (++i == d.size()) i = 0;
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["per_descriptor"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    state.counters["distances"] = v->size();
    state.SetLabel(footage().source);
}

void BM_QuantizeTree(benchmark::State& state) {
    const auto v = vocabulary();
    const auto& d = footage().descriptors;
    const Search s{SearchMethod::Tree, static_cast<uint32_t>(state.range(0))};
    std::size_t i = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(v->quantize(d[i], s));
        if (++i == d.size()) i = 0;
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["per_descriptor"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    // Quality and work, over all descriptors (outside the timed loop).
    uint64_t agree = 0, extra = 0, dist = 0;
    for (const auto& q : d) {
        int exact = 0, got = 0;
        const uint32_t a = v->quantize(q, exact, Search{SearchMethod::Linear, 0});
        const uint32_t b = v->quantize(q, got, s);
        agree += a == b;
        extra += static_cast<uint64_t>(got - exact);
        dist += v->distancesComputed(q, s);
    }
    state.counters["agree_exact"] = static_cast<double>(agree) / static_cast<double>(d.size());
    state.counters["extra_bits"] = static_cast<double>(extra) / static_cast<double>(d.size());
    state.counters["distances"] = static_cast<double>(dist) / static_cast<double>(d.size());
    state.SetLabel(footage().source);
}

void BM_OrbDetectAndDescribe(benchmark::State& state) {
    const auto& frames = footage().frames;
    auto orb = cv::ORB::create(1000, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
    cv::Mat grey, desc;
    std::vector<cv::KeyPoint> kps;
    std::size_t i = 0;
    for (auto _ : state) {
        cv::cvtColor(frames[i], grey, cv::COLOR_BGR2GRAY);
        orb->detectAndCompute(grey, cv::noArray(), kps, desc);
        benchmark::DoNotOptimize(desc.data);
        if (++i == frames.size()) i = 0;
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["per_frame"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_ExtractFrame(benchmark::State& state) {
    ExtractorConfig c;
    c.search.method = state.range(0) ? SearchMethod::Tree : SearchMethod::Linear;
    Status st;
    auto e = WordExtractor::create(c, vocabulary(), st);
    const auto& frames = footage().frames;
    FrameWords w;
    std::size_t i = 0;
    uint64_t words = 0;
    for (auto _ : state) {
        e->extract(frames[i], w);
        words += w.size();
        if (++i == frames.size()) i = 0;
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["per_frame"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    state.counters["words_per_frame"] = static_cast<double>(words) / static_cast<double>(state.iterations());
    state.SetLabel(c.search.method == SearchMethod::Tree ? "tree, 16 probes" : "linear");
}

void BM_TrainKMajority(benchmark::State& state) {
    // Training cost per iteration: 20k descriptors into 500 words, 5 iterations.
    const auto& all = footage().descriptors;
    std::vector<Descriptor> d(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(all.size(), 20000)));
    KMajorityOptions o;
    o.words = 500;
    o.max_iterations = 5;
    o.threads = 1;
    std::vector<Descriptor> c;
    for (auto _ : state) benchmark::DoNotOptimize(trainKMajority(d, o, c).ok());
    state.counters["descriptors"] = static_cast<double>(d.size());
}

double maxOf(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }

} // namespace

BENCHMARK(BM_QuantizeLinear)->ComputeStatistics("max", maxOf);
BENCHMARK(BM_QuantizeTree)->Arg(4)->Arg(8)->Arg(16)->Arg(32)->ComputeStatistics("max", maxOf);
BENCHMARK(BM_OrbDetectAndDescribe)->Unit(benchmark::kMillisecond)->ComputeStatistics("max", maxOf);
BENCHMARK(BM_ExtractFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->ComputeStatistics("max", maxOf);
BENCHMARK(BM_TrainKMajority)->Unit(benchmark::kMillisecond)->Iterations(3)->ComputeStatistics("max", maxOf);

int main(int argc, char** argv) {
    // One pinned core (the last), so the figures do not wander between CPUs.
    cpu_set_t set;
    CPU_ZERO(&set);
    const long n = sysconf(_SC_NPROCESSORS_ONLN);
    CPU_SET(static_cast<int>(n > 0 ? n - 1 : 0), &set);
    sched_setaffinity(0, sizeof set, &set);
    cv::setNumThreads(1);  // OpenCV's own threads would leave the pinned core
    if (argc == 3 && std::string(argv[1]) == "--dump-descriptors") {
        std::FILE* f = std::fopen(argv[2], "wb");
        if (!f) return 2;
        for (const auto& d : footage().descriptors) {
            uint8_t b[Descriptor::kBytes];
            d.toBytes(b);
            std::fwrite(b, 1, sizeof b, f);
        }
        std::fclose(f);
        std::printf("%zu descriptors from %s written to %s\n", footage().descriptors.size(), footage().source.c_str(), argv[2]);
        return 0;
    }
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    std::printf("descriptors: %zu from %s\n", footage().descriptors.size(), footage().source.c_str());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
