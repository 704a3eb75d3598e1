// Footprint of rost on a board (issue 5, bench/RESULTS.md "ARM footprint").
//
//   footprint memory
//       Bytes the model (and the engine, when built) allocates for the default
//       configuration and for the proposed small-board configuration, as
//       reported by Model::memoryBytes() / Engine::memory() and as measured by
//       the C library's allocator (mallinfo2) around construction.
//   footprint refine SWEEPS [--scalar] [--K N]
//       Builds a fixed stream (K = 16 or N, V = 5436, 640x480 frames, 64 px cells),
//       refines it twice to leave the random start, then runs SWEEPS more
//       batch sweeps and prints the tokens they refined. Instructions per token
//       refinement = (instructions(SWEEPS = n) - instructions(SWEEPS = 0)) /
//       tokens, counted with a qemu plugin (ARM) or callgrind (x86-64):
//       scripts/cross-footprint.sh.
//
// Runs natively or through qemu-user; output is plain text, one figure a line.

#include <malloc.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "aligned_buffer.hpp"
#include "rost/kernel_types.hpp"
#include "rost/model.hpp"
#if defined(ROST_FOOTPRINT_ENGINE)
#include "rost/engine.hpp"
#endif

namespace {

// The paper's setting: K = 16, V = 5436 (5000 ORB + 256 intensity + 180 hue
// words), 64 px cells on 640x480 frames; every other field at its default.
rost::Config defaultConfig() { return rost::Config{}; }

// Proposed for a small board (e.g. a Raspberry Pi Zero 2 W or a Cortex-A7
// with 512 MB shared with the camera stack): half-resolution frames with
// 32 px cells keep the paper's 10 x 8 cell grid; a 64-step window (a few
// seconds at the rates such a board sustains) and smaller per-cell and
// per-frame caps (about 1000 words a frame at 320x240) bound the ring.
rost::Config smallBoardConfig() {
    rost::Config c;
    c.frame_width = 320;
    c.frame_height = 240;
    c.cell_space = 32;
    c.ring_steps = 64;
    c.cell_capacity = 48;
    c.max_words_per_frame = 1024;
    return c;
}

std::size_t heapInUse() {
    const struct mallinfo2 mi = mallinfo2();
    // arena bytes in use + malloc's mmap'd blocks + the tables of 2 MiB and
    // more, which are mappings of their own (src/core/aligned_buffer.hpp)
    return mi.uordblks + mi.hblkhd + rost::mappedBytes();
}

double mib(std::size_t b) { return static_cast<double>(b) / (1024.0 * 1024.0); }

void printMemory(const char* name, const rost::Config& c) {
    const std::size_t before = heapInUse();
    std::size_t reported = 0, measured = 0;
    {
        rost::Model m(c);
        reported = m.memoryBytes();
        measured = heapInUse() - before;
    }
    std::printf("%-12s model   K=%d V=%d %dx%d cell=%dpx cells=%d ring=%d cap=%d maxw=%d: "
                "memoryBytes %zu (%.2f MiB), heap measured %zu (%.2f MiB)\n",
                name, c.K, c.V, c.frame_width, c.frame_height, c.cell_space, c.cellsPerStep(), c.ring_steps,
                c.cell_capacity, c.max_words_per_frame, reported, mib(reported), measured, mib(measured));
#if defined(ROST_FOOTPRINT_ENGINE)
    rost::EngineConfig ec;
    ec.model = c;
    const std::size_t before2 = heapInUse();
    {
        rost::Engine e(ec);
        const rost::EngineMemory em = e.memory();
        const std::size_t measured2 = heapInUse() - before2;
        std::printf("%-12s engine  queue_slots=%d: model %zu + queue %zu + snapshot %zu + other %zu = %zu "
                    "(%.2f MiB), heap measured %zu (%.2f MiB)\n",
                    name, ec.queue_slots, em.model, em.queue, em.snapshot, em.other, em.total(), mib(em.total()),
                    measured2, mib(measured2));
    }
#endif
}

// The refinement stream: 24 frames of 2000 words; six textures drifting
// through the frame, each with its own band of about 900 words.
constexpr int kFrames = 24;
constexpr int kWords = 2000;

int refine(int sweeps, bool scalar, int K) {
    rost::Config c = defaultConfig();
    c.K = K;
    c.ring_steps = kFrames;
    c.cell_capacity = 64;
    rost::Model m(c);
    if (scalar) m.setKernelPath(rost::kernel::Path::Scalar);
    rost::Rng r(42);
    std::vector<uint32_t> w(kWords);
    std::vector<rost::Position> p(kWords);
    for (int f = 0; f < kFrames; ++f) {
        for (int i = 0; i < kWords; ++i) {
            p[i] = {static_cast<int32_t>(r.below(640)), static_cast<int32_t>(r.below(480))};
            const auto texture = static_cast<uint32_t>((p[i].x / 160 + p[i].y / 160 + f / 8) % 6);
            w[i] = (texture * 900 + r.below(r.below(900) + 1)) % static_cast<uint32_t>(c.V);
        }
        if (!m.addObservation(w, p).ok()) {
            std::fprintf(stderr, "footprint: frame %d rejected\n", f);
            return 1;
        }
    }
    m.refineAll(2);
    const uint64_t before = m.tokensRefined();
    m.refineAll(sweeps);
    std::printf("refine kernel=%s K=%d sweeps=%d tokens=%llu\n",
                scalar ? "scalar" : rost::kernel::simdName(), c.K, sweeps,
                static_cast<unsigned long long>(m.tokensRefined() - before));
    return 0;
}

int usage() {
    std::fprintf(stderr, "usage: footprint memory | footprint refine SWEEPS [--scalar] [--K N]\n");
    return 2;
}

} // namespace

int main(int argc, char** argv) {
    if (argc >= 2 && std::strcmp(argv[1], "memory") == 0 && argc == 2) {
        std::printf("target kernel: %s, sizeof(void*) = %zu\n", rost::kernel::simdName(), sizeof(void*));
        printMemory("default", defaultConfig());
        printMemory("small-board", smallBoardConfig());
        return 0;
    }
    if (argc >= 3 && std::strcmp(argv[1], "refine") == 0) {
        char* end = nullptr;
        const long sweeps = std::strtol(argv[2], &end, 10);
        if (*end != '\0' || sweeps < 0 || sweeps > 1000) {
            std::fprintf(stderr, "footprint: SWEEPS must be an integer in [0, 1000], got '%s'\n", argv[2]);
            return 2;
        }
        bool scalar = false;
        long K = defaultConfig().K;
        for (int i = 3; i < argc; ++i) {
            if (std::strcmp(argv[i], "--scalar") == 0) {
                scalar = true;
            } else if (std::strcmp(argv[i], "--K") == 0 && i + 1 < argc) {
                K = std::strtol(argv[++i], &end, 10);
                if (*end != '\0' || K < 2 || K > 1024) {
                    std::fprintf(stderr, "footprint: --K must be an integer in [2, 1024], got '%s'\n", argv[i]);
                    return 2;
                }
            } else {
                return usage();
            }
        }
        return refine(static_cast<int>(sweeps), scalar, static_cast<int>(K));
    }
    return usage();
}
