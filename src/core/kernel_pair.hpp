#pragma once

// Two cells of one round refined together, against frozen word-topic counts
// (src/core/refine_tasks.cpp). Internal to the library.
//
// A word's draw waits on the previous word's (the cell's neighbourhood sums
// carry it), so one cell's words form one chain of dependent vector
// operations and a core runs it well below its issue width. Two tasks of a
// round share nothing a round writes: each has its own cell, labels, sums and
// counter-based draws, and the word-topic counts are frozen. Interleaving
// their words word by word gives a core two independent chains, and each
// cell gets exactly the draws and labels refineCellFrozen gives it alone.

#include <algorithm>

#include "kernel_frozen.hpp"

namespace rost::kernel {

// Whether refineCellsFrozenPair interleaves the two cells: a vector path
// with K known at compile time and at most kPairBlocks blocks, so both
// chains' sums and the reciprocals stay in registers (16 on SSE2).
inline constexpr int kPairBlocks = 4;
template <int KP, Path P>
constexpr bool interleavesPairs() noexcept {
#if defined(ROST_KERNEL_SIMD)
    return P == Path::Simd && KP > 0 && KP / kBlock <= kPairBlocks;
#else
    return false;
#endif
}

#if defined(ROST_KERNEL_SIMD)
// The first m words of A and of B, word by word: refineCellFrozenScanSimd's
// operations on each.
template <int KP, bool kFirst, typename R>
inline PairMoves refinePairFrozenScanSimd(const Tables& t, const FrozenCell& A, R& ra, const FrozenCell& B, R& rb,
                                          uint32_t m) noexcept {
    constexpr int nb = KP / kBlock;
    // Locals, the generators too: a store to the cells' labels or moves
    // could otherwise change them, and each word would reload them.
    const uint32_t* const wA = A.words;
    const uint32_t* const wB = B.words;
    uint16_t* const zA = A.topics;
    uint16_t* const zB = B.topics;
    const uint16_t* const z0A = A.z0;
    const uint16_t* const z0B = B.z0;
    uint64_t* const movesA = A.moves;
    uint64_t* const movesB = B.moves;
    uint32_t mA = 0, mB = 0;
    R drawsA = ra, drawsB = rb;
    v4::I ga[nb], gb[nb];
    for (int b = 0; b < nb; ++b) {
        ga[b] = v4::load(A.nG + kBlock * b);
        gb[b] = v4::load(B.nG + kBlock * b);
    }
    const float* const iv = t.inv;  // (unread: at known K a word's reciprocals are a row of t.left)
    const v4::F beta = v4::set(t.beta), alpha = v4::set(t.alpha);
    for (uint32_t i = 0; i < m; ++i) {
        const uint32_t vA = wA[i], vB = wB[i];
        const int32_t* rowA = t.nkv + static_cast<std::size_t>(vA) * KP;
        const int32_t* rowB = t.nkv + static_cast<std::size_t>(vB) * KP;
        const int cA = zA[i], cB = zB[i];
        const int aA = kFirst ? cA : z0A[i], aB = kFirst ? cB : z0B[i];
        // (Each word's draw taken where its sums are compared with it.)
        const int kA = frozenScanWord<KP, true>(t, ga, iv, rowA, aA, cA, drawsA, frozenLeft<KP>(t, aA), nb, beta, alpha);
        const int kB = frozenScanWord<KP, true>(t, gb, iv, rowB, aB, cB, drawsB, frozenLeft<KP>(t, aB), nb, beta, alpha);
        zA[i] = static_cast<uint16_t>(kA);
        zB[i] = static_cast<uint16_t>(kB);
        mA = logMove(movesA, mA, vA, aA, kA);
        mB = logMove(movesB, mB, vB, aB, kB);
    }
    for (int b = 0; b < nb; ++b) {
        v4::store(A.nG + kBlock * b, ga[b]);
        v4::store(B.nG + kBlock * b, gb[b]);
    }
    ra = drawsA;
    rb = drawsB;
    return {mA, mB};
}
#endif

// Refines every word of A with draws ra and every word of B with draws rb,
// as refineCellFrozen on each in turn: two cells of one round (no shared
// cell counts or sums). Interleaved while both have words (interleavesPairs).
// Returns the moves each listed. kFirst: the tasks' first picks (refineCellFrozen).
template <int KP, Path P, bool kFirst = false, typename R>
inline PairMoves refineCellsFrozenPair(const Tables& t, const FrozenCell& A, R& ra, const FrozenCell& B,
                                       R& rb) noexcept {
    uint32_t m = 0;
    PairMoves moved;
#if defined(ROST_KERNEL_SIMD)
    if constexpr (interleavesPairs<KP, P>()) {
        m = std::min(A.n, B.n);
        moved = refinePairFrozenScanSimd<KP, kFirst>(t, A, ra, B, rb, m);
    }
#endif
    if (A.n > m)
        moved.a += refineCellFrozen<KP, P, kFirst>(t, A.nG, A.words + m, A.topics + m, A.z0 + m, A.n - m, ra, A.moves + moved.a);
    if (B.n > m)
        moved.b += refineCellFrozen<KP, P, kFirst>(t, B.nG, B.words + m, B.topics + m, B.z0 + m, B.n - m, rb, B.moves + moved.b);
    return moved;
}

} // namespace rost::kernel
