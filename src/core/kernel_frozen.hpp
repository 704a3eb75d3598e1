#pragma once

// The frozen kernels: a cell refined against word-topic counts that hold
// still for a round of a window (src/core/refine_tasks.cpp), with the same
// float operations in the same order as the live kernels of kernel.hpp.
// Internal to the library.

#include "kernel.hpp"

namespace rost::kernel {

// ---- the register kernels against frozen word-topic counts ----------------

// t.left from t.inv and t.dec, which hold still for a round.
inline void fillLeft(Tables& t) noexcept {
    const int Kp = t.Kp;
    for (int a = 0; a < Kp; ++a) {
        float* row = t.left + static_cast<std::size_t>(a) * static_cast<std::size_t>(Kp);
        for (int k = 0; k < Kp; ++k) row[k] = t.inv[k];
        row[a] = t.dec[a];
    }
}

// A frozen kernel's move of word v from its round-start topic a to k, as the
// round's merge reads it (ModelCore::takeMoves): written for every word
// without a branch, kept (the count m advanced) only when the word moved.
// A task's later pick of the same cell writes its list again from the start.
inline uint32_t logMove(uint64_t* moves, uint32_t m, uint32_t v, int a, int k) noexcept {
    moves[m] = v | uint64_t{static_cast<uint16_t>(a)} << 32 | uint64_t{static_cast<uint16_t>(k)} << 48;
    return m + (a != k ? 1u : 0u);
}

// As refineCell, except that n_k^v, n_k and the reciprocals are only read:
// during a round they hold every word at z0[i], its label when the round
// began, so word i leaves topic z0[i] there, and leaves its current topic in
// its neighbourhood sums nG, which the task owns and updates in place. The
// cell's own counts are not written: they change exactly as nG does, so the
// task sets them from nG once, at its end (ModelCore::closeFrozenTask). The
// new labels reach n_k^v and n_k when the round's changes are merged, from
// the moves the kernel lists (logMove); it returns their number.
// Same float operations, in the same order, as the live kernel.
template <int KP, typename R>
inline uint32_t refineCellFrozenScanScalar(const Tables& t, int32_t* nG, const uint32_t* words, uint16_t* topics,
                                           const uint16_t* z0, uint32_t n, R& rng, uint64_t* moves) noexcept {
    const int Kp = KP > 0 ? KP : t.Kp;
    alignas(64) float cum[KP > 0 ? KP : 1024];
    alignas(64) int32_t row[KP > 0 ? KP : 1024];
    alignas(64) float inv[KP > 0 ? KP : 1024];
    for (int k = 0; k < Kp; ++k) inv[k] = t.inv[k];
    uint32_t m = 0;
    for (uint32_t i = 0; i < n; ++i) {
        const int32_t* src = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(Kp);
        const int a = z0[i], z = topics[i];
        const int L = liveLanes<KP>(t, Kp);
        for (int k = 0; k < L; ++k) row[k] = src[k];
        --row[a];
        // (With growth, a word that was its topic's last leaves it closed.)
        inv[a] = KP == kGrow && t.nk[a] == 1 ? 0.f : t.dec[a];
        --nG[z];
        float total = weightsAndScanScalar(row, inv, nG, t.alpha, t.beta, L, cum);
        if constexpr (KP == kGrow) total += freshWeight<KP>(t);
        inv[a] = t.inv[a];
        const float u = rng.uniformFloat() * total;
        int count = 0;
        for (int j = 0; j < L; ++j) count += cum[j] <= u ? 1 : 0;
        // With growth, a word that opens a topic takes label `slot`: every
        // task of the round that opens one opens the same, merged after it.
        const int k = drawnTopic<KP>(t, count, a);
        ++nG[k];
        topics[i] = static_cast<uint16_t>(k);
        m = logMove(moves, m, words[i], a, k);
    }
    return m;
}

#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
// Topic masks from a table at known K: row k holds -1 in lane k and 0
// elsewhere, so a word's mask for one of its labels is one load a block (on
// aarch64 four blocks a load), with no broadcast of the label, no compares, and
// no lane numbers held in registers. 1 KiB at K = 16, 4 KiB at K = 32.
template <int KP>
struct LaneMasks {
    alignas(64) int32_t lane[KP][KP];
    constexpr LaneMasks() noexcept : lane{} {
        for (int k = 0; k < KP; ++k) lane[k][k] = -1;
    }
};
template <int KP>
inline constexpr LaneMasks<KP> kLaneMasks{};

// Block b of topic k's mask: from the table at known K, else by compare.
template <int KP>
ROST_KERNEL_INLINE v4::I topicMask(int k, int b) noexcept {
    if constexpr (KP > 0) {
        return v4::load(kLaneMasks<KP>.lane[k] + kBlock * b);
    } else {
        return v4::eq(v4::iota(kBlock * b), v4::seti(k));
    }
}

// Whether the frozen kernels at K = 16 load a word's rows (its counts, its
// labels' masks, its reciprocals) whole, four blocks an instruction: aarch64.
#if defined(ROST_V4_LOAD4)
inline constexpr bool kWholeRows = true;
#else
inline constexpr bool kWholeRows = false;
#endif
// NB blocks of a row into x (NB a multiple of 4 where kWholeRows).
template <int NB, typename T, typename V>
ROST_KERNEL_INLINE void loadRow(const T* p, V* x) noexcept {
#if defined(ROST_V4_LOAD4)
    static_assert(NB % 4 == 0);
    for (int q = 0; q < NB; q += 4) v4::load4(p + kBlock * q, x + q);
#else
    for (int b = 0; b < NB; ++b) x[b] = v4::load(p + kBlock * b);
#endif
}

// One word of refineCellFrozenScanSimd: word (row) leaves topic a of the frozen
// counts (reciprocal va) and topic z of the cell's sums g; returns the drawn
// topic, which g has joined, with the next draw of `draws`. iv: the frozen reciprocals.
// kByLabel: g joins the topic by its label (its mask, as for a and z)
// rather than by the count vector (a compare with the blocks' negated lane
// numbers: one step shorter, four more constants).
// iv: the frozen reciprocals, in registers (v4::F*) or read from t.inv (float*).
inline v4::F ivBlock(const v4::F* iv, int b) noexcept { return iv[b]; }
inline v4::F ivBlock(const float* iv, int b) noexcept { return v4::load(iv + kBlock * b); }
template <int KP, bool kByLabel = false, typename IV, typename R>
ROST_KERNEL_INLINE int frozenScanWord(const Tables& t, v4::I* g, IV iv, const int32_t* row, int a, int z,
                                      R& draws, v4::F va, int nbL, v4::F beta, v4::F alpha) noexcept {
    v4::F cum[KP > 0 ? KP / kBlock : kMaxBlocks];
    v4::F carry = v4::set(0.f);
    // (Whole rows at K = 16 only: at 32 the four rows are 32 registers beside
    // the sums and spill, 262.6 against 248.1 instructions a token under qemu.)
    constexpr bool kWhole = KP == 16 && kWholeRows;
    constexpr int kNB = kWhole ? KP / kBlock : 1;
    [[maybe_unused]] v4::I rowW[kNB], maW[kNB], mzW[kNB];
    [[maybe_unused]] v4::F leftW[kNB];
    if constexpr (kWhole) {
        loadRow<kNB>(row, rowW);
        loadRow<kNB>(kLaneMasks<KP>.lane[a], maW);
        loadRow<kNB>(kLaneMasks<KP>.lane[z], mzW);
        loadRow<kNB>(t.left + a * KP, leftW);
    }
    for (int b = 0; b < nbL; ++b) {
        const v4::I ma = kWhole ? maW[b] : topicMask<KP>(a, b);
        const v4::I r = v4::add(kWhole ? rowW[b] : v4::load(row + kBlock * b), ma);
        g[b] = v4::add(g[b], kWhole ? mzW[b] : topicMask<KP>(z, b));
        // At known K without growth the row of t.left (no select, no
        // reciprocals in registers); else the frozen ones with lane a's swapped.
        v4::F ivb;
        if constexpr (kWhole)
            ivb = leftW[b];
        else if constexpr (KP > 0)
            ivb = v4::load(t.left + a * KP + kBlock * b);
        else
            ivb = v4::select(ma, va, ivBlock(iv, b));
        const v4::F p = v4::scan(v4::mul(v4::mul(v4::add(v4::cvt(r), beta), ivb), v4::add(v4::cvt(g[b]), alpha)));
        if (b == 0) {
            cum[b] = p;
            carry = v4::last(p);
        } else {
            cum[b] = v4::add(p, carry);
            carry = v4::add(carry, v4::last(p));
        }
    }
    v4::F total = carry;
    if constexpr (KP == kGrow) total = v4::add(carry, v4::set(freshWeight<KP>(t)));
    // The word's draw taken here, where it is used: its float holds a vector
    // register only from here on (in a pair, beside the other cell's sums).
    const v4::F uu = v4::mul(v4::set(draws.uniformFloat()), total);
#if defined(ROST_V4_COUNT_SET)
    if constexpr (kByLabel && (KP == 16 || KP == 32)) {
        // The lanes <= uu counted from one movemask a 16 lanes (x86), not
        // summed across lanes: the same k.
        constexpr int kNb = KP / kBlock;
        v4::I le[kNb];
        for (int b = 0; b < kNb; ++b) le[b] = v4::le(cum[b], uu);
        const int k = v4::countSet<kNb>(le);
        for (int b = 0; b < kNb; ++b) g[b] = v4::sub(g[b], topicMask<KP>(k, b));
        return k;
    }
#endif
    v4::I count = v4::le(cum[0], uu);
    for (int b = 1; b < nbL; ++b) count = v4::add(count, v4::le(cum[b], uu));
    if constexpr (kByLabel) {
        int k = -v4::hsum(count);
        if constexpr (KP == kGrow) k = drawnTopic<KP>(t, k, a);
        [[maybe_unused]] v4::I mkW[kNB];
        if constexpr (kWhole) loadRow<kNB>(kLaneMasks<KP>.lane[k], mkW);
        for (int b = 0; b < nbL; ++b) g[b] = v4::sub(g[b], kWhole ? mkW[b] : topicMask<KP>(k, b));
        return k;
    } else {
        count = v4::hbroadcast(count);
        int k = -v4::firsti(count);
        if constexpr (KP == kGrow) {
            k = drawnTopic<KP>(t, k, a);
            count = v4::seti(-k);
        }
        for (int b = 0; b < nbL; ++b) g[b] = v4::sub(g[b], v4::eq(v4::niota(kBlock * b), count));
        return k;
    }
}

// The frozen reciprocal of topic a for a word that leaves it.
template <int KP>
ROST_KERNEL_INLINE v4::F frozenLeft(const Tables& t, int a) noexcept {
    return v4::set(KP == kGrow && t.nk[a] == 1 ? 0.f : t.dec[a]);
}

// kFirst: the task's first pick of the cell, when every word is still at its
// round-start label (z0 == topics): one label, one mask a word.
template <int KP, bool kFirst, typename R>
inline uint32_t refineCellFrozenScanSimd(const Tables& t, int32_t* nG, const uint32_t* words, uint16_t* topics,
                                         const uint16_t* z0, uint32_t n, R& rng, uint64_t* moves) noexcept {
    const int Kp = KP > 0 ? KP : t.Kp;
    const int nb = Kp / kBlock;
    constexpr int kArr = KP > 0 ? KP / kBlock : kMaxBlocks;
    v4::I g[kArr];
    v4::F iv[kArr];
    for (int b = 0; b < nb; ++b) {
        g[b] = v4::load(nG + kBlock * b);
        iv[b] = v4::load(t.inv + kBlock * b);
    }
    const v4::F beta = v4::set(t.beta), alpha = v4::set(t.alpha);
    R draws = rng;  // a local: the label and move stores could otherwise change it
    uint32_t m = 0;
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t v = words[i];
        const int32_t* row = t.nkv + static_cast<std::size_t>(v) * static_cast<std::size_t>(Kp);
        const int z = topics[i], a = kFirst ? z : z0[i];
        const int nbL = liveLanes<KP>(t, Kp) / kBlock;
        if (nbL < 1) __builtin_unreachable();  // at least one topic is active
        const int k = frozenScanWord<KP, (KP > 0)>(t, g, iv, row, a, z, draws, frozenLeft<KP>(t, a), nbL, beta, alpha);
        topics[i] = static_cast<uint16_t>(k);
        m = logMove(moves, m, v, a, k);
    }
    for (int b = 0; b < nb; ++b) v4::store(nG + kBlock * b, g[b]);
    rng = draws;
    return m;
}
#endif

