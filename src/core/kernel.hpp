#pragma once

// The collapsed Gibbs refinement kernel (paper eq. 5), with a scalar reference
// and a 4-lane SIMD path (SSE2 on x86-64, NEON on aarch64 and ARMv7+NEON).
// Internal to the library (not installed): the public headers name only its
// types (rost/kernel_types.hpp).
//
// Determinism across paths and architectures: both paths perform exactly the
// same IEEE binary32 operations in the same order, so they draw the same
// topic for the same random number:
//   * weights  p_k = ((n_k^v + beta) * inv_k) * (n_G^k + alpha), no fused
//     multiply-add (the core is compiled with -ffp-contract=off);
//   * inv_k = 1 / (n_k + V beta) by IEEE division, cached per topic and
//     recomputed only for the two topics a token changes;
//   * a canonical prefix sum: a Hillis-Steele scan inside each block of 4
//     topics, then a running carry added block by block;
//   * the new topic is the number of prefix sums <= u, u = r * total.
// 4-lane blocks are what SSE2, NEON and a scalar loop all do natively; wider
// AVX registers would need a different summation tree (and so different
// samples), and at K = 16 the scan, not the arithmetic, bounds the speed.

#include <cstdint>

#include "rost/kernel_types.hpp"
#include "rost/random.hpp"

#if defined(__SSE2__) && !defined(ROST_FORCE_SCALAR)
#include <emmintrin.h>
#define ROST_SIMD_SSE2 1
#elif (defined(__ARM_NEON) || defined(__ARM_NEON__)) && !defined(ROST_FORCE_SCALAR)
#include <arm_neon.h>
#define ROST_SIMD_NEON 1
#endif

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

