#pragma once

// The Gibbs kernel's view of a model's word-topic counts, and the topic
// padding of its 4-lane blocks. Internal to the library: the public Model
// keeps these tables behind its implementation.

#include <cstdint>

#include "rost/kernel_types.hpp"

namespace rost::kernel {

inline constexpr int kBlock = 4;

// Topics padded to a whole number of 4-lane blocks; padding lanes carry zero weight.
constexpr int paddedK(int K) noexcept { return (K + kBlock - 1) / kBlock * kBlock; }
// The kernels' KP for a model whose topics grow (runtime K, active topics only).
constexpr int kGrow = -1;

// The word-topic side of the count tables, shared by every cell.
struct Tables {
    int32_t* nkv = nullptr;  // V x Kp, word-major: a word's K counts are contiguous
    int32_t* nk = nullptr;   // Kp topic totals
    float* inv = nullptr;    // Kp cached 1 / (n_k + V beta); 0 in padding lanes
    float* dec = nullptr;    // Kp cached 1 / (n_k - 1 + V beta)
    float* inc = nullptr;    // Kp cached 1 / (n_k + 1 + V beta)
    // Kp x Kp in a worker's tables where the frozen register kernels run at a
    // known K (16 or 32, no growth: ModelCore::leftTables), else null: row
    // a is inv with lane a replaced by dec[a], the reciprocals a word at topic
    // a draws with when it leaves a in the frozen counts. Filled as a worker
    // starts its part of a frozen round (kernel::fillLeft), read by the
    // frozen register kernels.
    float* left = nullptr;
    int K = 0;
    int Kp = 0;
    // Topic growth (docs/design.md, "Topics that grow"). Without growth all
    // K topics are open. With growth a topic is open while it holds a word
    // (n_k > 0; inv is 0 for a closed one), `active` counts the open ones,
    // `hi` is 1 + the highest open label, and a word opens topic `slot` (the
    // lowest closed label; K when none is left) with weight `fresh` (the
    // model sets kGrowthFreshMass / V: docs/design.md, "Growth from the data").
    // The growth kernels are the KP = kGrow instances.
    bool grow = false;
    int active = 0;
    int hi = 0;
    int slot = 0;
    float fresh = 0.f;
    float alpha = 0.f;
    float beta = 0.f;
    float vbeta = 0.f;
};

// One cell of a frozen round: its neighbourhood sums, its own counts, its
// words, labels and round-start labels, its word count, and room for its
// moves (one for each word).
struct FrozenCell {
    int32_t* nG;
    int32_t* nc;
    const uint32_t* words;
    uint16_t* topics;
    const uint16_t* z0;
    uint32_t n;
    uint64_t* moves;
};

// The moves two cells of a pair listed.
struct PairMoves {
    uint32_t a = 0;
    uint32_t b = 0;
};

} // namespace rost::kernel
