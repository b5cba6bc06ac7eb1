/* The sweep's NEON kernel (AArch64's Advanced SIMD): the segment filter and
 * the candidate scan of the AVX2 kernel, 8 records a step as two 4-lane
 * halves. Included by sweep.c only, beside its AVX2 functions, because it
 * works on sweep.c's own types and helpers: the record columns (lc_cols,
 * LC_PAD spare slots past the last record), the entry under test (lc_scan),
 * copy_row and emit_if_canonical. Each candidate that passes the vector
 * reject test goes to emit_if_canonical in ascending record order, as in
 * the scalar loop, so the pairs and their order are the scalar kernel's
 * byte for byte (test_determinism compares them under qemu, CI step
 * 38-arm). Advanced SIMD is part of every AArch64 CPU, so there is no run
 * time check and no target attribute (docs/encoding.md, "SIMD kernels"). */
#include <arm_neon.h>

/* One byte a lane for records r..r+7, its top bit set where the record's
 * box overlaps [lo, hi] (closed); the other bits are clear. AArch64 has no
 * movemask: the two halves' 32-bit lane masks are narrowed to one byte a
 * lane and read as one 64-bit word. */
LC_INLINE uint64_t overlap8_neon(const lc_cols *c, size_t r, int32x4_t lo0, int32x4_t lo1, int32x4_t lo2,
                                 int32x4_t hi0, int32x4_t hi1, int32x4_t hi2)
{
    uint32x4_t a = vcgtq_s32(lo0, vld1q_s32(c->hi[0] + r)), b = vcgtq_s32(lo0, vld1q_s32(c->hi[0] + r + 4));
    uint8x8_t rej;
    a = vorrq_u32(a, vcgtq_s32(vld1q_s32(c->lo[0] + r), hi0));
    b = vorrq_u32(b, vcgtq_s32(vld1q_s32(c->lo[0] + r + 4), hi0));
    a = vorrq_u32(a, vcgtq_s32(lo1, vld1q_s32(c->hi[1] + r)));
    b = vorrq_u32(b, vcgtq_s32(lo1, vld1q_s32(c->hi[1] + r + 4)));
    a = vorrq_u32(a, vcgtq_s32(vld1q_s32(c->lo[1] + r), hi1));
    b = vorrq_u32(b, vcgtq_s32(vld1q_s32(c->lo[1] + r + 4), hi1));
    a = vorrq_u32(a, vcgtq_s32(lo2, vld1q_s32(c->hi[2] + r)));
    b = vorrq_u32(b, vcgtq_s32(lo2, vld1q_s32(c->hi[2] + r + 4)));
    a = vorrq_u32(a, vcgtq_s32(vld1q_s32(c->lo[2] + r), hi2));
    b = vorrq_u32(b, vcgtq_s32(vld1q_s32(c->lo[2] + r + 4), hi2));
    rej = vmovn_u16(vcombine_u16(vmovn_u32(a), vmovn_u32(b)));
    return ~vget_lane_u64(vreinterpret_u64_u8(rej), 0) & 0x8080808080808080ull;
}

/* The lanes below `left` (1..7) of a byte-a-lane mask. */
LC_INLINE uint64_t first_lanes_neon(size_t left)
{
    return (1ull << (8 * left)) - 1u;
}

static size_t filter_neon(const lc_cols *c, size_t from, size_t to, const int32_t lo[3], const int32_t hi[3], size_t w)
{
    const int32x4_t lo0 = vdupq_n_s32(lo[0]), lo1 = vdupq_n_s32(lo[1]), lo2 = vdupq_n_s32(lo[2]);
    const int32x4_t hi0 = vdupq_n_s32(hi[0]), hi1 = vdupq_n_s32(hi[1]), hi2 = vdupq_n_s32(hi[2]);
    size_t r;
    /* Reads may run up to 7 records past `to` (padding or rows this call
       already wrote): those lanes are masked off. */
    for (r = from; r < to; r += 8) {
        uint64_t m = overlap8_neon(c, r, lo0, lo1, lo2, hi0, hi1, hi2);
        if (to - r < 8)
            m &= first_lanes_neon(to - r);
        while (m) {
            copy_row(c, r + ((size_t)__builtin_ctzll(m) >> 3), w++);
            m &= m - 1;
        }
    }
    return w;
}

static size_t scan_neon(const lc_scan *sc, size_t first, size_t end, uint32_t *pairs, size_t np, uint64_t *exact)
{
    const int32x4_t lo0 = vdupq_n_s32(sc->lo[0]), lo1 = vdupq_n_s32(sc->lo[1]), lo2 = vdupq_n_s32(sc->lo[2]);
    const int32x4_t hi0 = vdupq_n_s32(sc->hi[0]), hi1 = vdupq_n_s32(sc->hi[1]), hi2 = vdupq_n_s32(sc->hi[2]);
    size_t r;
    /* Past `end` lie padding or stale rows: masked off. */
    for (r = first; r < end; r += 8) {
        uint64_t m = overlap8_neon(&sc->c, r, lo0, lo1, lo2, hi0, hi1, hi2);
        if (end - r < 8)
            m &= first_lanes_neon(end - r);
        while (m) {
            np = emit_if_canonical(sc, r + ((size_t)__builtin_ctzll(m) >> 3), pairs, np, exact);
            m &= m - 1;
        }
    }
    return np;
}
