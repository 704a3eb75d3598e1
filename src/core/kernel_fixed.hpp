#pragma once

// The refinement kernel of a fixed topic model (Config::fixed; docs/design.md,
// "A fixed topic model"). Internal to the library.

#include "kernel.hpp"

namespace rost::kernel {

// Against a fixed topic model (Config::fixed): n_k^v, n_k and the
// reciprocals hold only the given counts and are never written, so a word
// leaves its topic in the cell's neighbourhood sums only, and any number of
// cells may be refined at once without a merge. Labelling in a given topic
// set costs a few sweeps, so this one scalar loop serves every K and path.
template <typename R>
inline void refineCellFixed(const Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
                            uint32_t n, R& rng) noexcept {
    alignas(64) float cum[1024];
    for (uint32_t i = 0; i < n; ++i) {
        const int32_t* row = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(t.Kp);
        const int z = topics[i];
        --nG[z];
        const float total = weightsAndScanScalar(row, t.inv, nG, t.alpha, t.beta, t.Kp, cum);
        const int k = selectScalar(cum, t.Kp, t.K, rng.uniformFloat() * total);
        ++nG[k];
        if (k != z) {
            --nc[z];
            ++nc[k];
            topics[i] = static_cast<uint16_t>(k);
        }
    }
}

} // namespace rost::kernel
