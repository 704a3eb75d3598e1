#pragma once

// The collapsed Gibbs refinement kernel (paper eq. 5), with a scalar reference
// and a 4-lane SIMD path (SSE2 on x86-64, NEON on aarch64 and ARMv7+NEON).
// Internal to the library (not installed): the public headers name only its
// types (rost/kernel_types.hpp).
//
// Determinism across paths and architectures: both paths perform exactly the
// same IEEE binary32 operations in the same order, so they draw the same
// topic for the same random number (the core is compiled with
// -ffp-contract=off: no fused multiply-add):
//   * inv_k = 1 / (n_k + V beta) by IEEE division, cached per topic and
//     recomputed only for the two topics a token changes;
//   * h_k = inv_k * (n_G^k + alpha), kept per cell for the cell's words and
//     recomputed only for the topics a token changes; the weight of topic k
//     is p_k = (n_k^v + beta) * h_k;
//   * the canonical sums (below, "the canonical sums"): blocks of 4 topics
//     alternate between two chains, each lane of a chain a running sum, and
//     the draw finds u = r * total first among the 8 lanes, then along one.
// 4-lane blocks are what SSE2, NEON and a scalar loop all do natively. Per
// block and token the vector path does one load of the counts, a convert,
// an add, a multiply and one add on the chain, and one compare and add in the
// draw; the sums across lanes are done once per token, not once per block.

#include <algorithm>
#include <cstdint>

#include "kernel_tables.hpp"
#include "kernel_v4.hpp"
#include "rost/random.hpp"

