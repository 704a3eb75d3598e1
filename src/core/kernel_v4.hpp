#pragma once

// The 4-lane vector wrapper of the Gibbs kernel (src/core/kernel.hpp): SSE2
// on x86-64, NEON on aarch64 and ARMv7+NEON, nothing (the scalar path only)
// elsewhere or with ROST_FORCE_SCALAR. Internal to the library.

#include <cstdint>

#if defined(__SSE2__) && !defined(ROST_FORCE_SCALAR)
#include <emmintrin.h>
#define ROST_SIMD_SSE2 1
#elif (defined(__ARM_NEON) || defined(__ARM_NEON__)) && !defined(ROST_FORCE_SCALAR)
#include <arm_neon.h>
#define ROST_SIMD_NEON 1
#endif

namespace rost::kernel::v4 {

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
inline F sub(F a, F b) noexcept { return _mm_sub_ps(a, b); }
inline F mul(F a, F b) noexcept { return _mm_mul_ps(a, b); }
inline F zero() noexcept { return _mm_setzero_ps(); }
inline I zeroi() noexcept { return _mm_setzero_si128(); }
inline F shift1(F p) noexcept {  // (0, p0, p1, p2)
    return _mm_castsi128_ps(_mm_slli_si128(_mm_castps_si128(p), 4));
}
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
// The number of set lanes in NB blocks of compare masks (each lane all ones
// or zero): the blocks packed to bytes and a movemask per 16 lanes. Where the
// set lanes are a prefix (as where cumulative sums <= u nearly always are),
// their number is the first clear bit; else (sums that round one ulp down in
// a later lane) the bits are counted. Fewer operations than adding the masks
// and summing across lanes, and the same count.
#define ROST_V4_COUNT_SET 1
template <int NB>
inline int countSet(const I* m) noexcept {
    static_assert(NB == 4 || NB == 8);
    unsigned bits = 0;
    for (int q = 0; q < NB; q += 4) {
        const I bytes = _mm_packs_epi16(_mm_packs_epi32(m[q], m[q + 1]), _mm_packs_epi32(m[q + 2], m[q + 3]));
        bits |= static_cast<unsigned>(_mm_movemask_epi8(bytes)) << (4 * q);
    }
    if ((bits & (bits + 1)) == 0) [[likely]]
        return __builtin_ctz(~bits);
    return __builtin_popcount(bits);
}
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
inline F sub(F a, F b) noexcept { return vsubq_f32(a, b); }
inline F mul(F a, F b) noexcept { return vmulq_f32(a, b); }
inline F zero() noexcept { return vdupq_n_f32(0.f); }
inline I zeroi() noexcept { return vdupq_n_s32(0); }
inline F shift1(F p) noexcept { return vextq_f32(vdupq_n_f32(0.f), p, 3); }  // (0, p0, p1, p2)
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
#if defined(__aarch64__)
    return vaddvq_s32(a);  // one across-lanes add
#else
    const int32x2_t h = vadd_s32(vget_low_s32(a), vget_high_s32(a));
    return vget_lane_s32(vpadd_s32(h, h), 0);
#endif
}
inline I hbroadcast(I a) noexcept {  // every lane = sum of the four
    const int32x2_t h = vadd_s32(vget_low_s32(a), vget_high_s32(a));
    const int32x2_t s = vpadd_s32(h, h);
    return vcombine_s32(s, s);
}
inline int32_t firsti(I a) noexcept { return vgetq_lane_s32(a, 0); }
#if defined(__aarch64__) && (defined(__clang__) || __GNUC__ > 10 || (__GNUC__ == 10 && __GNUC_MINOR__ >= 3))
// Four blocks (64 bytes) in one instruction (ld1 of four registers), where
// block by block GCC emits three. (GCC has the x4 loads for aarch64 from
// 10.3; older compilers take the block loads.)
#define ROST_V4_LOAD4 1
inline void load4(const int32_t* p, I* x) noexcept {
    const int32x4x4_t v = vld1q_s32_x4(p);
    x[0] = v.val[0];
    x[1] = v.val[1];
    x[2] = v.val[2];
    x[3] = v.val[3];
}
inline void load4(const float* p, F* x) noexcept {
    const float32x4x4_t v = vld1q_f32_x4(p);
    x[0] = v.val[0];
    x[1] = v.val[1];
    x[2] = v.val[2];
    x[3] = v.val[3];
}
#endif
#endif
} // namespace rost::kernel::v4

#if defined(ROST_SIMD_SSE2) || defined(ROST_SIMD_NEON)
#define ROST_KERNEL_SIMD 1
#endif
