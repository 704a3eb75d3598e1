#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "counter_rng.hpp"
#include "kernel.hpp"
#include "kernel_pair.hpp"
#include "rost/model.hpp"

namespace {

// The register kernels (the scan order, K <= 32): the SIMD path must
// reproduce the scalar reference bit for bit, the same
// prefix sums (compared as bit patterns) and the same selected topic, for
// many random count states, K values with and without padding, and u values
// including both ends of [0, total].
TEST(KernelSimdMatchesScalar, PrefixSumsAndSelectionBitIdentical) {
    rost::Rng r(1234);
    for (int K : {1, 3, 4, 16, 17, 32}) {
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

// The lane kernels (K > 32): the SIMD path must reproduce the scalar reference bit for bit: the same
// running sums and lane bases (compared as bit patterns) and the same drawn
// topic, for many random count states, K values with and without padding
// (odd and even block counts: the two chains), and u values including both
// ends of [0, total]. Every drawn topic has a positive weight.
TEST(KernelSimdMatchesScalar, CanonicalSumsAndDrawBitIdentical) {
    using rost::kernel::Path;
    rost::Rng r(1234);
    for (int K : {1, 3, 4, 8, 16, 17, 32, 64, 100}) {
        const int Kp = rost::kernel::paddedK(K);
        const int nb = Kp / rost::kernel::kBlock;
        std::vector<int32_t> row(Kp, 0), g(Kp, 0);
        std::vector<float> inv(Kp, 0.f), h(Kp, 0.f);
        alignas(64) float a[1024], b[1024];
        float ba[8], bb[8];
        for (int trial = 0; trial < 2000; ++trial) {
            for (int k = 0; k < K; ++k) {
                row[k] = static_cast<int32_t>(r.below(trial % 2 ? 50u : 100000u));
                g[k] = static_cast<int32_t>(r.below(200));
                // Some topics closed (weight 0), as with growth.
                inv[k] = trial % 3 == 0 && r.below(4) == 0
                             ? 0.f
                             : rost::kernel::reciprocal(static_cast<int32_t>(r.below(1u << 22)), 2718.f);
            }
            rost::kernel::cellWeights(inv.data(), g.data(), 0.1f, Kp, h.data());
            const float ts = rost::kernel::laneSums<Path::Scalar>(row.data(), h.data(), 0.5f, nb, a, ba);
            const float tv = rost::kernel::laneSums<Path::Simd>(row.data(), h.data(), 0.5f, nb, b, bb);
            ASSERT_EQ(std::memcmp(&ts, &tv, sizeof(float)), 0) << "K=" << K;
            ASSERT_EQ(std::memcmp(a, b, sizeof(float) * Kp), 0) << "K=" << K;
            ASSERT_EQ(std::memcmp(ba, bb, sizeof ba), 0) << "K=" << K;
            if (!(ts > 0.f)) continue;
            for (float u : {0.f, ts * 0.5f, std::nextafter(ts, 0.f), ts, ts * r.uniformFloat()}) {
                const int ks = rost::kernel::laneSelect<Path::Scalar>(a, ba, nb, u);
                ASSERT_EQ(ks, (rost::kernel::laneSelect<Path::Simd>(b, bb, nb, u))) << "K=" << K;
                ASSERT_GE(ks, 0);
                ASSERT_LT(ks, K);
                ASSERT_GT(h[ks], 0.f) << "a topic of weight 0 was drawn, K=" << K << " u=" << u;
            }
        }
    }
}

// The draw is the canonical order's inverse CDF: with u at each running
// sum's exact boundary, the topic is the one whose interval holds u.
TEST(KernelCanonicalOrder, DrawFindsTheIntervalThatHoldsU) {
    using rost::kernel::Path;
    constexpr int K = 24, nb = K / rost::kernel::kBlock;
    std::vector<int32_t> row(K);
    std::vector<float> h(K);
    for (int k = 0; k < K; ++k) {
        row[k] = k % 5;
        h[k] = k % 7 == 3 ? 0.f : 0.25f * static_cast<float>(1 + k % 3);  // exact small binary fractions
    }
    alignas(64) float cum[K];
    float base[8];
    const float total = rost::kernel::laneSums<Path::Scalar>(row.data(), h.data(), 0.5f, nb, cum, base);
    // Walk the canonical order: lane v = 4 chain + j, blocks of that chain.
    double lo = 0;
    int drawn = 0;
    for (int v = 0; v < 8; ++v)
        for (int blk = v >> 2; blk < nb; blk += 2) {
            const int k = 4 * blk + (v & 3);
            const double w = (row[k] + 0.5) * h[k];
            if (w == 0) continue;
            for (const double f : {0.0, 0.5, 0.999}) {
                const float u = static_cast<float>(lo + f * w);
                EXPECT_EQ(rost::kernel::laneSelect<Path::Scalar>(cum, base, nb, u), k) << "u=" << u;
                EXPECT_EQ(rost::kernel::laneSelect<Path::Simd>(cum, base, nb, u), k) << "u=" << u;
            }
            lo += w;
            ++drawn;
        }
    EXPECT_EQ(lo, total) << "the sums of these exact fractions are exact";
    EXPECT_EQ(drawn, K - 3);
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

// Points t at the tables (K = Kp = KP, every topic active).
template <int KP>
void wireTables(rost::kernel::Tables& t, std::vector<int32_t>& nkv, std::vector<int32_t>& nk, std::vector<float>& inv,
                std::vector<float>& dec, std::vector<float>& inc, std::vector<float>& left) {
    t.nkv = nkv.data();
    t.nk = nk.data();
    t.inv = inv.data();
    t.dec = dec.data();
    t.inc = inc.data();
    t.left = left.data();
    t.K = t.Kp = t.active = t.hi = t.slot = KP;
}

// A round's frozen tables at known K over word-topic counts nkv (V words x
// KP topics): n_k from them, the reciprocals, and the worker's table of
// reciprocals with a word's own topic left out (alpha 0.1, beta 0.5).
template <int KP>
struct FrozenTables {
    std::vector<int32_t> nkv, nk;
    std::vector<float> inv, dec, inc, left;
    rost::kernel::Tables t;
    FrozenTables(std::vector<int32_t> counts, int V)
        : nkv(std::move(counts)), nk(KP, 0), inv(KP), dec(KP), inc(KP), left(KP * KP) {
        for (std::size_t i = 0; i < nkv.size(); ++i) nk[i % KP] += nkv[i];
        wireTables<KP>(t, nkv, nk, inv, dec, inc, left);
        t.alpha = 0.1f;
        t.beta = 0.5f;
        t.vbeta = static_cast<float>(V) * 0.5f;
        rost::kernel::refreshReciprocals(t);
        rost::kernel::fillLeft(t);
    }
    FrozenTables(const FrozenTables&) = delete;  // t points into the vectors
};

// Two cells of a round refined as a pair (src/core/kernel_pair.hpp) get
// exactly what refineCellFrozen gives each alone: labels, cell counts and
// neighbourhood sums, for cells of equal and unequal word counts (the
// longer one's last words after the interleaved part), at the interleaved
// K (16) and at K the pair runs one cell after the other (32), on both paths.
template <int KP, rost::kernel::Path P>
void pairCase(uint32_t nA, uint32_t nB, uint64_t seed) {
    constexpr int V = 97;
    rost::Rng r(seed);
    std::vector<int32_t> counts(static_cast<std::size_t>(V) * KP);
    for (auto& n : counts) n = static_cast<int32_t>(r.below(6)) + 1;
    const FrozenTables<KP> frozen(std::move(counts), V);
    const rost::kernel::Tables& t = frozen.t;
    struct Cell {
        std::vector<int32_t> g, nc;
        std::vector<uint32_t> words;
        std::vector<uint16_t> z, z0;
        std::vector<uint64_t> moves;
        uint32_t moved = 0;
    };
    auto make = [&](uint32_t n) {
        Cell c{std::vector<int32_t>(KP), std::vector<int32_t>(KP, 0), std::vector<uint32_t>(n),
               std::vector<uint16_t>(n), std::vector<uint16_t>(n), std::vector<uint64_t>(n), 0};
        for (uint32_t i = 0; i < n; ++i) {
            c.words[i] = r.below(V);
            c.z[i] = c.z0[i] = static_cast<uint16_t>(r.below(KP));
            ++c.nc[c.z[i]];
        }
        for (int k = 0; k < KP; ++k) c.g[k] = c.nc[k] + static_cast<int32_t>(r.below(20));
        return c;
    };
    const Cell a0 = make(nA), b0 = make(nB);
    Cell a1 = a0, b1 = b0, a2 = a0, b2 = b0, a3 = a0, b3 = b0;
    auto view = [](Cell& c) {
        return rost::kernel::FrozenCell{c.g.data(),  c.nc.data(), c.words.data(), c.z.data(), c.z0.data(),
                                        static_cast<uint32_t>(c.words.size()), c.moves.data()};
    };
    // A task's picks, in turn; the first with the kernels' first-pick form
    // (every word still at its round-start label), the others without.
    auto alone = [&](Cell& c, rost::detail::CounterRng& rng, bool first) {
        const auto n = static_cast<uint32_t>(c.words.size());
        c.moved = first ? rost::kernel::refineCellFrozen<KP, P, true>(t, c.g.data(), c.words.data(), c.z.data(),
                                                                      c.z0.data(), n, rng, c.moves.data())
                        : rost::kernel::refineCellFrozen<KP, P>(t, c.g.data(), c.words.data(), c.z.data(), c.z0.data(),
                                                                n, rng, c.moves.data());
    };
    for (uint64_t pick = 0; pick < 3; ++pick) {
        rost::detail::CounterRng ra(seed, 2 * pick), rb(seed, 2 * pick + 1);
        alone(a1, ra, pick == 0);
        alone(b1, rb, pick == 0);
        rost::detail::CounterRng ga(seed, 2 * pick), gb(seed, 2 * pick + 1);
        alone(a3, ga, false);  // the general form at the first pick too
        alone(b3, gb, false);
        rost::detail::CounterRng pa(seed, 2 * pick), pb(seed, 2 * pick + 1);
        const rost::kernel::PairMoves moved =
            pick == 0 ? rost::kernel::refineCellsFrozenPair<KP, P, true>(t, view(a2), pa, view(b2), pb)
                      : rost::kernel::refineCellsFrozenPair<KP, P>(t, view(a2), pa, view(b2), pb);
        a2.moved = moved.a;
        b2.moved = moved.b;
    }
    const char* path = P == rost::kernel::Path::Simd ? "simd" : "scalar";
    if (nA >= 9) {
        EXPECT_NE(a1.z, a0.z) << "the draws moved some labels";
    }
    EXPECT_TRUE(a3.z == a1.z && b3.z == b1.z && a3.g == a1.g && b3.g == b1.g && a3.moves == a1.moves)
        << "K " << KP << " " << path << ": the first-pick form gives what the general one gives";
    EXPECT_EQ(a2.z, a1.z) << "K " << KP << " " << path << " cell A, " << nA << " and " << nB << " words";
    EXPECT_EQ(b2.z, b1.z) << "K " << KP << " " << path << " cell B, " << nA << " and " << nB << " words";
    EXPECT_TRUE(a2.g == a1.g && b2.g == b1.g) << "K " << KP << " " << path << ": neighbourhood sums";
    // The kernels leave the cells' own counts to the task; the sums carry
    // every move, and the moves list (the last pick's) names each word that
    // left its round-start label, in order: word | from << 32 | to << 48.
    EXPECT_TRUE(a2.nc == a0.nc && b2.nc == b0.nc) << "K " << KP << " " << path << ": cell counts untouched";
    for (const auto* c : {&a0, &b0}) {
        const Cell& now = c == &a0 ? a2 : b2;
        const Cell& single = c == &a0 ? a1 : b1;
        std::vector<int32_t> change(KP, 0);
        std::vector<uint64_t> moves;
        for (std::size_t i = 0; i < now.z.size(); ++i) {
            ++change[now.z[i]];
            --change[c->z[i]];
            if (now.z[i] != c->z0[i])
                moves.push_back(now.words[i] | uint64_t{c->z0[i]} << 32 | uint64_t{now.z[i]} << 48);
        }
        for (int k = 0; k < KP; ++k)
            EXPECT_EQ(now.g[k] - c->g[k], change[k]) << "K " << KP << " " << path << ": sums follow the labels, topic " << k;
        ASSERT_EQ(now.moved, moves.size()) << "K " << KP << " " << path << ": moves listed";
        ASSERT_EQ(single.moved, moves.size()) << "K " << KP << " " << path << ": moves listed alone";
        EXPECT_TRUE(std::equal(moves.begin(), moves.end(), now.moves.begin())) << "K " << KP << " " << path;
        EXPECT_TRUE(std::equal(moves.begin(), moves.end(), single.moves.begin())) << "K " << KP << " " << path;
    }
}

// The frozen kernels' vector path draws what the scalar reference draws,
// word by word, at K = 16 and 32 (all of a word's lanes counted against u).
template <int KP>
void frozenPathsAgree(uint64_t seed) {
    constexpr int V = 61;
    rost::Rng r(seed);
    std::vector<int32_t> counts(static_cast<std::size_t>(V) * KP);
    // Skewed: a word's few topics hold most of its counts.
    for (auto& n : counts) n = static_cast<int32_t>(r.below(4) == 0 ? 20 + r.below(200) : r.below(3)) + 1;
    const FrozenTables<KP> frozen(std::move(counts), V);
    const rost::kernel::Tables& t = frozen.t;
    constexpr uint32_t n = 200;
    std::vector<uint32_t> words(n);
    std::vector<uint16_t> z(n), z0(n);
    std::vector<int32_t> g(KP, 0);
    for (uint32_t i = 0; i < n; ++i) {
        words[i] = r.below(V);
        z[i] = z0[i] = static_cast<uint16_t>(r.below(KP));
        ++g[z[i]];
    }
    auto zs = z, zv = z;
    auto gs = g, gv = g;
    std::vector<uint64_t> ms(n), mv(n);
    for (uint64_t pick = 0; pick < 5; ++pick) {
        rost::detail::CounterRng rs(seed, pick), rv(seed, pick);
        const uint32_t a = rost::kernel::refineCellFrozen<KP, rost::kernel::Path::Scalar>(t, gs.data(), words.data(), zs.data(),
                                                                            z0.data(), n, rs, ms.data());
        const uint32_t b = rost::kernel::refineCellFrozen<KP, rost::kernel::Path::Simd>(t, gv.data(), words.data(), zv.data(),
                                                                          z0.data(), n, rv, mv.data());
        ASSERT_EQ(zv, zs) << "K " << KP << ", pick " << pick;
        ASSERT_EQ(gv, gs) << "K " << KP << ", pick " << pick;
        ASSERT_EQ(b, a) << "K " << KP << ", pick " << pick;
    }
    EXPECT_NE(zs, z0) << "the draws moved some labels";
    EXPECT_GT(*std::max_element(zs.begin(), zs.end()), KP / 2) << "draws reach the upper lanes";
}

TEST(KernelPair, TheFrozenVectorPathDrawsWhatTheScalarReferenceDraws) {
    for (const uint64_t seed : {3u, 4u, 5u}) {
        frozenPathsAgree<16>(seed);
        frozenPathsAgree<32>(seed);
    }
}

TEST(KernelPair, TwoCellsOfARoundGetWhatEachGetsAlone) {
    using rost::kernel::Path;
    for (const auto& [nA, nB] : {std::pair{25u, 25u}, std::pair{40u, 9u}, std::pair{3u, 31u}, std::pair{1u, 1u}}) {
        pairCase<16, Path::Simd>(nA, nB, 11 + nA);
        pairCase<16, Path::Scalar>(nA, nB, 11 + nA);
        pairCase<32, Path::Simd>(nA, nB, 17 + nB);
    }
#if defined(ROST_KERNEL_SIMD)
    EXPECT_TRUE((rost::kernel::interleavesPairs<16, Path::Simd>())) << "K = 16 interleaves on a vector path";
#endif
}

} // namespace

namespace rost_kernel_rounding {

using rost::kernel::Path;

// A generator that always returns u01 (the kernels take any type with uniformFloat()).
struct FixedUniform {
    float u;
    float uniformFloat() noexcept { return u; }
};

// The least u01 in [0, 1) with u01 * scale in [lo, hi); 0 if none.
float uniformHitting(float lo, float hi, float scale) {
    float u01 = lo / scale;
    for (int i = 0; i < 64 && u01 < 1.f; ++i, u01 = std::nextafter(u01, 1.f)) {
        const float u = u01 * scale;
        if (u >= lo && u < hi) return u01;
    }
    return 0.f;
}

// Weights (1 + 2^-23, 2^-24, 1.5 * 2^-24, 0) in one block: the scan's sums
// are rounded in different orders, and the sum at the closed topic 3 ends one
// ulp above the sum at topic 2. A u between them must draw topic 2, not the
// closed topic, on both paths.
TEST(KernelScanRounding, TheLaneKernelsScanNeverDrawsAClosedTopic) {
    alignas(64) float h[8] = {1.f + 0x1p-23f, 0x1p-24f, 1.5f * 0x1p-24f, 0.f, 0.f, 0.f, 0.f, 0.f};
    alignas(64) int32_t row[8] = {};
    int32_t nk[8] = {5, 1, 1, 0, 0, 0, 0, 0};
    rost::kernel::Tables t;
    t.nk = nk;
    t.K = t.Kp = 8;
    t.grow = true;
    t.beta = 1.f;
    t.fresh = 1e-30f;
    rost::kernel::updateTopics(t);
    ASSERT_EQ(t.slot, 3);
    alignas(64) float cum[8];
    const float total = rost::kernel::scanSumsScalar<false>(row, -1, h, 1.f, 1, cum);
    ASSERT_LT(cum[2], cum[3]) << "the rounding this test is about";
    const float u01 = uniformHitting(cum[2], cum[3], total + t.fresh);
    ASSERT_GT(u01, 0.f);
    EXPECT_EQ((rost::kernel::drawTopic<rost::kernel::kGrow, Path::Scalar, false>(t, row, -1, h, 1, u01)), 2);
    EXPECT_EQ((rost::kernel::drawTopic<rost::kernel::kGrow, Path::Simd, false>(t, row, -1, h, 1, u01)), 2);
}

// The same rounding in the register kernels (growth, few open topics): topics
// 0-2 open with those weights, 3 closed (the slot), 4 holds the word. A u
// between the sums at 2 and 3 draws topic 2, and the open set stays right.
TEST(KernelScanRounding, TheRegisterKernelsNeverDrawAClosedTopic) {
    constexpr int K = 8;
    for (const Path path : {Path::Scalar, Path::Simd}) {
        std::vector<int32_t> nkv(K, 0), nk = {5, 1, 1, 0, 2, 0, 0, 0}, nG(K, 0), nc(K, 0);
        nkv[4] = nG[4] = nc[4] = 1;  // the word, at topic 4
        alignas(64) float inv[K], dec[K], inc[K];
        rost::kernel::Tables t;
        t.nkv = nkv.data();
        t.nk = nk.data();
        t.inv = inv;
        t.dec = dec;
        t.inc = inc;
        t.K = t.Kp = K;
        t.grow = true;
        t.alpha = t.beta = 1.f;
        t.vbeta = 1e6f;
        t.fresh = 1e-30f;
        rost::kernel::refreshReciprocals(t);
        rost::kernel::updateTopics(t);
        inv[0] = 1.f + 0x1p-23f;  // weights ((0 + 1) * inv_k) * (0 + 1) = inv_k
        inv[1] = 0x1p-24f;
        inv[2] = 1.5f * 0x1p-24f;
        // The weights after the word leaves topic 4, as the kernel forms them.
        std::vector<int32_t> rowAfter = nkv, nGAfter = nG;
        rowAfter[4] = nGAfter[4] = 0;
        std::vector<float> invAfter(inv, inv + K);
        invAfter[4] = dec[4];
        alignas(64) float cum[K];
        const float total =
            rost::kernel::weightsAndScanScalar(rowAfter.data(), invAfter.data(), nGAfter.data(), 1.f, 1.f, K, cum);
        ASSERT_LT(cum[2], cum[3]) << "the rounding this test is about";
        FixedUniform rng{uniformHitting(cum[2], cum[3], total + t.fresh)};
        ASSERT_GT(rng.u, 0.f);
        const uint32_t word = 0;
        uint16_t z = 4;
        if (path == Path::Simd)
            rost::kernel::refineCell<rost::kernel::kGrow, Path::Simd>(t, nG.data(), nc.data(), &word, &z, 1, rng);
        else
            rost::kernel::refineCell<rost::kernel::kGrow, Path::Scalar>(t, nG.data(), nc.data(), &word, &z, 1, rng);
        EXPECT_EQ(z, 2) << (path == Path::Simd ? "simd" : "scalar");
        EXPECT_EQ(nk[3], 0) << "the closed topic stays closed";
        EXPECT_EQ(t.slot, 3);
    }
}

// A cell's cumulative sums can fall by an ulp from one lane to the next: the
// scan adds (p1 + p2) + p0 for lane 2 and (p2 + p3) + (p0 + p1) for lane 3.
// With weights (1, 2^-24, 0.75 2^-24, 2^-27) in topics 0-3, 1 in topic 4 and
// 0 elsewhere, the sums are (1, 1, 1 + 2^-23, 1, 2, ...) and u = 1 (half the
// total, 2) is at or above lanes 0, 1 and 3: the drawn topic is 3, the number
// of lanes at or below u, on every path (not 2, the length of their prefix).
template <int KP, Path P>
int frozenDrawWithSumsThatFall() {
    std::vector<int32_t> nkv(KP, 0), nk(KP, 100);
    std::vector<float> inv(KP, 1.f), dec(KP, 1.f), inc(KP, 1.f), left(KP * KP);
    nkv[0] = nkv[1] = nkv[3] = nkv[4] = 1;
    nkv[2] = 3;
    nkv[KP - 1] = 1;  // the word's own topic: n - 1 = 0 there
    inv[1] = 0x1p-24f;
    inv[2] = 0x1p-26f;
    inv[3] = 0x1p-27f;
    rost::kernel::Tables t;
    wireTables<KP>(t, nkv, nk, inv, dec, inc, left);
    t.alpha = 0.f;
    t.beta = 0.f;
    t.vbeta = 1.f;
    rost::kernel::fillLeft(t);
    std::vector<int32_t> g(KP, 0);
    g[0] = g[1] = g[2] = g[3] = g[4] = 1;
    g[KP - 1] = 1;  // the word itself, which leaves its topic
    const uint32_t word = 0;
    uint16_t z = KP - 1, z0 = KP - 1;
    uint64_t move = 0;
    FixedUniform u{0.5f};
    rost::kernel::refineCellFrozen<KP, P>(t, g.data(), &word, &z, &z0, 1, u, &move);
    return z;
}

TEST(KernelScanRounding, TheFrozenKernelsCountEveryLaneAtOrBelowU) {
    EXPECT_EQ((frozenDrawWithSumsThatFall<16, Path::Scalar>()), 3);
    EXPECT_EQ((frozenDrawWithSumsThatFall<16, Path::Simd>()), 3);
    EXPECT_EQ((frozenDrawWithSumsThatFall<32, Path::Scalar>()), 3);
    EXPECT_EQ((frozenDrawWithSumsThatFall<32, Path::Simd>()), 3);
}

} // namespace rost_kernel_rounding