namespace rost::kernel {

inline float reciprocal(int32_t nk, float vbeta) noexcept {
    return 1.0f / (static_cast<float>(nk) + vbeta);
}

// Recomputes the cached reciprocals of every topic from n_k.
inline void refreshReciprocals(Tables& t) noexcept {
    for (int k = 0; k < t.K; ++k) {
        t.inv[k] = reciprocal(t.nk[k], t.vbeta);
        t.dec[k] = reciprocal(t.nk[k] - 1, t.vbeta);
        t.inc[k] = reciprocal(t.nk[k] + 1, t.vbeta);
    }
    for (int k = t.K; k < t.Kp; ++k) t.inv[k] = t.dec[k] = t.inc[k] = 0.f;
    if (t.grow)
        for (int k = 0; k < t.K; ++k)
            if (t.nk[k] == 0) t.inv[k] = 0.f;  // a closed topic weighs nothing
}

// Recomputes which topics are open (growth) from n_k.
inline void updateTopics(Tables& t) noexcept {
    if (!t.grow) {
        t.active = t.hi = t.slot = t.K;
        return;
    }
    t.active = 0;
    t.hi = 0;
    t.slot = t.K;
    for (int k = 0; k < t.K; ++k) {
        if (t.nk[k] > 0) {
            ++t.active;
            t.hi = k + 1;
        } else if (t.slot == t.K) {
            t.slot = k;
        }
    }
}

// A word left topic z, which held only it: z closes (growth).
inline void closeTopic(Tables& t, int z) noexcept {
    --t.active;
    if (z < t.slot) t.slot = z;
    if (z + 1 == t.hi)
        while (t.hi > 0 && t.nk[t.hi - 1] == 0) --t.hi;
}

// A word joined closed topic k (always the slot): k opens (growth).
inline void openTopic(Tables& t, int k) noexcept {
    ++t.active;
    if (k + 1 > t.hi) t.hi = k + 1;
    int s = k + 1;
    while (s < t.K && t.nk[s] != 0) ++s;
    t.slot = s;
}

// ---- topic growth -----------------------------------------------------------

// Lanes a word's draw looks at: all Kp without growth; with growth the active
// topics and the one a word may open, in whole blocks.
template <int KP>
inline int liveLanes(const Tables& t, int Kp) noexcept {
    if constexpr (KP != kGrow) {
        return Kp;
    } else {
        const int n = t.hi < t.K ? t.hi + 1 : t.K;  // the open topics and the slot (<= hi)
        return (n + kBlock - 1) / kBlock * kBlock;
    }
}

// Weight of opening a new topic for this word (0 without growth or at the cap).
template <int KP>
inline float freshWeight(const Tables& t) noexcept {
    if constexpr (KP != kGrow) return 0.f;
    return t.slot < t.K ? t.fresh : 0.f;
}

// 1 / (n_z + V beta) after a word left topic z (now n_z = nz); with growth,
// 0 when it was the topic's last word: the topic closes.
template <int KP>
inline float leftReciprocal(Tables& t, int z, int32_t nz) noexcept {
    if constexpr (KP == kGrow) {
        if (nz == 0) {
            closeTopic(t, z);
            return 0.f;
        }
    }
    return t.dec[z];
}
#define ROST_KERNEL_INLINE inline __attribute__((always_inline))

inline constexpr int kMaxK = 1024;                // the schema's largest K (a multiple of kBlock)
inline constexpr int kMaxBlocks = kMaxK / kBlock;  // blocks of the runtime-K kernels' arrays

// ---- the register kernels (the scan order, up to 8 blocks) ----------------------
//
// With at most kScanBlocks blocks (K <= 32, or with growth that many live
// blocks when a cell starts) a cell is refined by these kernels. They keep the
// neighbourhood sums and reciprocals in vector registers for the whole cell
// and apply a word's -1/+1 with lane masks: at a few blocks the masks are
// cheap, and no word waits for a store of the previous one. Weights are
// ((n_k^v + beta) * inv_k) * (n_G^k + alpha); the sum is the scan order: a
// Hillis-Steele scan inside each block of 4 topics, then a running carry
// added block by block; the new topic is the number of running sums <= u,
// u = r * total.

// The drawn topic from the number of prefix sums <= u: with growth, all of
// the open topics' sums <= u means a new topic, the slot (while there is
// room). `away` is a topic whose count in t.nk is one higher than the draw's (the
// frozen kernels' round-start label; -1 for the live ones, which decrement
// n_k first).
template <int KP>
inline int drawnTopic(const Tables& t, int count, int away = -1) noexcept {
    if constexpr (KP != kGrow) {
        return count < t.K ? count : t.K - 1;
    } else {
        if (count >= t.hi) return t.slot < t.K ? t.slot : t.hi - 1;
        // A block's scan rounds its sums in different orders, so the sum at
        // a closed topic (weight 0) can end one ulp above the sum before it
        // and be counted: the draw is then the last open topic below it.
        int k = count;
        while (k > 0 && t.nk[k] - (k == away ? 1 : 0) <= 0) --k;
        return k;
    }
}

// ---- scalar reference -------------------------------------------------------

// Writes the canonical prefix sums of the weights into cum[0..Kp) and returns the total.
inline float weightsAndScanScalar(const int32_t* row, const float* inv, const int32_t* nG, float alpha,
                                  float beta, int Kp, float* cum) noexcept {
    float carry = 0.f;
    for (int b = 0; b < Kp; b += kBlock) {
        float p[kBlock];
        for (int j = 0; j < kBlock; ++j) {
            const float a = static_cast<float>(row[b + j]) + beta;
            const float c = static_cast<float>(nG[b + j]) + alpha;
            p[j] = (a * inv[b + j]) * c;
        }
        const float q0 = p[0], q1 = p[1] + p[0], q2 = p[2] + p[1], q3 = p[3] + p[2];
        const float s0 = q0, s1 = q1, s2 = q2 + q0, s3 = q3 + q1;
        cum[b + 0] = s0 + carry;
        cum[b + 1] = s1 + carry;
        cum[b + 2] = s2 + carry;
        cum[b + 3] = s3 + carry;
        carry = cum[b + 3];
    }
    return carry;
}

inline int selectScalar(const float* cum, int Kp, int K, float u) noexcept {
    int count = 0;
    for (int k = 0; k < Kp; ++k) count += cum[k] <= u ? 1 : 0;
    return count < K ? count : K - 1;
}

// ---- SIMD path --------------------------------------------------------------

inline float weightsAndScanSimd(const int32_t* row, const float* inv, const int32_t* nG, float alpha, float beta,
                                int Kp, float* cum) noexcept {
#if defined(ROST_SIMD_SSE2)
    const __m128 b4 = _mm_set1_ps(beta);
    const __m128 a4 = _mm_set1_ps(alpha);
    __m128 carry = _mm_setzero_ps();
    for (int b = 0; b < Kp; b += kBlock) {
        const __m128 r = _mm_cvtepi32_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + b)));
        const __m128 g = _mm_cvtepi32_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(nG + b)));
        __m128 p = _mm_mul_ps(_mm_mul_ps(_mm_add_ps(r, b4), _mm_loadu_ps(inv + b)), _mm_add_ps(g, a4));
        p = _mm_add_ps(p, _mm_castsi128_ps(_mm_slli_si128(_mm_castps_si128(p), 4)));
        p = _mm_add_ps(p, _mm_castsi128_ps(_mm_slli_si128(_mm_castps_si128(p), 8)));
        p = _mm_add_ps(p, carry);
        _mm_storeu_ps(cum + b, p);
        carry = _mm_shuffle_ps(p, p, _MM_SHUFFLE(3, 3, 3, 3));
    }
    return _mm_cvtss_f32(carry);
#elif defined(ROST_SIMD_NEON)
    const float32x4_t b4 = vdupq_n_f32(beta);
    const float32x4_t a4 = vdupq_n_f32(alpha);
    const float32x4_t zero = vdupq_n_f32(0.f);
    float32x4_t carry = zero;
    for (int b = 0; b < Kp; b += kBlock) {
        const float32x4_t r = vcvtq_f32_s32(vld1q_s32(row + b));
        const float32x4_t g = vcvtq_f32_s32(vld1q_s32(nG + b));
        float32x4_t p = vmulq_f32(vmulq_f32(vaddq_f32(r, b4), vld1q_f32(inv + b)), vaddq_f32(g, a4));
        p = vaddq_f32(p, vextq_f32(zero, p, 3));
        p = vaddq_f32(p, vextq_f32(zero, p, 2));
        p = vaddq_f32(p, carry);
        vst1q_f32(cum + b, p);
        carry = vdupq_n_f32(vgetq_lane_f32(p, 3));
    }
    return vgetq_lane_f32(carry, 0);
#else
    return weightsAndScanScalar(row, inv, nG, alpha, beta, Kp, cum);
