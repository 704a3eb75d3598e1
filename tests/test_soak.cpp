// A short soak in the test suite (the long one is bench/soak.cpp): 50,000
// small observations through the engine with a count budget. Memory stays
// flat after warm-up and every count invariant holds at the end. No timing
// is asserted here.

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include "rost/engine.hpp"
#include "rost/random.hpp"

namespace rost {
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

TEST(Soak, FiftyThousandObservationsKeepMemoryFlatAndCountsConsistent) {
    EngineConfig cfg;
    cfg.model.K = 8;
    cfg.model.V = 300;
    cfg.model.frame_width = 128;
    cfg.model.frame_height = 96;
    cfg.model.cell_space = 32;  // 4 x 3 cells
    cfg.model.ring_steps = 32;
    cfg.model.cell_capacity = 16;
    cfg.model.max_words_per_frame = 64;
    cfg.budget = Budget::steps(1);
    Engine e(cfg);

    constexpr uint64_t kObservations = 50000;
    constexpr uint32_t kWords = 24;
    std::vector<uint32_t> words(kWords);
    std::vector<Position> pos(kWords);
    Rng r(77);
    std::size_t warm = 0, peak = 0;
    for (uint64_t i = 0; i < kObservations; ++i) {
        // A scene that changes every 5,000 observations, so topics move.
        const uint32_t scene = static_cast<uint32_t>(i / 5000) % 3;
        for (uint32_t j = 0; j < kWords; ++j) {
            pos[j] = {static_cast<int32_t>(r.below(128)), static_cast<int32_t>(r.below(96))};
            words[j] = (r.below(8) == 0 ? r.below(300) : (scene * 100 + (pos[j].x < 64 ? 0u : 50u) + r.below(50))) % 300;
        }
        const ObservationResult res = e.processNow({static_cast<int64_t>(i), words, pos});
        ASSERT_TRUE(res.add.ok()) << i;
        if (i == kObservations / 10) warm = residentBytes();
        if (i > kObservations / 10) peak = std::max(peak, i % 1000 == 0 ? residentBytes() : peak);
    }
    const std::size_t end = residentBytes();
    ASSERT_GT(warm, 0u);
    // Flat: nothing on the path allocates; allow a few pages of noise.
    EXPECT_LE(std::max(peak, end), warm + 256 * 1024) << "warm " << warm << " peak " << peak << " end " << end;
    std::string why;
    EXPECT_TRUE(e.model().checkInvariants(&why)) << why;
    const EngineCounters k = e.counters();
    EXPECT_EQ(k.ingested, kObservations);
    EXPECT_EQ(k.pushed, kObservations);
    EXPECT_EQ(k.refinements, kObservations);
    EXPECT_EQ(e.model().observations(), kObservations);
    EXPECT_EQ(e.model().steps(), static_cast<int64_t>(kObservations));
}

} // namespace
} // namespace rost
