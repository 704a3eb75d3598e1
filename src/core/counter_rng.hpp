#pragma once

// Counter-based random numbers for parallel refinement (internal).
//
// A draw is a pure function of (key, pick, index): the window's key (drawn
// serially from the model's generator), the pick's position in the window
// and the word's position in its cell. No draw depends on which thread makes
// it or on how many threads there are. The mixing function is the
// finaliser of SplitMix64 (Steele, Lea & Flood 2014), a bijection of 64-bit
// integers whose outputs over a counter pass BigCrush; 64-bit integer
// arithmetic only, so every architecture draws the same numbers.

#include <cstdint>
#if defined(__aarch64__)
#include <arm_neon.h>  // vcvts_n_f32_u32
#endif

namespace rost::detail {

constexpr uint64_t mix64(uint64_t z) noexcept {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// The draws of one pick: uniformFloat() returns the draw of index 0, 1, 2, ...
// in turn (the kernel asks once per word, in the cell's order).
class CounterRng {
public:
    CounterRng(uint64_t key, uint64_t pick) noexcept : base_(mix64(key ^ ((pick + 1) * 0x9E3779B97F4A7C15ull))) {}

    uint32_t next() noexcept {
        ++index_;
        return static_cast<uint32_t>(mix64(base_ + index_ * 0xD1B54A32D192ED03ull) >> 32);
    }
    // Uniform float in [0, 1) with 24 random bits (exact in binary32), as Rng::uniformFloat.
    // (On aarch64 one fixed-point convert, the same value: x * 2^-24 is exact.)
    float uniformFloat() noexcept {
#if defined(__aarch64__)
        return vcvts_n_f32_u32(next() >> 8, 24);
#else
        return static_cast<float>(next() >> 8) * 0x1p-24f;
#endif
    }

private:
    uint64_t base_;
    uint64_t index_ = 0;
};

} // namespace rost::detail
