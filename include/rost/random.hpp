#pragma once

#include <cstdint>
#include <span>

namespace rost {

// xoshiro128++ (Blackman & Vigna): 128 bits of state, 32-bit outputs, only
// 32-bit integer operations, so it is equally fast on armhf and gives the
// same stream on every architecture. Seeded through splitmix64.
class Rng {
public:
    explicit Rng(uint64_t seed = 1) noexcept { reseed(seed); }

    void reseed(uint64_t seed) noexcept {
        for (int i = 0; i < 4; i += 2) {
            const uint64_t z = splitmix64(seed);
            s_[i] = static_cast<uint32_t>(z);
            s_[i + 1] = static_cast<uint32_t>(z >> 32);
        }
        if ((s_[0] | s_[1] | s_[2] | s_[3]) == 0) s_[0] = 1;
    }

    uint32_t next() noexcept {
        const uint32_t result = rotl(s_[0] + s_[3], 7) + s_[0];
        const uint32_t t = s_[1] << 9;
        s_[2] ^= s_[0];
        s_[3] ^= s_[1];
        s_[1] ^= s_[2];
        s_[0] ^= s_[3];
        s_[2] ^= t;
        s_[3] = rotl(s_[3], 11);
        return result;
    }

    // Uniform float in [0, 1) with 24 random bits (exact in binary32).
    float uniformFloat() noexcept { return static_cast<float>(next() >> 8) * 0x1p-24f; }

    // Uniform double in [0, 1) with 53 random bits.
    double uniformDouble() noexcept {
        const uint64_t hi = next() >> 5;  // 27 bits
        const uint64_t lo = next() >> 6;  // 26 bits
        return static_cast<double>((hi << 26) | lo) * 0x1p-53;
    }

    // Uniform integer in [0, n), n > 0, without modulo bias (Lemire's method).
    uint32_t below(uint32_t n) noexcept {
        uint64_t m = static_cast<uint64_t>(next()) * n;
        auto low = static_cast<uint32_t>(m);
        if (low < n) {
            const uint32_t threshold = (0u - n) % n;
            while (low < threshold) {
                m = static_cast<uint64_t>(next()) * n;
                low = static_cast<uint32_t>(m);
            }
        }
        return static_cast<uint32_t>(m >> 32);
    }

    // The whole state, for checkpoints.
    struct State {
        uint32_t s[4];
    };
    State state() const noexcept { return {{s_[0], s_[1], s_[2], s_[3]}}; }
    void setState(const State& st) noexcept {
        for (int i = 0; i < 4; ++i) s_[i] = st.s[i];
    }
    // The state words themselves (a checkpoint section).
    std::span<uint32_t, 4> stateWords() noexcept { return std::span<uint32_t, 4>(s_); }
    std::span<const uint32_t, 4> stateWords() const noexcept { return std::span<const uint32_t, 4>(s_); }

private:
    static uint32_t rotl(uint32_t x, int k) noexcept { return (x << k) | (x >> (32 - k)); }
    static uint64_t splitmix64(uint64_t& x) noexcept {
        uint64_t z = (x += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    uint32_t s_[4];
};

} // namespace rost