#endif
}

inline int selectSimd(const float* cum, int Kp, int K, float u) noexcept {
#if defined(ROST_SIMD_SSE2)
    const __m128 u4 = _mm_set1_ps(u);
    __m128i acc = _mm_setzero_si128();
    for (int b = 0; b < Kp; b += kBlock)
        acc = _mm_sub_epi32(acc, _mm_castps_si128(_mm_cmple_ps(_mm_loadu_ps(cum + b), u4)));
    acc = _mm_add_epi32(acc, _mm_shuffle_epi32(acc, _MM_SHUFFLE(1, 0, 3, 2)));
    acc = _mm_add_epi32(acc, _mm_shuffle_epi32(acc, _MM_SHUFFLE(2, 3, 0, 1)));
    const int count = _mm_cvtsi128_si32(acc);
#elif defined(ROST_SIMD_NEON)
    const float32x4_t u4 = vdupq_n_f32(u);
    uint32x4_t acc = vdupq_n_u32(0);
    for (int b = 0; b < Kp; b += kBlock) acc = vsubq_u32(acc, vcleq_f32(vld1q_f32(cum + b), u4));
    const uint32x2_t half = vadd_u32(vget_low_u32(acc), vget_high_u32(acc));
    const int count = static_cast<int>(vget_lane_u32(vpadd_u32(half, half), 0));
#else
    return selectScalar(cum, Kp, K, u);
#endif
#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
    return count < K ? count : K - 1;
#endif
}



// Refines every word of one cell once (paper eq. 5): the word leaves its
// current topic only, a new topic is drawn from the exact conditional, and
// n_k^v, n_k, n_c^k and the neighbourhood sums nG are updated in place.
// KP is the padded K when known at compile time (0: use t.Kp).
//
// The scalar path is the reference. The SIMD path keeps the neighbourhood
// sums and reciprocals in vector registers for the whole cell and applies a
// word's -1/+1 with lane masks, so no scalar store is ever followed by a
// vector load of the same bytes (a store-forwarding stall on x86 and ARM).
// It performs the same float operations in the same order as the reference.
template <int KP, typename R>
inline void refineCellScanScalar(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
                             uint32_t n, R& rng) noexcept {
    const int Kp = KP > 0 ? KP : t.Kp;
    alignas(64) float cum[KP > 0 ? KP : 1024];
    for (uint32_t i = 0; i < n; ++i) {
        int32_t* row = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(Kp);
        const int z = topics[i];
        const float invOld = t.inv[z];
        --row[z];
        --nG[z];
        --t.nk[z];
        t.inv[z] = reciprocal(t.nk[z], t.vbeta);
        if constexpr (KP == kGrow) {
            if (t.nk[z] == 0) {  // the word was its topic's last: the topic closes
                t.inv[z] = 0.f;
                closeTopic(t, z);
            }
        }
        const int L = liveLanes<KP>(t, Kp);
        float total = weightsAndScanScalar(row, t.inv, nG, t.alpha, t.beta, L, cum);
        if constexpr (KP == kGrow) total += freshWeight<KP>(t);
        const float u = rng.uniformFloat() * total;
        int count = 0;
        for (int j = 0; j < L; ++j) count += cum[j] <= u ? 1 : 0;
        const int k = drawnTopic<KP>(t, count);
        ++row[k];
        ++nG[k];
        ++t.nk[k];
        if constexpr (KP == kGrow) {
            if (t.nk[k] == 1) openTopic(t, k);  // a new topic (its reciprocals follow below)
        }
        if (k == z) {
            t.inv[z] = invOld;
        } else {
            t.inv[k] = reciprocal(t.nk[k], t.vbeta);
            t.dec[z] = reciprocal(t.nk[z] - 1, t.vbeta);
            t.inc[z] = reciprocal(t.nk[z] + 1, t.vbeta);
            t.dec[k] = reciprocal(t.nk[k] - 1, t.vbeta);
            t.inc[k] = reciprocal(t.nk[k] + 1, t.vbeta);
            --nc[z];
            ++nc[k];
            topics[i] = static_cast<uint16_t>(k);
        }
    }
}

