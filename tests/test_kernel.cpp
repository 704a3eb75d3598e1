#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "kernel.hpp"
#include "rost/model.hpp"

namespace {

// The SIMD path must reproduce the scalar reference bit for bit: the same
// prefix sums (compared as bit patterns) and the same selected topic, for
// many random count states, K values with and without padding, and u values
// including both ends of [0, total].
TEST(KernelSimdMatchesScalar, PrefixSumsAndSelectionBitIdentical) {
    rost::Rng r(1234);
    for (int K : {1, 3, 4, 16, 17, 32, 64, 100}) {
        const int Kp = rost::kernel::paddedK(K);
        std::vector<int32_t> row(Kp, 0), g(Kp, 0);
        std::vector<float> inv(Kp, 0.f);
        alignas(64) float a[1024], b[1024];
        for (int trial = 0; trial < 2000; ++trial) {
            for (int k = 0; k < K; ++k) {
                row[k] = static_cast<int32_t>(r.below(trial % 2 ? 50u : 100000u));
                g[k] = static_cast<int32_t>(r.below(200));
                inv[k] = rost::kernel::reciprocal(static_cast<int32_t>(r.below(1u << 22)), 2718.f);
            }
            const float ts = rost::kernel::weightsAndScanScalar(row.data(), inv.data(), g.data(), 0.1f, 0.5f, Kp, a);
            const float tv = rost::kernel::weightsAndScanSimd(row.data(), inv.data(), g.data(), 0.1f, 0.5f, Kp, b);
            ASSERT_EQ(std::memcmp(&ts, &tv, sizeof(float)), 0) << "K=" << K;
            ASSERT_EQ(std::memcmp(a, b, sizeof(float) * Kp), 0) << "K=" << K;
            for (float u : {0.f, ts * 0.5f, ts, ts * r.uniformFloat()}) {
                const int ks = rost::kernel::selectScalar(a, Kp, K, u);
                ASSERT_EQ(ks, rost::kernel::selectSimd(b, Kp, K, u)) << "K=" << K;
                ASSERT_GE(ks, 0);
                ASSERT_LT(ks, K);
            }
        }
    }
}

TEST(KernelSimdMatchesScalar, WholeModelRunsGiveIdenticalLabels) {
    for (int K : {16, 20, 32}) {
        rost::Config c;
        c.K = K;
        c.V = 300;
        c.frame_width = 128;
        c.frame_height = 128;
        c.cell_space = 32;
        c.ring_steps = 16;
        c.seed = 77;
        rost::Model simd(c), scalar(c);
        scalar.setKernelPath(rost::kernel::Path::Scalar);
        rost::Rng r(5);
        std::vector<uint32_t> w(200);
        std::vector<rost::Position> p(200);
        for (int f = 0; f < 10; ++f) {
            for (std::size_t i = 0; i < w.size(); ++i) {
                w[i] = r.below(static_cast<uint32_t>(c.V));
                p[i] = {static_cast<int32_t>(r.below(128)), static_cast<int32_t>(r.below(128))};
            }
            ASSERT_TRUE(simd.addObservation(w, p).ok());
            ASSERT_TRUE(scalar.addObservation(w, p).ok());
            simd.refineAll(2);
            scalar.refineAll(2);
        }
        std::vector<uint16_t> a(200), b(200);
        for (uint64_t f = 0; f < 10; ++f) {
            simd.observationSamples(f, a);
            scalar.observationSamples(f, b);
            ASSERT_EQ(a, b) << "K=" << K << " frame " << f;
        }
        EXPECT_EQ(simd.tokensRefined(), scalar.tokensRefined());
    }
}

} // namespace