// ---- one cell against frozen word-topic counts (a round of a parallel window) --

// As refineCell, except that n_k^v, n_k and the reciprocals are only read:
// during a round they hold every word at z0[i], its label when the round
// began, so word i leaves topic z0[i] there, and leaves its current topic in
// its neighbourhood sums nG, which the task owns and updates in place. The
// cell's own counts are not written: they change exactly as nG does, so the
// task sets them from nG once, at its end (ModelCore::closeFrozenTask). The
// new labels reach n_k^v and n_k when the round's changes are merged.
template <int KP, Path P, typename R>
inline uint32_t refineCellFrozenLanes(const Tables& t, int32_t* nG, const uint32_t* words, uint16_t* topics,
                                      const uint16_t* z0, uint32_t n, R& rng, uint64_t* moves) noexcept {
    const int Kp = KP > 0 ? KP : t.Kp;
    alignas(64) float h[KP > 0 ? KP : kMaxK];
    cellWeights(t.inv, nG, t.alpha, Kp, h);
    uint32_t m = 0;
    for (uint32_t i = 0; i < n; ++i) {
        const int32_t* row = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(Kp);
        const int a = z0[i], z = topics[i];
        const float u01 = rng.uniformFloat();
        // In the frozen tables the word is at a: n_a^v and n_a one lower for
        // its draw (with growth, a word that was its topic's last leaves it
        // closed); in the cell's own counts it leaves z.
        const float invA = KP == kGrow && t.nk[a] == 1 ? 0.f : t.dec[a];
        const auto hZ = keepBlock<P>(h, z);
        --nG[z];
        if (a == z) {  // the common case: one change to h
            setAt<P>(h, z, invA * (static_cast<float>(nG[z]) + t.alpha));
        } else {
            setAt<P>(h, z, t.inv[z] * (static_cast<float>(nG[z]) + t.alpha));
            setAt<P>(h, a, invA * (static_cast<float>(nG[a]) + t.alpha));
        }
        const int nb = liveLanes<KP>(t, Kp) / kBlock;
        // With growth, a word that opens a topic takes label `slot`: every
        // task of the round that opens one opens the same, merged after it.
        const int k = drawTopic<KP, P, true>(t, row, a, h, nb, u01);
        m = logMove(moves, m, words[i], a, k);
        if (k == z) {
            ++nG[z];
            if (a != z) setAt<P>(h, a, t.inv[a] * (static_cast<float>(nG[a]) + t.alpha));
            restoreBlock(h, z, hZ);
            continue;
        }
        if (a == z) {
            setAt<P>(h, z, t.inv[z] * (static_cast<float>(nG[z]) + t.alpha));
        } else {
            setAt<P>(h, a, t.inv[a] * (static_cast<float>(nG[a]) + t.alpha));
        }
        ++nG[k];
        setAt<P>(h, k, t.inv[k] * (static_cast<float>(nG[k]) + t.alpha));
        topics[i] = static_cast<uint16_t>(k);
    }
    return m;
}

// Refines every word of one cell once against frozen word-topic counts (a
// round of a parallel window); path P as refineCell. Returns the moves listed.
template <int KP, Path P, bool kFirst = false, typename R>
inline uint32_t refineCellFrozen(const Tables& t, int32_t* nG, const uint32_t* words, uint16_t* topics,
                                 const uint16_t* z0, uint32_t n, R& rng, uint64_t* moves) noexcept {
    if (registerKernel<KP>(t)) {
#if defined(ROST_KERNEL_SIMD)
        if constexpr (P == Path::Simd) return refineCellFrozenScanSimd<KP, kFirst>(t, nG, words, topics, z0, n, rng, moves);
#endif
        return refineCellFrozenScanScalar<KP>(t, nG, words, topics, z0, n, rng, moves);
    }
    if constexpr (KP <= 0 || KP / kBlock > kScanBlocks)
        return refineCellFrozenLanes<KP, P>(t, nG, words, topics, z0, n, rng, moves);
    else
        return 0;  // (not reached: known K <= 32 is always a register kernel)
}

} // namespace rost::kernel