#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
template <int KP, typename R>
inline void refineCellScanSimd(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
                           uint32_t n, R& draws) noexcept {
    R rng = draws;  // a local: the count and label stores could otherwise change it
    const int Kp = KP > 0 ? KP : t.Kp;
    const int nb = Kp / kBlock;
    constexpr int kArr = KP > 0 ? KP / kBlock : kMaxBlocks;
    // t.dec / t.inc hold 1/(n_k -+ 1 + V beta), so a token's decrement and
    // increment take their new reciprocal with a load and the divisions run
    // off the dependency chain (the values are the reference's).
    float* const inv = t.inv;
    float* const dec = t.dec;
    float* const inc = t.inc;
    v4::I g[kArr], r[kArr];
    v4::F iv[kArr], cum[kArr];
    for (int b = 0; b < nb; ++b) {
        g[b] = v4::load(nG + kBlock * b);
        iv[b] = v4::load(inv + kBlock * b);
    }
    const v4::F beta = v4::set(t.beta), alpha = v4::set(t.alpha);
    for (uint32_t i = 0; i < n; ++i) {
        int32_t* row = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(Kp);
        const int z = topics[i];
        const float u01 = rng.uniformFloat();
        // Word i leaves topic z (eq. 5's -i): n_k^v and n_G^k in registers by
        // lane mask; n_k and the reciprocals in memory.
        const int32_t nz = --t.nk[z];
        const float invZ = leftReciprocal<KP>(t, z, nz);
        const v4::I zz = v4::seti(z);
        const v4::F vz = v4::set(invZ);
        v4::F carry = v4::set(0.f);
        const int nbL = liveLanes<KP>(t, Kp) / kBlock;
        if (nbL < 1) __builtin_unreachable();  // at least one topic is active
        for (int b = 0; b < nbL; ++b) {
            const v4::I m = v4::eq(v4::iota(kBlock * b), zz);
            r[b] = v4::add(v4::load(row + kBlock * b), m);
            g[b] = v4::add(g[b], m);
            iv[b] = v4::select(m, vz, iv[b]);
            const v4::F p = v4::scan(
                v4::mul(v4::mul(v4::add(v4::cvt(r[b]), beta), iv[b]), v4::add(v4::cvt(g[b]), alpha)));
            // cum = scan + carry, and the next carry = carry + the block's last
            // lane: the reference's sums, with the shuffle off the chain
            // (block 0's carry is zero, and x + 0 = x exactly).
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
        const v4::F uu = v4::mul(v4::set(u01), total);
        // -(number of prefix sums <= u) in every lane. Without growth u <
        // total = cum[K-1], so the count never exceeds K - 1 and needs no clamp.
        v4::I count = v4::le(cum[0], uu);
        for (int b = 1; b < nbL; ++b) count = v4::add(count, v4::le(cum[b], uu));
        count = v4::hbroadcast(count);
        int k = -v4::firsti(count);
        bool opened = false;
        if constexpr (KP == kGrow) {
            k = drawnTopic<KP>(t, k);
            count = v4::seti(-k);
            opened = t.nk[k] == 0;
        }
        // Word i joins topic k. When k == z (common once converged) every
        // value is restored and nothing else is written.
        float invK;
        if (k == z) {
            ++t.nk[z];
            invK = inv[z];
        } else {
            inc[z] = inv[z];
            inv[z] = invZ;
            dec[z] = reciprocal(nz - 1, t.vbeta);
            const int32_t nk = ++t.nk[k];
            invK = inc[k];
            dec[k] = inv[k];
            inv[k] = invK;
            inc[k] = reciprocal(nk + 1, t.vbeta);
            if (opened) dec[k] = reciprocal(nk - 1, t.vbeta);  // its inv was 0 while closed
            --nc[z];
            ++nc[k];
            topics[i] = static_cast<uint16_t>(k);
        }
        if constexpr (KP == kGrow) {
            if (opened) openTopic(t, k);
        }
        const v4::F vk = v4::set(invK);
        for (int b = 0; b < nbL; ++b) {
            const v4::I m = v4::eq(v4::niota(kBlock * b), count);  // lane j is topic k <=> -j == count
            v4::store(row + kBlock * b, v4::sub(r[b], m));
            g[b] = v4::sub(g[b], m);
            iv[b] = v4::select(m, vk, iv[b]);
        }
    }
    for (int b = 0; b < nb; ++b) v4::store(nG + kBlock * b, g[b]);
    draws = rng;
}
#endif



// ---- the canonical sums ----------------------------------------------------
//
// Every path computes a word's weights and draws its topic with these
// operations in this order (docs/design.md, "The kernel's sums"):
//   * p_k = (n_k^v + beta) * h_k over the nb live blocks of 4 topics;
//   * block b belongs to chain b & 1; in each chain, lane by lane, cum_b =
//     cum_{b-2} + p_b, starting from 0: eight running sums ("lanes"
//     v = 4 * chain + j, j the position in the block);
//   * the lanes' totals T_v get exclusive bases: within a chain the
//     Hillis-Steele scan of (0, T_0, T_1, T_2) (pairs (x + shifted x), then
//     + shifted by two); chain 1's bases are chain 0's total (base_3 + T_3)
//     plus its own scan; total = base_7 + T_7;
//   * u = r * (total + the new-topic weight with growth). u >= total opens
//     the slot (growth). Otherwise the lane is the last v with base_v <= u and
//     the topic the first block b of that lane with cum_b > u - base_v: topic
//     4 b + (v & 3). When rounding leaves no such block (u at the very end of
//     its lane), the draw is the last topic of positive weight at or before
//     that lane.
// Any fixed order of the topics samples the same law. This one costs, per
// block, one add on a chain and one compare in the draw; the two chains
// halve the dependency chain of the adds.

// Scalar form: (0, t0, t1, t2) scanned as the vector path scans it.
inline void exclusiveScan4(const float* t, float* s) noexcept {
    const float x0 = 0.f, x1 = t[0], x2 = t[1], x3 = t[2];
    const float q0 = x0 + 0.f, q1 = x1 + x0, q2 = x2 + x1, q3 = x3 + x2;
    s[0] = q0 + 0.f;
    s[1] = q1 + 0.f;
    s[2] = q2 + q0;
    s[3] = q3 + q1;
}

// h_k = inv_k * (n_G^k + alpha) for the Kp topics (0 for closed and padding topics).
inline void cellWeights(const float* inv, const int32_t* nG, float alpha, int Kp, float* h) noexcept {
    for (int k = 0; k < Kp; ++k) h[k] = inv[k] * (static_cast<float>(nG[k]) + alpha);
}

// The weights' running sums cum[4 nb] and the lanes' bases base[8]; returns
// the total. With kMinus the word's count of topic `minus` is one lower.
template <bool kMinus>
inline float laneSumsScalar(const int32_t* row, int minus, const float* h, float beta, int nb, float* cum,
                            float* base) noexcept {
    float acc[8] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
    for (int b = 0; b < nb; ++b) {
        float* a = acc + kBlock * (b & 1);
        for (int j = 0; j < kBlock; ++j) {
            const int k = kBlock * b + j;
            const int32_t n = kMinus && k == minus ? row[k] - 1 : row[k];
            a[j] = a[j] + (static_cast<float>(n) + beta) * h[k];
            cum[k] = a[j];
        }
    }
    exclusiveScan4(acc, base);
    const float tot0 = base[3] + acc[3];
    float s1[4];
    exclusiveScan4(acc + 4, s1);
    for (int j = 0; j < 4; ++j) base[4 + j] = tot0 + s1[j];
    return base[7] + acc[7];
}

// The topic of u in [0, total), or -1 - v when rounding left no block of
// lane v above u (the caller then takes lastWeighted).
inline int laneSelectScalar(const float* cum, const float* base, int nb, float u) noexcept {
    int v = 0;
    for (int q = 1; q < 8; ++q) v += base[q] <= u ? 1 : 0;
    const int c = v >> 2, j = v & 3;
    const float thr = u - base[v];
    int n = 0;
    for (int b = c; b < nb; b += 2) n += cum[kBlock * b + j] <= thr ? 1 : 0;
    const int blk = c + 2 * n;
    return blk < nb ? kBlock * blk + j : -1 - v;
}

// The last topic of positive weight in lanes v, v - 1, ..., 0 (then in the
// lanes after v): the draw when rounding put u at the end of lane v. -1 only
// when every weight is 0.
inline int lastWeighted(const float* cum, int nb, int v) noexcept {
    for (int step = 0; step < 8; ++step) {
        const int lane = step <= v ? v - step : step;
        const int c = lane >> 2, j = lane & 3;
        int last = -1;
        float prev = 0.f;
        for (int b = c; b < nb; b += 2) {
            const float x = cum[kBlock * b + j];
            if (x > prev) last = kBlock * b + j;
            prev = x;
        }
        if (last >= 0) return last;
    }
    return -1;
}

// ---- the scan order (few blocks) ---------------------------------------------
//
// With at most kScanBlocks live blocks the draw follows the topics' own order,
// which needs fewer steps between one token's draw and the next's: a
// Hillis-Steele scan inside each block ((x + x shifted by one), then + shifted
// by two), a carry added block by block (cum = scan + carry, next carry =
// carry + the block's last scan), and the topic is the number of running sums
// <= u (u >= the last one: the last topic of positive weight).
inline constexpr int kScanBlocks = 8;

template <bool kMinus>
inline float scanSumsScalar(const int32_t* row, int minus, const float* h, float beta, int nb, float* cum) noexcept {
    float carry = 0.f;
    for (int b = 0; b < nb; ++b) {
        float p[kBlock];
        for (int j = 0; j < kBlock; ++j) {
            const int k = kBlock * b + j;
            const int32_t n = kMinus && k == minus ? row[k] - 1 : row[k];
            p[j] = (static_cast<float>(n) + beta) * h[k];
        }
        const float q0 = p[0] + 0.f, q1 = p[1] + p[0], q2 = p[2] + p[1], q3 = p[3] + p[2];
        const float s[kBlock] = {q0 + 0.f, q1 + 0.f, q2 + q0, q3 + q1};
        for (int j = 0; j < kBlock; ++j) cum[kBlock * b + j] = b == 0 ? s[j] : s[j] + carry;
        carry = b == 0 ? s[3] : carry + s[3];
    }
    return carry;
}

inline int scanSelectScalar(const float* cum, int nb, float u) noexcept {
    int count = 0;
    for (int k = 0; k < kBlock * nb; ++k) count += cum[k] <= u ? 1 : 0;
    return count;
}

// Topic k if its weight is positive, else the last topic of positive weight
// below it: a block's scan rounds its sums in different orders, so the sum at
// a topic of weight 0 (closed, or padding) can end one ulp above the sum
// before it and be counted. The weight is positive iff h_k > 0.
inline int lastPositive(const float* h, int k) noexcept {
    while (k > 0 && !(h[k] > 0.f)) --k;
    return k;
}

#if defined(ROST_KERNEL_SIMD)
inline v4::F exclusiveScan4(v4::F t) noexcept { return v4::scan(v4::shift1(t)); }

// The canonical sums on vectors: cum[b] per block, the bases of chain 0's
// and chain 1's lanes; returns the total.
template <bool kMinus, int KA>
ROST_KERNEL_INLINE float laneSumsSimd(const int32_t* row, int minus, const float* h, float beta, int nb,
                                      v4::F (&cum)[KA], v4::F& base0, v4::F& base1) noexcept {
    const v4::F b4 = v4::set(beta);
    const v4::I mm = v4::seti(minus);
    auto weight = [&](int b) {
        v4::I r = v4::load(row + kBlock * b);
        if constexpr (kMinus) r = v4::add(r, v4::eq(v4::iota(kBlock * b), mm));  // -1 in topic `minus`
        return v4::mul(v4::add(v4::cvt(r), b4), v4::load(h + kBlock * b));
    };
    v4::F c0 = v4::zero(), c1 = v4::zero();
    int b = 0;
    for (; b + 1 < nb; b += 2) {
        c0 = v4::add(c0, weight(b));
        cum[b] = c0;
        c1 = v4::add(c1, weight(b + 1));
        cum[b + 1] = c1;
    }
    if (b < nb) {
        c0 = v4::add(c0, weight(b));
        cum[b] = c0;
    }
    base0 = exclusiveScan4(c0);
    base1 = v4::add(v4::add(v4::last(base0), v4::last(c0)), exclusiveScan4(c1));
    return v4::first(v4::add(v4::last(base1), v4::last(c1)));
}

template <int KA>
ROST_KERNEL_INLINE int laneSelectSimd(const v4::F (&cum)[KA], v4::F base0, v4::F base1, int nb, float u) noexcept {
    const v4::F uu = v4::set(u);
    const int v = (-v4::hsum(v4::add(v4::le(base0, uu), v4::le(base1, uu))) - 1) & 7;  // base_0 = 0 <= u
    const v4::F t0 = v4::sub(uu, base0), t1 = v4::sub(uu, base1);
    v4::I n0 = v4::zeroi(), n1 = v4::zeroi();
    int b = 0;
    for (; b + 1 < nb; b += 2) {
        n0 = v4::add(n0, v4::le(cum[b], t0));
        n1 = v4::add(n1, v4::le(cum[b + 1], t1));
    }
    if (b < nb) n0 = v4::add(n0, v4::le(cum[b], t0));
    alignas(16) int32_t n[8];
    v4::store(n, n0);
    v4::store(n + 4, n1);
    const int blk = (v >> 2) - 2 * n[v];
    return blk < nb ? kBlock * blk + (v & 3) : -1 - v;
}

template <int KA>
inline int lastWeightedSimd(const v4::F (&cum)[KA], int nb, int v) noexcept {
    alignas(64) float c[kBlock * KA];
    for (int b = 0; b < nb; ++b) v4::store(c + kBlock * b, cum[b]);
    return lastWeighted(c, nb, v);
}

template <bool kMinus, int KA>
ROST_KERNEL_INLINE float scanSumsSimd(const int32_t* row, int minus, const float* h, float beta, int nb,
                                     v4::F (&cum)[KA]) noexcept {
    const v4::F b4 = v4::set(beta);
    const v4::I mm = v4::seti(minus);
    v4::F carry = v4::zero();
    if (nb < 1) __builtin_unreachable();
    for (int b = 0; b < nb; ++b) {
        v4::I r = v4::load(row + kBlock * b);
        if constexpr (kMinus) r = v4::add(r, v4::eq(v4::iota(kBlock * b), mm));
        const v4::F p = v4::scan(v4::mul(v4::add(v4::cvt(r), b4), v4::load(h + kBlock * b)));
        // (block 0's carry is zero, and x + 0 = x exactly)
        if (b == 0) {
            cum[b] = p;
            carry = v4::last(p);
        } else {
            cum[b] = v4::add(p, carry);
            carry = v4::add(carry, v4::last(p));
        }
    }
    return v4::first(carry);
}

template <int KA>
ROST_KERNEL_INLINE int scanSelectSimd(const v4::F (&cum)[KA], int nb, float u) noexcept {
    if (nb < 1) __builtin_unreachable();  // at least one topic is live
    const v4::F uu = v4::set(u);
    v4::I count = v4::le(cum[0], uu);
    for (int b = 1; b < nb; ++b) count = v4::add(count, v4::le(cum[b], uu));
    return -v4::hsum(count);
}

#endif

// The canonical sums and draw on path P from memory, for tests that compare
// the paths (the kernels below keep the sums in registers).
template <Path P>
inline float laneSums(const int32_t* row, const float* h, float beta, int nb, float* cum, float* base) noexcept {
#if defined(ROST_KERNEL_SIMD)
    if constexpr (P == Path::Simd) {
        v4::F c[kMaxBlocks], b0, b1;
        const float total = laneSumsSimd<false>(row, -1, h, beta, nb, c, b0, b1);
        for (int b = 0; b < nb; ++b) v4::store(cum + kBlock * b, c[b]);
        v4::store(base, b0);
        v4::store(base + 4, b1);
        return total;
    }
#endif
    return laneSumsScalar<false>(row, -1, h, beta, nb, cum, base);
}

template <Path P>
inline int laneSelect(const float* cum, const float* base, int nb, float u) noexcept {
#if defined(ROST_KERNEL_SIMD)
    if constexpr (P == Path::Simd) {
        v4::F c[kMaxBlocks];
        for (int b = 0; b < nb; ++b) c[b] = v4::load(cum + kBlock * b);
        const int k = laneSelectSimd(c, v4::load(base), v4::load(base + 4), nb, u);
        return k >= 0 ? k : lastWeightedSimd(c, nb, -1 - k);
    }
#endif
    const int k = laneSelectScalar(cum, base, nb, u);
    return k >= 0 ? k : lastWeighted(cum, nb, -1 - k);
}

// u = u01 * (total + the new-topic weight); the slot when u >= total with
// growth. `select(u)` is the order's draw for u < total, `last()` the last
// topic of positive weight (u at the very end by rounding).
template <int KP, typename Select, typename Last>
ROST_KERNEL_INLINE int drawFrom(const Tables& t, float total, float u01, Select select, Last last) noexcept {
    const float u = u01 * (total + freshWeight<KP>(t));
    if (u < total) return select(u);
    return KP == kGrow && t.slot < t.K ? t.slot : last();
}

// A word's topic: the sums over nb live blocks (the scan order up to
// kScanBlocks blocks, the lane order beyond), u = u01 * (total + the
// new-topic weight), and the draw (the slot when u >= total with growth).
template <int KP, Path P, bool kMinus>
ROST_KERNEL_INLINE int drawTopic(const Tables& t, const int32_t* row, int minus, const float* h, int nb,
                                 float u01) noexcept {
    constexpr int KA = KP > 0 ? KP / kBlock : kMaxBlocks;
    const bool scan = KP > 0 ? KA <= kScanBlocks : nb <= kScanBlocks;
    const int lastLane = kBlock * nb - 1;
    auto lastScan = [&] { return lastPositive(h, lastLane); };
#if defined(ROST_KERNEL_SIMD)
    if constexpr (P == Path::Simd) {
        v4::F cum[KA];
        if (scan) {
            const float total = scanSumsSimd<kMinus>(row, minus, h, t.beta, nb, cum);
            return drawFrom<KP>(
                t, total, u01, [&](float u) { return lastPositive(h, std::min(scanSelectSimd(cum, nb, u), lastLane)); },
                lastScan);
        }
        v4::F base0, base1;
        const float total = laneSumsSimd<kMinus>(row, minus, h, t.beta, nb, cum, base0, base1);
        return drawFrom<KP>(
            t, total, u01,
            [&](float u) {
                const int k = laneSelectSimd(cum, base0, base1, nb, u);
                return k >= 0 ? k : lastWeightedSimd(cum, nb, -1 - k);
            },
            [&] { return lastWeightedSimd(cum, nb, 7); });
    }
#endif
    alignas(64) float cum[kBlock * KA];
    if (scan) {
        const float total = scanSumsScalar<kMinus>(row, minus, h, t.beta, nb, cum);
        return drawFrom<KP>(
            t, total, u01, [&](float u) { return lastPositive(h, std::min(scanSelectScalar(cum, nb, u), lastLane)); },
            lastScan);
    }
    float base[8];
    const float total = laneSumsScalar<kMinus>(row, minus, h, t.beta, nb, cum, base);
    return drawFrom<KP>(
        t, total, u01,
        [&](float u) {
            const int k = laneSelectScalar(cum, base, nb, u);
            return k >= 0 ? k : lastWeighted(cum, nb, -1 - k);
        },
        [&] { return lastWeighted(cum, nb, 7); });
}

// One count of a word-topic row or of h changed. The vector path rewrites the
// whole 4-topic block with a vector store, so the next vector load of the
// block is forwarded from a store of its own width (a scalar store followed
// by a wider load of the same bytes stalls on x86 and ARM).
template <Path P, int D>
ROST_KERNEL_INLINE void addAt(int32_t* a, int k) noexcept {
#if defined(ROST_KERNEL_SIMD)
    if constexpr (P == Path::Simd) {
        const int b = k & ~(kBlock - 1);
        const v4::I m = v4::eq(v4::iota(b), v4::seti(k));  // -1 in lane k
        v4::store(a + b, D > 0 ? v4::sub(v4::load(a + b), m) : v4::add(v4::load(a + b), m));
        return;
    }
#endif
    a[k] += D;
}

template <Path P>
ROST_KERNEL_INLINE void setAt(float* a, int k, float x) noexcept {
#if defined(ROST_KERNEL_SIMD)
    if constexpr (P == Path::Simd) {
        const int b = k & ~(kBlock - 1);
        v4::store(a + b, v4::select(v4::eq(v4::iota(b), v4::seti(k)), v4::set(x), v4::load(a + b)));
        return;
    }
#endif
    a[k] = x;
}

// The 4-topic block of topic k (the value of k on the scalar path), kept so
// that a word that keeps its topic restores it with one store: the stores
// then have addresses known before the draw, so the next word's loads need
// not wait for it.
#if defined(ROST_KERNEL_SIMD)
template <Path P>
ROST_KERNEL_INLINE auto keepBlock(const float* a, int k) noexcept {
    if constexpr (P == Path::Simd)
        return v4::load(a + (k & ~(kBlock - 1)));
    else
        return a[k];
}
template <Path P>
ROST_KERNEL_INLINE auto keepBlock(const int32_t* a, int k) noexcept {
    if constexpr (P == Path::Simd)
        return v4::load(a + (k & ~(kBlock - 1)));
    else
        return a[k];
}
ROST_KERNEL_INLINE void restoreBlock(float* a, int k, v4::F x) noexcept { v4::store(a + (k & ~(kBlock - 1)), x); }
ROST_KERNEL_INLINE void restoreBlock(int32_t* a, int k, v4::I x) noexcept { v4::store(a + (k & ~(kBlock - 1)), x); }
#else
template <Path P>
ROST_KERNEL_INLINE float keepBlock(const float* a, int k) noexcept {
    return a[k];
}
template <Path P>
ROST_KERNEL_INLINE int32_t keepBlock(const int32_t* a, int k) noexcept {
    return a[k];
}
#endif
ROST_KERNEL_INLINE void restoreBlock(float* a, int k, float x) noexcept { a[k] = x; }
ROST_KERNEL_INLINE void restoreBlock(int32_t* a, int k, int32_t x) noexcept { a[k] = x; }

// ---- one cell ---------------------------------------------------------------

// Refines every word of one cell once (paper eq. 5): the word leaves its
// current topic only, a new topic is drawn from the exact conditional, and
// n_k^v, n_k, n_c^k and the neighbourhood sums nG are updated in place.
// KP is the padded K when known at compile time (0: use t.Kp; kGrow: growth).
// Path::Scalar is the reference; Path::Simd does the same float operations
// in the same order on vectors.
template <int KP, Path P, typename R>
inline void refineCellLanes(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
                            uint32_t n, R& rng) noexcept {
    const int Kp = KP > 0 ? KP : t.Kp;
    alignas(64) float h[KP > 0 ? KP : kMaxK];
    cellWeights(t.inv, nG, t.alpha, Kp, h);
    float* const inv = t.inv;
    float* const dec = t.dec;
    float* const inc = t.inc;
    for (uint32_t i = 0; i < n; ++i) {
        int32_t* row = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(Kp);
        const int z = topics[i];
        const float u01 = rng.uniformFloat();
        // Word i leaves topic z (eq. 5's -i). t.dec holds 1/(n_z - 1 + V beta),
        // so the new reciprocal is a load and the divisions run off the chain.
        const int32_t nz = --t.nk[z];
        const float invZ = leftReciprocal<KP>(t, z, nz);  // 0 when z closes (growth)
        const auto rowZ = keepBlock<P>(row, z);
        const auto hZ = keepBlock<P>(h, z);
        addAt<P, -1>(row, z);
        --nG[z];
        setAt<P>(h, z, invZ * (static_cast<float>(nG[z]) + t.alpha));
        const int nb = liveLanes<KP>(t, Kp) / kBlock;
        const int k = drawTopic<KP, P, false>(t, row, -1, h, nb, u01);
        if (k == z) {
            // Every value is restored, at addresses known before the draw.
            ++t.nk[z];
            ++nG[z];
            restoreBlock(row, z, rowZ);
            restoreBlock(h, z, hZ);
            if constexpr (KP == kGrow) {
                if (nz == 0) openTopic(t, z);  // it closed when the word left
            }
            continue;
        }
        // Word i joins topic k.
        const bool opened = KP == kGrow && t.nk[k] == 0;
        inc[z] = inv[z];
        inv[z] = invZ;
        dec[z] = reciprocal(nz - 1, t.vbeta);
        const int32_t nk = ++t.nk[k];
        const float invK = inc[k];
        dec[k] = inv[k];
        inv[k] = invK;
        inc[k] = reciprocal(nk + 1, t.vbeta);
        if (opened) dec[k] = reciprocal(nk - 1, t.vbeta);  // its inv was 0 while closed
        --nc[z];
        ++nc[k];
        topics[i] = static_cast<uint16_t>(k);
        if constexpr (KP == kGrow) {
            if (opened) openTopic(t, k);
        }
        addAt<P, 1>(row, k);
        ++nG[k];
        setAt<P>(h, k, invK * (static_cast<float>(nG[k]) + t.alpha));
    }
}

// ---- the kernels' entry points -----------------------------------------------------

// The scan order's register kernels when a cell starts with at most
// kScanBlocks live blocks, the lane kernels beyond (docs/design.md, "The
// kernel's sums"). Fixed K decides at compile time; with growth, per cell.
template <int KP>
inline bool registerKernel(const Tables& t) noexcept {
    if constexpr (KP > 0)
        return KP / kBlock <= kScanBlocks;
    else
        return liveLanes<KP>(t, t.Kp) / kBlock <= kScanBlocks;
}

// Refines every word of one cell once (paper eq. 5); path P (Path::Scalar is
// the reference, Path::Simd the same float operations on vectors).
template <int KP, Path P, typename R>
inline void refineCell(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics, uint32_t n,
                       R& rng) noexcept {
    if (registerKernel<KP>(t)) {
#if defined(ROST_KERNEL_SIMD)
        if constexpr (P == Path::Simd) {
            refineCellScanSimd<KP>(t, nG, nc, words, topics, n, rng);
            return;
        }
#endif
        refineCellScanScalar<KP>(t, nG, nc, words, topics, n, rng);
        return;
    }
    if constexpr (KP <= 0 || KP / kBlock > kScanBlocks) refineCellLanes<KP, P>(t, nG, nc, words, topics, n, rng);
}

} // namespace rost::kernel