// The drawn topic from the number of prefix sums <= u (closed topics weigh 0,
// so they are never drawn this way): with growth, all of the open topics'
// sums <= u means a new topic, the slot (while there is room).
template <int KP>
inline int drawnTopic(const Tables& t, int count) noexcept {
    if constexpr (KP != kGrow) {
        return count < t.K ? count : t.K - 1;
    } else {
        return count < t.hi ? count : (t.slot < t.K ? t.slot : t.hi - 1);
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

// ---- 4-lane vector wrapper used by the register-resident kernel --------------

namespace v4 {
#if defined(ROST_SIMD_SSE2)
using F = __m128;
using I = __m128i;
inline F load(const float* p) noexcept { return _mm_loadu_ps(p); }
inline I load(const int32_t* p) noexcept { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
inline void store(float* p, F x) noexcept { _mm_storeu_ps(p, x); }
inline void store(int32_t* p, I x) noexcept { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), x); }
inline F set(float x) noexcept { return _mm_set1_ps(x); }
inline I seti(int32_t x) noexcept { return _mm_set1_epi32(x); }
inline I iota(int32_t b) noexcept { return _mm_setr_epi32(b, b + 1, b + 2, b + 3); }
inline I niota(int32_t b) noexcept { return _mm_setr_epi32(-b, -b - 1, -b - 2, -b - 3); }
inline F add(F a, F b) noexcept { return _mm_add_ps(a, b); }
inline F mul(F a, F b) noexcept { return _mm_mul_ps(a, b); }
inline I add(I a, I b) noexcept { return _mm_add_epi32(a, b); }
inline I sub(I a, I b) noexcept { return _mm_sub_epi32(a, b); }
inline F cvt(I a) noexcept { return _mm_cvtepi32_ps(a); }
inline I eq(I a, I b) noexcept { return _mm_cmpeq_epi32(a, b); }  // all ones where equal
inline I le(F a, F b) noexcept { return _mm_castps_si128(_mm_cmple_ps(a, b)); }
inline F select(I m, F a, F b) noexcept {
    const F mf = _mm_castsi128_ps(m);
    return _mm_or_ps(_mm_and_ps(mf, a), _mm_andnot_ps(mf, b));
}
inline F scan(F p) noexcept {
    p = _mm_add_ps(p, _mm_castsi128_ps(_mm_slli_si128(_mm_castps_si128(p), 4)));
    return _mm_add_ps(p, _mm_castsi128_ps(_mm_slli_si128(_mm_castps_si128(p), 8)));
}
inline F last(F p) noexcept { return _mm_shuffle_ps(p, p, _MM_SHUFFLE(3, 3, 3, 3)); }
inline float first(F p) noexcept { return _mm_cvtss_f32(p); }
inline int32_t hsum(I a) noexcept {
    a = _mm_add_epi32(a, _mm_shuffle_epi32(a, _MM_SHUFFLE(1, 0, 3, 2)));
    a = _mm_add_epi32(a, _mm_shuffle_epi32(a, _MM_SHUFFLE(2, 3, 0, 1)));
    return _mm_cvtsi128_si32(a);
}
inline I hbroadcast(I a) noexcept {  // every lane = sum of the four
    a = _mm_add_epi32(a, _mm_shuffle_epi32(a, _MM_SHUFFLE(1, 0, 3, 2)));
    return _mm_add_epi32(a, _mm_shuffle_epi32(a, _MM_SHUFFLE(2, 3, 0, 1)));
}
inline int32_t firsti(I a) noexcept { return _mm_cvtsi128_si32(a); }
#elif defined(ROST_SIMD_NEON)
using F = float32x4_t;
using I = int32x4_t;
inline F load(const float* p) noexcept { return vld1q_f32(p); }
inline I load(const int32_t* p) noexcept { return vld1q_s32(p); }
inline void store(float* p, F x) noexcept { vst1q_f32(p, x); }
inline void store(int32_t* p, I x) noexcept { vst1q_s32(p, x); }
inline F set(float x) noexcept { return vdupq_n_f32(x); }
inline I seti(int32_t x) noexcept { return vdupq_n_s32(x); }
inline I iota(int32_t b) noexcept {
    const int32_t v[4] = {b, b + 1, b + 2, b + 3};
    return vld1q_s32(v);
}
inline I niota(int32_t b) noexcept {
    const int32_t v[4] = {-b, -b - 1, -b - 2, -b - 3};
    return vld1q_s32(v);
}
inline F add(F a, F b) noexcept { return vaddq_f32(a, b); }
inline F mul(F a, F b) noexcept { return vmulq_f32(a, b); }
inline I add(I a, I b) noexcept { return vaddq_s32(a, b); }
inline I sub(I a, I b) noexcept { return vsubq_s32(a, b); }
inline F cvt(I a) noexcept { return vcvtq_f32_s32(a); }
inline I eq(I a, I b) noexcept { return vreinterpretq_s32_u32(vceqq_s32(a, b)); }
inline I le(F a, F b) noexcept { return vreinterpretq_s32_u32(vcleq_f32(a, b)); }
inline F select(I m, F a, F b) noexcept { return vbslq_f32(vreinterpretq_u32_s32(m), a, b); }
inline F scan(F p) noexcept {
    const F zero = vdupq_n_f32(0.f);
    p = vaddq_f32(p, vextq_f32(zero, p, 3));
    return vaddq_f32(p, vextq_f32(zero, p, 2));
}
inline F last(F p) noexcept { return vdupq_n_f32(vgetq_lane_f32(p, 3)); }
inline float first(F p) noexcept { return vgetq_lane_f32(p, 0); }
inline int32_t hsum(I a) noexcept {
    const int32x2_t h = vadd_s32(vget_low_s32(a), vget_high_s32(a));
    return vget_lane_s32(vpadd_s32(h, h), 0);
}
inline I hbroadcast(I a) noexcept {  // every lane = sum of the four
    const int32x2_t h = vadd_s32(vget_low_s32(a), vget_high_s32(a));
    const int32x2_t s = vpadd_s32(h, h);
    return vcombine_s32(s, s);
}
inline int32_t firsti(I a) noexcept { return vgetq_lane_s32(a, 0); }
#endif
} // namespace v4

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

// ---- one cell ---------------------------------------------------------------

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
inline void refineCellScalar(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
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
inline void refineCellSimd(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
                           uint32_t n, R& rng) noexcept {
    constexpr int kMaxBlocks = 256;
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
}
#endif

template <int KP, Path P, typename R>
inline void refineCell(Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics, uint32_t n,
                       R& rng) noexcept {
#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
    if constexpr (P == Path::Simd) {
        refineCellSimd<KP>(t, nG, nc, words, topics, n, rng);
        return;
    }
#endif
    refineCellScalar<KP>(t, nG, nc, words, topics, n, rng);
}

// ---- one cell against frozen word-topic counts (a round of a parallel window) --

// As refineCell, except that n_k^v, n_k and the reciprocals are only read:
// during a round they hold every word at z0[i], its label when the round
// began, so word i leaves topic z0[i] there, and leaves its current topic in
// the cell's own counts (nG, nc), which the task owns and updates in place.
// The new labels reach n_k^v and n_k when the round's changes are merged.
// Same float operations, in the same order, as the live kernel.
template <int KP, typename R>
inline void refineCellFrozenScalar(const Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words,
                                   uint16_t* topics, const uint16_t* z0, uint32_t n, R& rng) noexcept {
    const int Kp = KP > 0 ? KP : t.Kp;
    alignas(64) float cum[KP > 0 ? KP : 1024];
    alignas(64) int32_t row[KP > 0 ? KP : 1024];
    alignas(64) float inv[KP > 0 ? KP : 1024];
    for (int k = 0; k < Kp; ++k) inv[k] = t.inv[k];
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
        const int k = drawnTopic<KP>(t, count);
        ++nG[k];
        if (k != z) {
            --nc[z];
            ++nc[k];
            topics[i] = static_cast<uint16_t>(k);
        }
    }
}

#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
template <int KP, typename R>
inline void refineCellFrozenSimd(const Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words,
                                 uint16_t* topics, const uint16_t* z0, uint32_t n, R& rng) noexcept {
    constexpr int kMaxBlocks = 256;
    const int Kp = KP > 0 ? KP : t.Kp;
    const int nb = Kp / kBlock;
    constexpr int kArr = KP > 0 ? KP / kBlock : kMaxBlocks;
    v4::I g[kArr];
    v4::F iv[kArr], cum[kArr];
    for (int b = 0; b < nb; ++b) {
        g[b] = v4::load(nG + kBlock * b);
        iv[b] = v4::load(t.inv + kBlock * b);
    }
    const v4::F beta = v4::set(t.beta), alpha = v4::set(t.alpha);
    for (uint32_t i = 0; i < n; ++i) {
        const int32_t* row = t.nkv + static_cast<std::size_t>(words[i]) * static_cast<std::size_t>(Kp);
        const int a = z0[i], z = topics[i];
        const float u01 = rng.uniformFloat();
        const v4::I aa = v4::seti(a), zz = v4::seti(z);
        const v4::F va = v4::set(KP == kGrow && t.nk[a] == 1 ? 0.f : t.dec[a]);
        v4::F carry = v4::set(0.f);
        const int nbL = liveLanes<KP>(t, Kp) / kBlock;
        if (nbL < 1) __builtin_unreachable();  // at least one topic is active
        for (int b = 0; b < nbL; ++b) {
            const v4::I lanes = v4::iota(kBlock * b);
            const v4::I ma = v4::eq(lanes, aa);
            const v4::I r = v4::add(v4::load(row + kBlock * b), ma);
            g[b] = v4::add(g[b], v4::eq(lanes, zz));
            const v4::F ivb = v4::select(ma, va, iv[b]);
            const v4::F p =
                v4::scan(v4::mul(v4::mul(v4::add(v4::cvt(r), beta), ivb), v4::add(v4::cvt(g[b]), alpha)));
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
        v4::I count = v4::le(cum[0], uu);
        for (int b = 1; b < nbL; ++b) count = v4::add(count, v4::le(cum[b], uu));
        count = v4::hbroadcast(count);
        int k = -v4::firsti(count);
        if constexpr (KP == kGrow) {
            k = drawnTopic<KP>(t, k);
            count = v4::seti(-k);
        }
        for (int b = 0; b < nbL; ++b) g[b] = v4::sub(g[b], v4::eq(v4::niota(kBlock * b), count));
        if (k != z) {
            --nc[z];
            ++nc[k];
            topics[i] = static_cast<uint16_t>(k);
        }
    }
    for (int b = 0; b < nb; ++b) v4::store(nG + kBlock * b, g[b]);
}
#endif

template <int KP, Path P, typename R>
inline void refineCellFrozen(const Tables& t, int32_t* nG, int32_t* nc, const uint32_t* words, uint16_t* topics,
                             const uint16_t* z0, uint32_t n, R& rng) noexcept {
#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
    if constexpr (P == Path::Simd) {
        refineCellFrozenSimd<KP>(t, nG, nc, words, topics, z0, n, rng);
        return;
    }
#endif
    refineCellFrozenScalar<KP>(t, nG, nc, words, topics, z0, n, rng);
}

} // namespace rost::kernel
