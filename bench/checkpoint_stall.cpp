// How long a periodic checkpoint stalls the refiner (CheckpointWriter::capture:
// a copy of the whole state into the preallocated file image), and how long
// the writer thread then takes off the refiner's path (checksums, write,
// fsync, rename), for three configurations with a full ring:
//   paper  K=16 V=5436 640x480, 64 px cells, ring 256, cell capacity 128, 4096 words/frame
//   board  K=16 V=5436 640x480, 64 px cells, ring 64, capacity 64, 2048 words/frame
//   soak   the bench_soak configuration
// and, for the paper configuration, the stall measured inside a running
// engine (time budget 40 ms, capture every 25th observation in the hook).
// Reports mean, median and worst of each. Usage: bench_checkpoint [DIR]
// (files are written to DIR, default /tmp).

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/random.hpp"

namespace {

struct Named {
    const char* name;
    rost::EngineConfig cfg;
    uint32_t words;  // per frame
};

rost::EngineConfig paper() {
    rost::EngineConfig e;  // Config's defaults are the paper's
    e.budget = rost::Budget::steps(1);
    return e;
}
rost::EngineConfig board() {
    rost::EngineConfig e = paper();
    e.model.ring_steps = 64;
    e.model.cell_capacity = 64;
    e.model.max_words_per_frame = 2048;
    return e;
}
rost::EngineConfig soak() {
    rost::EngineConfig e;
    rost::Config& c = e.model;
    c.K = 16;
    c.V = 1000;
    c.frame_width = 160;
    c.frame_height = 120;
    c.cell_space = 32;
    c.ring_steps = 64;
    c.cell_capacity = 16;
    c.max_words_per_frame = 128;
    e.budget = rost::Budget::steps(1);
    return e;
}

void frame(const rost::Config& c, rost::Rng& r, uint32_t n, std::vector<uint32_t>& w, std::vector<rost::Position>& p) {
    w.resize(n);
    p.resize(n);
    for (uint32_t i = 0; i < n; ++i) {
        w[i] = r.below(static_cast<uint32_t>(c.V));
        p[i] = {static_cast<int32_t>(r.below(static_cast<uint32_t>(c.frame_width))),
                static_cast<int32_t>(r.below(static_cast<uint32_t>(c.frame_height)))};
    }
}

// CPU time of the calling thread: the stall without the time other
// processes took the CPU away (the machine is shared).
double threadCpuMs() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) / 1e6;
}

struct Stat {
    double mean = 0, median = 0, worst = 0;
};
Stat stat(std::vector<double> v) {
    Stat s;
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    for (double x : v) s.mean += x;
    s.mean /= static_cast<double>(v.size());
    s.median = v[v.size() / 2];
    s.worst = v.back();
    return s;
}

} // namespace

int main(int argc, char** argv) {
    const std::string dir = argc > 1 ? argv[1] : "/tmp";
    const std::vector<Named> configs = {{"paper", paper(), 2000}, {"board", board(), 1500}, {"soak", soak(), 60}};
    std::printf("| configuration | state (file) MiB | capture wall ms: mean / median / worst | capture CPU ms: median / worst | "
                "set-up (create: full copy) ms | write (writer thread) ms: median / worst |\n|---|---|---|---|---|---|\n");
    for (const Named& n : configs) {
        rost::Engine e(n.cfg);
        rost::Rng r(1);
        std::vector<uint32_t> w;
        std::vector<rost::Position> p;
        for (int f = 0; f < n.cfg.model.ring_steps + 8; ++f) {  // a full ring
            frame(n.cfg.model, r, n.words, w, p);
            e.processNow({f, w, p});
        }
        rost::Status st;
        const auto s0 = std::chrono::steady_clock::now();
        auto writer = rost::CheckpointWriter::create(e, dir + "/rost_bench_" + n.name + ".ckpt", st);
        const double setup = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s0).count();
        if (!writer) {
            std::fprintf(stderr, "%s\n", st.message().c_str());
            return 1;
        }
        std::vector<double> cap, cpu, wr;
        for (int i = 0; i < 20; ++i) {
            // New observations between captures, so the state is not all in cache.
            for (int f = 0; f < 4; ++f) {
                frame(n.cfg.model, r, n.words, w, p);
                e.processNow({1000 + i * 4 + f, w, p});
            }
            const double c0 = threadCpuMs();
            writer->capture();
            const double c1 = threadCpuMs();
            if (!writer->flush().ok()) return 1;
            const auto s = writer->stats();
            cap.push_back(static_cast<double>(s.last_capture_ns) / 1e6);
            cpu.push_back(c1 - c0);
            wr.push_back(static_cast<double>(s.last_write_ns) / 1e6);
        }
        const Stat c = stat(cap), u = stat(cpu), x = stat(wr);
        std::printf("| %s | %.2f | %.2f / %.2f / %.2f | %.2f / %.2f | %.2f | %.1f / %.1f |\n", n.name,
                    static_cast<double>(writer->imageBytes()) / (1024.0 * 1024.0), c.mean, c.median, c.worst, u.median,
                    u.worst, setup, x.median, x.worst);
        writer.reset();
        std::remove((dir + "/rost_bench_" + n.name + ".ckpt").c_str());
    }

    // Inside a running engine: the paper configuration with a 40 ms time
    // budget, frames every 40 ms, a capture every 25th observation.
    rost::EngineConfig cfg = paper();
    cfg.budget = rost::Budget::time(40.0);
    rost::Engine e(cfg);
    rost::Status st;
    const std::string path = dir + "/rost_bench_running.ckpt";
    auto writer = rost::CheckpointWriter::create(e, path, st);
    if (!writer) return 1;
    std::vector<double> stalls;
    stalls.reserve(64);
    int64_t seen = 0;
    e.setObservationHook([&](const rost::ObservationResult& res, const rost::Model&) {
        if (writer->captureEvery(25, res)) {
            stalls.push_back(static_cast<double>(writer->stats().last_capture_ns) / 1e6);
            ++seen;
        }
    });
    if (!e.start().ok()) return 1;
    rost::Rng r(3);
    std::vector<uint32_t> w;
    std::vector<rost::Position> p;
    const int frames = 400;
    const auto t0 = std::chrono::steady_clock::now();
    for (int f = 0; f < frames; ++f) {
        frame(cfg.model, r, 2000, w, p);
        (void)e.tryPush({f, w, p});
        std::this_thread::sleep_until(t0 + std::chrono::milliseconds(40 * (f + 1)));
    }
    e.stop();
    (void)writer->flush();
    const auto s = writer->stats();
    const rost::EngineCounters k = e.counters();
    const Stat c = stat(stalls);
    std::printf("\nrunning engine (paper configuration, 40 ms time budget, 25 fps, capture every 25th observation):\n"
                "  captures %llu (skipped %llu, written %llu): stall mean %.2f / median %.2f / worst %.2f ms; "
                "writes worst %.1f ms\n  observations %llu ingested, %llu dropped, %llu deadline overruns (worst %.2f ms)\n",
                static_cast<unsigned long long>(s.captured), static_cast<unsigned long long>(s.skipped),
                static_cast<unsigned long long>(s.written), c.mean, c.median, c.worst,
                static_cast<double>(s.max_write_ns) / 1e6, static_cast<unsigned long long>(k.ingested),
                static_cast<unsigned long long>(k.dropped()), static_cast<unsigned long long>(k.overruns),
                static_cast<double>(k.max_overrun_ns) / 1e6);
    writer.reset();
    std::remove(path.c_str());
    return 0;
}
