// Soak: streams >= 1,000,000 synthetic observations (compressed time: the
// producer pushes as fast as the refiner takes them, count budget, small
// frames) through the engine's producer and refiner threads, and reports
//   - resident memory (/proc/self/statm) at every tenth of the run: flat
//     after warm-up, since nothing on the path allocates;
//   - the per-observation cost (take-up to publish, measured by the engine)
//     in each tenth: median and worst, first tenth against last (no drift);
//   - the count invariants at the end (Model::checkInvariants) and the
//     counters (nothing dropped, nothing rejected);
//   - the run time.
// Usage: bench_soak [observations=1000000] [--sync]
// Exit code 1 if the invariants fail, memory grows after warm-up by more
// than 1 MiB, or anything was lost.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include "rost/engine.hpp"
#include "rost/random.hpp"

namespace {

// Resident set size from /proc/self/statm, read without allocating (an
// allocating reader would itself grow the heap under AddressSanitizer, whose
// quarantine keeps freed blocks).
std::size_t residentBytes() {
    const int fd = ::open("/proc/self/statm", O_RDONLY);
    if (fd < 0) return 0;
    char buf[128];
    const ssize_t n = ::read(fd, buf, sizeof buf - 1);
    ::close(fd);
    if (n <= 0) return 0;
    buf[n] = 0;
    unsigned long long pages = 0, resident = 0;
    if (std::sscanf(buf, "%llu %llu", &pages, &resident) != 2) return 0;
    return static_cast<std::size_t>(resident) * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

double mib(std::size_t b) { return static_cast<double>(b) / (1024.0 * 1024.0); }

struct Chunk {
    std::size_t rss = 0;
    double median_us = 0, p99_us = 0, max_us = 0;
    double seconds = 0;
};

// The command line: [observations=1000000] [--sync]; at least 1000 observations.
struct SoakArgs {
    uint64_t total = 1000000;
    bool sync = false;
};

SoakArgs parseArgs(int argc, char** argv) {
    SoakArgs a;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--sync") == 0)
            a.sync = true;
        else
            a.total = std::strtoull(argv[i], nullptr, 10);
    }
    if (a.total < 1000) a.total = 1000;
    return a;
}

// The engine under soak: small frames, a short ring, a count budget.
rost::EngineConfig soakConfig() {
    rost::EngineConfig cfg;
    rost::Config& c = cfg.model;
    c.K = 16;
    c.V = 1000;
    c.frame_width = 160;
    c.frame_height = 120;
    c.cell_space = 32;  // 5 x 4 cells
    c.ring_steps = 64;
    c.cell_capacity = 16;
    c.max_words_per_frame = 128;
    c.seed = 2024;
    cfg.budget = rost::Budget::steps(2);
    cfg.queue_slots = 256;  // compressed time: the producer refills in bursts, few sleeps on either side
    cfg.drop = rost::DropPolicy::DropNewest;
    return cfg;
}

// A loop of distinct frames whose scene changes, streamed over and over.
constexpr uint32_t kWords = 60;
constexpr int kFrames = 256;

struct Frames {
    std::vector<std::vector<uint32_t>> words;
    std::vector<std::vector<rost::Position>> pos;
};

Frames makeFrames() {
    Frames fr{std::vector<std::vector<uint32_t>>(kFrames, std::vector<uint32_t>(kWords)),
              std::vector<std::vector<rost::Position>>(kFrames, std::vector<rost::Position>(kWords))};
    rost::Rng r(7);
    for (int f = 0; f < kFrames; ++f) {
        const uint32_t scene = static_cast<uint32_t>(f / 64);
        for (uint32_t j = 0; j < kWords; ++j) {
            fr.pos[f][j] = {static_cast<int32_t>(r.below(160)), static_cast<int32_t>(r.below(120))};
            const uint32_t region = (fr.pos[f][j].x < 80 ? 0u : 1u) + 2 * scene;
            fr.words[f][j] = r.below(10) == 0 ? r.below(1000) : (region * 100 + r.below(100)) % 1000;
        }
    }
    return fr;
}

// Streams `total` observations through the engine (threaded, or
// synchronously with `sync`), taking the resident memory and the time of
// each tenth into `chunks`; the run time in `seconds`. False if the engine
// does not start or a push fails.
bool stream(rost::Engine& engine, const Frames& fr, const SoakArgs& a, std::vector<Chunk>& chunks, double& seconds) {
    const uint64_t tenth = a.total / 10;
    const auto t0 = std::chrono::steady_clock::now();
    auto tChunk = t0;
    if (!a.sync && !engine.start().ok()) return false;
    for (uint64_t i = 0; i < a.total; ++i) {
        const int f = static_cast<int>(i % kFrames);
        const rost::ObservationView v{static_cast<int64_t>(i), fr.words[f], fr.pos[f]};
        if (a.sync) {
            engine.processNow(v);
        } else if (!engine.pushWait(v)) {
            std::fprintf(stderr, "soak: push failed at %llu\n", static_cast<unsigned long long>(i));
            return false;
        }
        if ((i + 1) % tenth == 0 && (i + 1) / tenth <= 10) {
            const auto now = std::chrono::steady_clock::now();
            Chunk& ch = chunks[(i + 1) / tenth - 1];
            ch.rss = residentBytes();
            ch.seconds = std::chrono::duration<double>(now - tChunk).count();
            tChunk = now;
        }
    }
    if (!a.sync) engine.stop(rost::Engine::StopMode::Drain);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return true;
}

// Median, p99 and worst per-observation cost of each tenth, from `cost` (ns).
void costPerTenth(const std::vector<int32_t>& cost, uint64_t tenth, std::vector<Chunk>& chunks) {
    for (int k = 0; k < 10; ++k) {
        std::vector<int32_t> part(cost.begin() + static_cast<std::ptrdiff_t>(k * tenth),
                                  cost.begin() + static_cast<std::ptrdiff_t>((k + 1) * tenth));
        std::sort(part.begin(), part.end());
        chunks[k].median_us = part[part.size() / 2] / 1e3;
        chunks[k].p99_us = part[part.size() * 99 / 100] / 1e3;
        chunks[k].max_us = part.back() / 1e3;
    }
}

// Prints the table of tenths, memory growth, cost drift, counters,
// invariants and run time; true if the soak passed (invariants hold, memory
// grew by at most 1 MiB after warm-up, nothing lost).
bool report(const rost::Engine& engine, const std::vector<Chunk>& chunks, uint64_t total, double seconds) {
    const uint64_t tenth = total / 10;
    std::string why;
    const bool invariants = engine.model().checkInvariants(&why);
    const rost::EngineCounters k = engine.counters();
    std::printf("\n| tenth | observations | RSS MiB | median us/obs | p99 us/obs | worst us/obs | obs/s |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < 10; ++i)
        std::printf("| %d | %llu | %.2f | %.2f | %.2f | %.1f | %.0f |\n", i + 1,
                    static_cast<unsigned long long>((i + 1) * tenth), mib(chunks[i].rss), chunks[i].median_us,
                    chunks[i].p99_us, chunks[i].max_us, static_cast<double>(tenth) / chunks[i].seconds);
    const long long growth = static_cast<long long>(chunks[9].rss) - static_cast<long long>(chunks[0].rss);
    std::printf("\nRSS after warm-up (first tenth) %.2f MiB, at the end %.2f MiB: growth %lld bytes\n", mib(chunks[0].rss),
                mib(chunks[9].rss), growth);
    std::printf("per-observation cost, median: first tenth %.2f us, last tenth %.2f us, ratio last/first %.3f\n",
                chunks[0].median_us, chunks[9].median_us, chunks[9].median_us / chunks[0].median_us);
    std::printf("counters: pushed %llu ingested %llu dropped %llu rejected %llu refinements %llu tokens %llu\n",
                static_cast<unsigned long long>(k.pushed), static_cast<unsigned long long>(k.ingested),
                static_cast<unsigned long long>(k.dropped()), static_cast<unsigned long long>(k.rejected),
                static_cast<unsigned long long>(k.refinements), static_cast<unsigned long long>(k.tokens));
    std::printf("invariants at the end: %s\n", invariants ? "hold" : why.c_str());
    std::printf("run time: %.1f s (%.0f observations/s)\n", seconds, static_cast<double>(total) / seconds);
    return invariants && growth <= (1 << 20) && k.ingested == total && k.dropped() == 0 && k.rejected == 0;
}

} // namespace

int main(int argc, char** argv) {
    const SoakArgs a = parseArgs(argc, argv);
    const rost::EngineConfig cfg = soakConfig();
    const rost::Config& c = cfg.model;

    // Every buffer the bench itself needs, before the run.
    std::vector<int32_t> cost(a.total, 0);  // ns per observation
    const Frames frames = makeFrames();

    rost::Engine engine(cfg);
    engine.setObservationHook([&cost](const rost::ObservationResult& res, const rost::Model&) {
        if (res.observation < cost.size()) cost[res.observation] = static_cast<int32_t>(std::min<int64_t>(res.elapsed_ns, INT32_MAX));
    });
    std::printf("soak: %llu observations, %s, K=%d V=%d %dx%d frames, %d cells, ring %d, %u words/frame, budget %llu refines\n",
                static_cast<unsigned long long>(a.total), a.sync ? "synchronous" : "producer + refiner threads", c.K,
                c.V, c.frame_width, c.frame_height, c.cellsPerStep(), c.ring_steps, kWords,
                static_cast<unsigned long long>(cfg.budget.count));
    std::printf("engine memory: %.2f MiB (fixed at construction)\n", mib(engine.memoryBytes()));

    std::vector<Chunk> chunks(10);
    double seconds = 0;
    if (!stream(engine, frames, a, chunks, seconds)) return 1;
    costPerTenth(cost, a.total / 10, chunks);
    return report(engine, chunks, a.total, seconds) ? 0 : 1;
}
