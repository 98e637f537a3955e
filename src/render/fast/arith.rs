//! The fast arithmetic's words: [`Pf`] (a 32-bit mantissa and an
//! exponent, for the radiometric products), the reciprocal and reciprocal
//! square root from seeds and a Newton step ([`recip`], `rsqrt_norm`,
//! `rsqrt_fine`), square roots, and the 32 × 32 → 64-bit products and
//! shifts the line loops are written in (`wmul`, `umul`, …; on the M0,
//! which has no such product, from 16-bit halves). Each states its formats
//! and error; the tests below check them against exact arithmetic.

use crate::num::scalar::shr_sat;
use crate::num::{clz32, clz64, umul16, umul16_words};
use crate::scene::Q;
use crate::target::M0;
use core::num::NonZeroU32;

/// The cap of a pixel's sum before vignetting (S15 DN): 2³² DN, so that a
/// capped sum times any `cos⁴α` (≥ 2⁻¹⁸) still saturates the pixel.
pub const SUM_CAP: u64 = 1 << 47;

/// Hits have `t` in `(0, T_MAX]` (a saturated `t` is `T_MAX`), below
/// `NO_HIT`.
pub(super) const T_MAX: i32 = i32::MAX - 1;

/// `m · 2^e`: a normalized mantissa (top bit set) or zero, for the
/// radiometric products, whose range no fixed format covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Pf {
    pub(super) m: u32,
    pub(super) e: i32,
}

impl Pf {
    /// `v · 2^e`, normalized.
    #[inline(always)]
    pub fn new(v: u64, e: i32) -> Pf {
        if v == 0 {
            return Pf::default();
        }
        let (m, z) = norm_top(v);
        Pf {
            m,
            e: e + 32 - z as i32,
        }
    }

    /// `v · 2^e`, normalized (one 32-bit count of leading zeros).
    #[inline(always)]
    pub fn new32(v: u32, e: i32) -> Pf {
        if v == 0 {
            return Pf::default();
        }
        let z = clz32(v);
        Pf {
            m: v << z,
            e: e - z as i32,
        }
    }

    /// An I32F32 value (negative values as 0).
    pub fn of_q(q: Q) -> Pf {
        Pf::new(q.to_bits().max(0) as u64, -32)
    }

    /// `floor(value · 2^frac)` for `frac` ≤ 15, capped at [`SUM_CAP`].
    #[inline(always)]
    pub fn to_sum(self, frac: i32) -> u64 {
        let s = self.e + frac;
        if self.m == 0 || s <= -32 {
            0
        } else if s < 0 {
            (self.m >> -s) as u64
        } else if s <= 15 {
            (self.m as u64) << s
        } else {
            SUM_CAP
        }
    }

    /// `(self · o).to_sum(frac)` for `frac` ≤ 15, from the product's top 32
    /// bits (low by under one unit of `2^-frac`), without normalizing it.
    #[inline(always)]
    pub fn mul_to_sum(self, o: Pf, frac: i32) -> u64 {
        // p in [2^30, 2^32) (or 0); value · 2^frac = p · 2^s.
        let p = (umul_px(self.m, o.m) >> 32) as u32;
        let s = self.e + o.e + frac + 32;
        if s <= 0 {
            // 32-bit shifts: the common case.
            p.checked_shr(s.unsigned_abs()).unwrap_or(0) as u64
        } else if s <= 15 {
            // ≤ 2^47 = SUM_CAP. (`shl64`: in words on the M0, whose
            // 64-bit shift by a variable amount is a library call.)
            shl64(p as u64, s.unsigned_abs())
        } else if p == 0 {
            // A zero factor (an albedo of 0, a lobe that vanished) with a
            // large exponent.
            0
        } else {
            SUM_CAP
        }
    }

    /// The value as f64 (exact), for tests.
    #[cfg(test)]
    pub fn to_f64(self) -> f64 {
        libm::ldexp(self.m as f64, self.e)
    }
}

impl Pf {
    /// The product of two nonzero values with its mantissa rounded up (≥
    /// the exact product; [`Pf`]'s `*` rounds down): bounds from above,
    /// once a frame ([`lobe_below`](super::lobe_below)).
    pub(super) fn mul_up(self, o: Pf) -> Pf {
        let p = umul(self.m, o.m);
        let n = (p >> 63) as u32 ^ 1; // 1: one shift left
        let p = p << n;
        let e = self.e + o.e + 32 - n as i32;
        match ((p >> 32) as u32).checked_add(u32::from(p as u32 != 0)) {
            Some(m) => Pf { m, e },
            None => Pf { m: 1 << 31, e: e + 1 },
        }
    }
}

impl core::ops::Mul for Pf {
    type Output = Pf;

    /// The product (mantissa truncated to 32 bits: ≤ 2⁻³¹ relative).
    #[inline(always)]
    fn mul(self, o: Pf) -> Pf {
        // Two normalized mantissas: the product is in [2^62, 2^64), one
        // shift from normalized (or 0).
        let p = umul(self.m, o.m);
        let (hi, lo) = ((p >> 32) as u32, p as u32);
        let n = (hi >> 31) ^ 1; // 1: one shift left
        Pf {
            m: (hi << n) | ((lo >> 31) & n),
            e: self.e + o.e + 32 - n as i32,
        }
    }
}

/// Seeds for [`recip`]: `1/v` in Q2.14 at the middle of each of 1 024
/// intervals of `v` in `[½, 1)` (within 2⁻¹¹).
// Indexing in a constant: an index out of range fails the build.
#[allow(clippy::indexing_slicing)]
pub(super) const RECIP_SEED: [u16; 1024] = {
    let mut t = [0u16; 1024];
    let mut i = 0;
    while i < 1024 {
        // 2^14 / ((1024 + i + ½)/2048) = 2^26 / (2049 + 2i), rounded.
        let d = 2049 + 2 * i as u32;
        t[i] = ((1u32 << 26) + d / 2).wrapping_div(d) as u16;
        i += 1;
    }
    t
};

/// `1/d` for `d > 0` as `(r, z)` with `1/d ≈ r · 2^(z − 62)`, `r` in
/// `(2³⁰, 2³¹)` (below 2³¹: `tests`), relative error < 2⁻²¹: one Newton step from a 1 024-entry
/// seed, two 32 × 32 products, no division.
#[inline(always)]
pub fn recip(d: NonZeroU32) -> (u32, u32) {
    let z = clz32(d.get());
    let dn = d.get() << z; // v = dn / 2^32 in [½, 1)
                           // dn >> 21 is in [1024, 2048): its low ten bits index the seed
                           // (taken as (dn << 1) >> 22: no mask, a constant on the M0).
    let idx = ((dn << 1) >> 22) as usize;
    // r = seed 2^16: both products are by the 16-bit seed.
    let seed = RECIP_SEED.get(idx).copied().unwrap_or(1 << 15);
    // r (2 − v r), Q2.30.
    let vr = if M0 {
        (umul_h(dn, seed) >> 16) as u32
    } else {
        // The product's high word: no shift on the M3.
        ((dn as u64 * ((seed as u64) << 16)) >> 32) as u32
    };
    let f = (1u32 << 31).wrapping_sub(vr);
    let r = if M0 {
        mul_h_words::<14>(f, seed)
    } else {
        (umul_h(f, seed) >> 14) as u32
    };
    (r, z)
}

/// `⌊a b / 2^S⌋` (`S ≤ 16`) for a result below 2³², in 32-bit words on
/// the M0: `a = a_h 2¹⁶ + a_l` gives `a_h b 2^(16−S) + ⌊a_l b / 2^S⌋`
/// (the first term an integer), two 16 × 16-bit products and no 64-bit
/// sum (`umul_h`'s took 4 instructions more in `recip`).
#[inline(always)]
pub(super) fn mul_h_words<const S: u32>(a: u32, b: u16) -> u32 {
    (((a >> 16) * b as u32) << (16 - S)) + (((a & 0xFFFF) * b as u32) >> S)
}

/// `(v · r) · 2^-sh` for `r` < 2³¹ (a [`recip`] value) and `|v| ≤ T_MAX`, a plane's `t`
/// ([`Ray::plane_t`](super::Ray::plane_t)): the product over 2³¹ (below `|v|`) shifted right,
/// or left with saturation to `±T_MAX`, so that negating it is exact and
/// leaves it within `T_MAX` (a plane's `dist`, S24, lies within 8 U of the
/// camera and the aperture, below 2²⁸; a parallel ray's numerator `dist −
/// n·o` within 72 U, below 2³⁰·⁵). The same values as saturating to the
/// i32 limits and then clamping to `±T_MAX` (`tests`).
#[inline(always)]
pub(super) fn mul_shr_t(v: i32, r: u32, sh: u32) -> i32 {
    if sh >= 31 {
        return mul_shr_right(v, r, sh);
    }
    // |v r| < 2^59: the quotient by 2^31, below |v|, fits.
    let q = (smul_r(v, r) >> 31) as i32;
    // Left by 31 − sh ≥ 1: below 2^31 − 1 in magnitude, or saturated.
    let l = 31 - sh;
    if clz32(q.unsigned_abs()) > l {
        q << l
    } else {
        let s = q >> 31;
        (T_MAX ^ s).wrapping_sub(s)
    }
}

/// `(v · r) · 2^-sh` for `r` < 2³¹ (a [`recip`] value) and `sh ≥ 31`:
/// the product over 2³¹ (below `|v|` in magnitude), then a 32-bit right
/// shift.
#[inline(always)]
pub(super) fn mul_shr_right(v: i32, r: u32, sh: u32) -> i32 {
    ((smul_r(v, r) >> 31) as i32) >> sh.saturating_sub(31).min(31)
}

/// `v · r` for `r` < 2³¹ (every [`recip`] value: `tests`), exact: on the
/// M3 and M4F one signed product (`smul_u`'s i32 × u32 took two more
/// instructions), on the M0 [`smul_u`]'s.
#[inline(always)]
pub(super) fn smul_r(v: i32, r: u32) -> i64 {
    if M0 {
        smul_u(v, r)
    } else {
        v as i64 * (r as i32) as i64
    }
}

/// Seeds for [`rsqrt_norm`]: `1/√((i + ½)/1024)` in Q2.14 for `i` in
/// 256..1024 (within 2⁻¹⁰, so that one Newton step reaches 2⁻¹⁹).
#[allow(clippy::indexing_slicing)]
pub(super) const SEED: [u16; 768] = {
    let mut t = [0u16; 768];
    let mut i = 0;
    while i < 768 {
        // y² (2(i+256)+1)/2048 = 1 in Q2.14: y = √(2^39 / (2i + 513)).
        t[i] = ((1u128 << 39) / (2 * i as u128 + 513)).isqrt() as u16;
        i += 1;
    }
    t
};

/// [`SEED`] indexed by `m >> 22` itself (`m < 2³⁰`, never given: `2¹⁴`):
/// an index in bounds without a test (a table of 2 KB for 1.5 KB;
/// low-light 6.6 M3 instructions a pixel fewer, the M0's standard scene
/// 3.4).
#[allow(clippy::indexing_slicing)]
const SEED_BY_TOP: [u16; 1024] = {
    let mut t = [1u16 << 14; 1024];
    let mut i = 0;
    while i < 768 {
        t[i + 256] = SEED[i];
        i += 1;
    }
    t
};

/// For `x ≠ 0`: `(m, y, z)` with `m` the top word of `x << z` in `[2³⁰,
/// 2³²)`, `z` even, and `y ≈ 1/√(m/2³²)` in Q2.30 (in `(1, 2]`; relative
/// error < 2⁻¹⁹): one Newton step from a 768-entry seed, three products.
#[inline(always)]
pub(super) fn rsqrt_norm(x: u64) -> (u32, u32, u32) {
    let z = clz64(x) & !1;
    let m32 = (shl64(x, z) >> 32) as u32;
    (m32, rsqrt_top(m32), z)
}

/// [`rsqrt_norm`]'s `y` for its `m` (in `[2³⁰, 2³²)`).
#[inline(always)]
pub(super) fn rsqrt_top(m32: u32) -> u32 {
    // (m32 < 2^30, never given, reads `SEED_BY_TOP`'s filler.) y = seed
    // 2^16: y² and the last product are by the 16-bit seed.
    let top = (m32 >> 22) as usize;
    // (In bounds: no test.)
    let seed = SEED_BY_TOP.get(top & 1023).copied().unwrap_or(1 << 14);
    // y (3 − m y²) / 2: y² in Q3.29, m y² in Q2.30, 32 × 32 products.
    // (m y² < 3·2^30 for every m and its seed: `tests`. The M0 keeps the
    // saturating form, which measured 3 instructions a pixel fewer there.)
    if M0 {
        newton_words(m32, seed)
    } else {
        // The same values from the products' high words: m y² = ⌊m · 4
        // seed² / 2^32⌋ (every seed is below 2^15 − 32: 4 seed² fits a
        // word), and ⌊f seed / 2^15⌋ = ⌊f · 2^17 seed / 2^32⌋.
        let hi = |a: u32, b: u32| (umul(a, b) >> 32) as u32;
        let my2 = hi(m32, (seed as u32 * seed as u32) << 2);
        hi((3u32 << 30).wrapping_sub(my2), (seed as u32) << 17)
    }
}

/// [`rsqrt_top`]'s Newton step on the M0, in 32-bit words: `m y²` the
/// high word of the product by `4 seed²` ([`umul16_words`]'s), and `⌊f
/// seed / 2¹⁵⌋` by [`mul_h_words`]: the M3's values (`tests`).
#[inline(always)]
pub(super) fn newton_words(m32: u32, seed: u16) -> u32 {
    let seed = seed as u32;
    let my2 = (umul16_words(m32, (seed * seed) << 2) >> 32) as u32;
    mul_h_words::<15>((3u32 << 30).saturating_sub(my2), seed as u16)
}

/// [`rsqrt_norm`] refined by a second Newton step in 64-bit arithmetic:
/// `(y, z)` with `y ≈ 1/√(m/2⁶⁴)` in Q2.30 within 2⁻²⁹ relative — for the
/// unit vectors of the specular lobe, whose exponent multiplies their
/// error (`s` up to 1 000).
#[inline]
pub(super) fn rsqrt_fine(x: u64) -> (u32, u32) {
    let (_, y, z) = rsqrt_norm(x);
    rsqrt_refine(x, y, z)
}

/// [`rsqrt_fine`] from [`rsqrt_norm`]'s `y` and `z` of the same `x`, for a
/// caller that has them already (a lit pixel's `1/r` and the lobe's `l̂`).
#[inline]
pub(super) fn rsqrt_refine(x: u64, y: u32, z: u32) -> (u32, u32) {
    let m = shl64(x, z);
    // y (3 − m y²) / 2: y² Q4.60, m y² Q4.60 (m/2^64 < 1), then Q2.30.
    let y2 = umul(y, y);
    let my2 = mul_hi_64(m, y2);
    let f = (3u64 << 60).saturating_sub(my2);
    // y f < 2^93: ⌊y f / 2^61⌋ < 2^32.
    let r = if M0 {
        mul_shr61_words(y, f)
    } else {
        ((y as u128 * f as u128) >> 61) as u64
    };
    (r as u32, z)
}

/// `⌊y · f / 2⁶¹⌋` for `f < 2⁶²` from two 32 × 32-bit products:
/// `(y f_hi + ⌊y f_lo / 2³²⌋) / 2²⁹`, nested floors of integers
/// ([`rsqrt_fine`] on the M0).
#[inline(always)]
pub(super) fn mul_shr61_words(y: u32, f: u64) -> u64 {
    let (fh, fl) = ((f >> 32) as u32, f as u32);
    // y f_hi < 2^62: the sum stays below 2^63.
    (umul(y, fh) + (umul(y, fl) >> 32)) >> 29
}

/// `⌊a · b / 2⁶⁴⌋` for u64 `a`, `b`, exactly: on the M0 from four
/// 32 × 32-bit products (two where `b` is a u32's: the others fold away),
/// as its 128-bit product is library calls; elsewhere the 128-bit
/// product (on the M3 the words measured more).
#[inline(always)]
pub(super) fn mul_hi_64(a: u64, b: u64) -> u64 {
    if M0 {
        mul_hi_64_words(a, b)
    } else {
        ((a as u128 * b as u128) >> 64) as u64
    }
}

/// [`mul_hi_64`] from four 32 × 32-bit products (the M0's; compiled
/// everywhere, so that the tests check it).
#[inline(always)]
pub(super) fn mul_hi_64_words(a: u64, b: u64) -> u64 {
    let (ah, al) = ((a >> 32) as u32, a as u32);
    let (bh, bl) = ((b >> 32) as u32, b as u32);
    let mid = umul(ah, bl) as u128 + umul(al, bh) as u128 + (umul(al, bl) >> 32) as u128;
    umul(ah, bh) + (mid >> 32) as u64
}

/// `(n·l)/r³` in U⁻² for `n·l` in S48 U with `0 < n·l ≤ |n| |l|`
/// (`n` a unit vector in S30) and `r² = l·l > 0` in S36 U²: one
/// normalization of `r²` serves both (`(n·l) 2^(z/2)` lies below 2⁶³).
/// Relative error: `(1/r)³`'s 3 · 2⁻¹⁹ and the truncation of `n·l` to its
/// top word, 2⁻²¹ where `n̂·l̂ ≥ 2⁻⁸` (`2⁻²⁹ / n̂·l̂`).
#[inline]
#[cfg(test)]
pub fn cos_over_r2(nl: u64, r2: u64) -> Pf {
    let (_, y, z) = rsqrt_norm(r2);
    cos_over_r3(nl, y, z)
}

/// [`cos_over_r2`] from [`rsqrt_norm`]`(r²)`'s `y`, `z` (which the lobe
/// shares).
#[inline(always)]
pub(super) fn cos_over_r3(nl: u64, y: u32, z: u32) -> Pf {
    // 1/r³ = y3 2^(3z/2 − 70) with y² in Q3.29, y³ in Q5.28; n·l's top
    // word q: n·l ≈ q 2^(32 − z/2) 2⁻⁴⁸. Product: q y3 2^(z − 86).
    let q = top_shl(nl, z / 2);
    let y2 = (umul(y, y) >> 31) as u32;
    let y3 = (umul(y2, y) >> 31) as u32;
    Pf::new(umul(q, y3), z as i32 - 86)
}

/// `√x` for `x < 2⁵⁶` (S48 → S24), within 2⁻²⁸ relative and one unit:
/// `x · (1/√x)` from [`rsqrt_fine`].
#[inline(always)]
pub(super) fn sqrt_fine(x: u64) -> i32 {
    if x == 0 {
        return 0;
    }
    let (y, z) = rsqrt_fine(x);
    // m = x 2^z in [2^62, 2^64); √(m/2^64) 2^30 = m y / 2^64 (y in Q2.30);
    // √x = √(m/2^64) 2^(32 − z/2): a right shift by z/2 − 2 (z ≥ 8).
    let m = shl64(x, z);
    // s30 < 2^31 (m < 2^64, y ≤ 2^31): a word, shifted by at most 29.
    let s30 = mul_hi_64(m, y as u64).min(u32::MAX as u64) as u32;
    (s30 >> (z / 2).saturating_sub(2)).min(i32::MAX as u32) as i32
}

/// `√(x · 2⁻⁴⁴)` in S22 for `x < 2⁶²`, within 2⁻¹⁹ relative and one unit.
#[inline]
pub(super) fn sqrt_s44_to_s22(x: u64) -> i32 {
    if x == 0 {
        return 0;
    }
    let (m, y, z) = rsqrt_norm(x);
    // √(m/2^32) = (m/2^32) · y in Q0.32; √x_real = that · 2^((20 − z)/2).
    // (A word's shift: z/2 ≤ 31, and no 64-bit shift by a variable amount,
    // a library call on the M0.)
    let s = (umul(m, y) >> 30).min(u32::MAX as u64) as u32;
    (s >> (z / 2)).min(i32::MAX as u32) as i32
}

/// `[f(a₀, b₀), f(a₁, b₁), f(a₂, b₂)]`.
#[inline(always)]
pub(super) fn zip3<A: Copy, B: Copy, R>(a: [A; 3], b: [B; 3], f: impl Fn(A, B) -> R) -> [R; 3] {
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2])]
}

/// `a.map(f)` written out: in a pixel's code `array::map` was a loop
/// through the stack (five M3 instructions a component; in the `compact`
/// build too, where the camera's spheres-specular measured 425.4 against
/// 409.0 on the M3, 1 652.3 against 1 642.7 on the M0, whose flash it
/// took 260 B less).
#[inline(always)]
pub(super) fn map3<A: Copy, R>(a: [A; 3], f: impl Fn(A) -> R) -> [R; 3] {
    [f(a[0]), f(a[1]), f(a[2])]
}

/// An array of three `u64`s, `$a` — in the M0's `compact` build copied
/// element by element: the same array, but not a `memcpy` call, which a
/// copy of 24 B is at its camera's opt-level "z" (the library's word loop,
/// about 45 instructions; a hit pixel took several). Elsewhere `$a` as it
/// is: there the element-wise copy, through a reference, moved the default
/// M3 firmware's code (spheres-specular 392.6 against 378.3 instructions a
/// pixel).
macro_rules! copy3 {
    ($a:expr) => {
        if $crate::target::M0_COMPACT {
            let a: &[u64; 3] = &$a;
            [a[0], a[1], a[2]]
        } else {
            $a
        }
    };
}
pub(super) use copy3;

// Products and bit counts. Cortex-M0 (ARMv6-M, the Arm target without
// atomics) has only a 32 × 32 → 32 multiply and no count of leading
// zeros: the compiler's 64-bit product there is a 64 × 64 library call and
// its `leading_zeros` a library loop. On the M0 these are 16 × 16-bit
// products and a byte table instead; elsewhere the one instruction. The
// results are the same bits on every target.

/// `a · b`, exact (i32 × i32 → i64).
#[inline(always)]
#[cfg(not(hilcam_m0))]
pub(super) fn wmul(a: i32, b: i32) -> i64 {
    a as i64 * b as i64
}

/// [`wmul`] on the Cortex-M0: out of line where it is used in the sphere
/// test and the rare paths (inlined everywhere, the registers it needs made
/// the standard scene slower: 1 500 against 1 428 instructions a pixel);
/// [`wmul_px`] inlines it where every pixel needs it.
#[inline(never)]
#[cfg(hilcam_m0)]
pub(super) fn wmul(a: i32, b: i32) -> i64 {
    wmul16(a, b)
}

/// [`wmul`] by a component `c` of a frame's axis, which may be 0: on the
/// Cortex-M0, where a product is four 16-bit ones, 0 without the product
/// where it is (the same value, as `closed_w` takes a normal's); elsewhere
/// the product, whose test measured more there.
#[inline(always)]
pub(super) fn wmul_axis(v: i32, c: i32) -> i64 {
    if M0 && c == 0 {
        0
    } else {
        wmul(v, c)
    }
}

/// [`wmul`] inlined on the Cortex-M0 too: for the products every pixel
/// makes (the call costs the M0 a third of the product).
#[inline(always)]
pub(super) fn wmul_px(a: i32, b: i32) -> i64 {
    if M0 {
        wmul16(a, b)
    } else {
        a as i64 * b as i64
    }
}

/// `a · b`, exact (u32 × u32 → u64).
#[inline(always)]
pub(super) fn umul(a: u32, b: u32) -> u64 {
    if M0 {
        umul16(a, b)
    } else {
        a as u64 * b as u64
    }
}

/// [`umul`] with the M0's product in 32-bit words ([`umul16_words`]): at
/// the sites where that measured cheaper on the M0 (`rsqrt_top`'s `m y²`,
/// [`Pf::mul_to_sum`], and [`vignette_dn`](super::vignette_dn)'s rare
/// case beside [`round_c4_words`](super::round_c4_words)).
/// In [`cube_over`](super::cube_over) and [`cos_over_r3`] it cost more (the registers
/// around them), so those keep [`umul`].
#[inline(always)]
pub(super) fn umul_px(a: u32, b: u32) -> u64 {
    if M0 {
        umul16_words(a, b)
    } else {
        umul(a, b)
    }
}

/// `a · b` for a 16-bit `b` (u32 × u16 → u64).
#[inline(always)]
pub(super) fn umul_h(a: u32, b: u16) -> u64 {
    if M0 {
        umul_h16(a, b)
    } else {
        a as u64 * b as u64
    }
}

/// The saturating product of raw 32-bit fixed-point values with `F`
/// fractional bits, rounded down (as `saturating_mul`): one `SMULL` and a
/// check that the high word is the sign extension of the result.
#[inline(always)]
pub(super) fn mul32<const F: u32>(a: i32, b: i32) -> i32 {
    shr_sat::<F>(wmul_px(a, b))
}

/// `a²`, exact (three 16 × 16-bit products on the M0).
#[inline(always)]
pub(super) fn wsq(a: i32) -> u64 {
    if M0 {
        usq16(a)
    } else {
        (a as i64 * a as i64) as u64
    }
}

/// `a · b` for an unsigned `b` (i32 × u32 → i64; `|a b| ≤ 2⁶³`).
#[inline(always)]
pub(super) fn smul_u(a: i32, b: u32) -> i64 {
    if M0 {
        smul_u16(a, b)
    } else {
        a as i64 * b as i64
    }
}

/// `v << z` for `z` < 64 (bits shifted out are lost).
#[inline(always)]
pub(super) fn shl64(v: u64, z: u32) -> u64 {
    if M0 {
        shl64_words(v, z)
    } else {
        v << z
    }
}

/// `v >> s` (arithmetic) for `s` < 64.
#[inline(always)]
pub(super) fn sar64(v: i64, s: u32) -> i64 {
    if M0 {
        sar64_words(v, s)
    } else {
        v >> s
    }
}

/// The low word of [`sar64`]`(v, s)` (`s < 64`), for a shifted value
/// known to fit i32: no saturation ([`sat32`]).
#[inline(always)]
pub(super) fn sar64_low(v: i64, s: u32) -> i32 {
    sar64(v, s) as i32
}

/// [`sar64_low`] for a shift `s` below 32, in 32-bit words: `(lo >> s) |
/// (hi << (32 − s))` (the left shift in two steps, so that `s = 0` is
/// exact). The same value as `sar64_low` for every `s < 32`, without the
/// test for 32 and more that a 64-bit shift by a variable amount takes
/// (`tests::m0_products_and_counts_are_exact`).
#[inline(always)]
pub(super) fn sar64_low_lt32(v: i64, s: u32) -> i32 {
    let (hi, lo) = ((v >> 32) as u32, v as u32);
    let s = s & 31;
    ((lo >> s) | ((hi << 1) << (31 - s))) as i32
}

/// For `v ≠ 0`: the top word of `v << z` and `z`, the count of `v`'s
/// leading zeros, in 32-bit words: [`Pf::new`]'s normalization, which the
/// 64-bit count and shift by a variable amount took the M3 twelve
/// instructions. ([`rsqrt_norm`]'s, through an even-count form of this,
/// cost the M3's wide-vignetting 8 instructions a pixel more, though it
/// runs no [`rsqrt_norm`]: the shading's registers.)
#[inline(always)]
pub(super) fn norm_top(v: u64) -> (u32, u32) {
    norm_top_by::<false>(v)
}

/// For `v ≠ 0`: [`rsqrt_norm`]'s `(m, z)` (`z` the even count at most
/// `v`'s leading zeros, `m` the top word of `v << z`) in 32-bit words, for
/// the noise's `σ` ([`sigma_z16`](super::sigma_z16): the 64-bit count and shift cost
/// low-light 5 M3 instructions a pixel more) and the closed plane's `1/|q|`
/// ([`cube_over`](super::cube_over)). In `rsqrt_norm` itself, for every caller, it cost
/// spheres-specular 3.6 more (and wide-vignetting 8 at an earlier commit,
/// [`norm_top`]).
#[inline(always)]
pub(super) fn norm_top_even(v: u64) -> (u32, u32) {
    norm_top_by::<true>(v)
}

/// [`norm_top`] (`EVEN` false) and [`norm_top_even`] (`EVEN` true): the
/// count rounded down to even where `EVEN`.
#[inline(always)]
pub(super) fn norm_top_by<const EVEN: bool>(v: u64) -> (u32, u32) {
    let mask = if EVEN { !1 } else { !0 };
    let (hi, lo) = ((v >> 32) as u32, v as u32);
    if hi != 0 {
        let z = clz32(hi) & mask;
        ((hi << z) | ((lo >> 1) >> (31 - z)), z)
    } else {
        // lo ≠ 0: z < 32.
        let z = clz32(lo) & 31 & mask;
        (lo << z, z + 32)
    }
}

/// The top word of `v << s` for `s` < 32 (bits shifted out are lost).
#[inline(always)]
pub(super) fn top_shl(v: u64, s: u32) -> u32 {
    let (hi, lo, s) = ((v >> 32) as u32, v as u32, s & 31);
    (hi << s) | ((lo >> 1) >> (31 - s))
}

// The M0's versions, compiled everywhere so that the tests check them.

/// `a · b` from 16 × 16-bit products: `a = a_h 2¹⁶ + a_l` (`a_h` signed,
/// `a_l` unsigned 16 bits), the same for `b`; the cross terms fit `i32`.
/// In 32-bit words: each cross term's `c 2¹⁶` added to the low word with
/// its carry, `c >> 16` to the high word (modulo 2⁶⁴, where `|a b| ≤ 2⁶²`
/// is exact). (The cross terms summed in 64 bits first took 4 more
/// instructions a product on the M0, a spill among them.)
#[inline(always)]
pub(super) fn wmul16(a: i32, b: i32) -> i64 {
    let (ah, al) = (a >> 16, a & 0xFFFF);
    let (bh, bl) = (b >> 16, b & 0xFFFF);
    let (c1, c2) = (ah * bl, al * bh);
    let (lo, k1) = (al as u32 * bl as u32).overflowing_add((c1 as u32) << 16);
    let (lo, k2) = lo.overflowing_add((c2 as u32) << 16);
    let hi = (ah * bh)
        .wrapping_add(c1 >> 16)
        .wrapping_add(c2 >> 16)
        .wrapping_add(k1 as i32 + k2 as i32);
    (((hi as u32 as u64) << 32) | lo as u64) as i64
}

/// [`umul_h`] from two 32-bit products.
#[inline(always)]
pub(super) fn umul_h16(a: u32, b: u16) -> u64 {
    ((((a >> 16) * b as u32) as u64) << 16) + ((a & 0xFFFF) * b as u32) as u64
}

/// [`wsq`] from `|a| = h 2¹⁶ + l`: `h² 2³² + h l 2¹⁷ + l²`.
#[inline(always)]
pub(super) fn usq16(a: i32) -> u64 {
    let u = a.unsigned_abs();
    let (h, l) = (u >> 16, u & 0xFFFF);
    (((h * h) as u64) << 32) + (((h * l) as u64) << 17) + (l * l) as u64
}

/// [`smul_u`] from the unsigned product of `|a|` and `b`.
#[inline(always)]
pub(super) fn smul_u16(a: i32, b: u32) -> i64 {
    let p = umul(a.unsigned_abs(), b) as i64;
    if a < 0 {
        p.wrapping_neg()
    } else {
        p
    }
}

/// [`sar64`] in 32-bit words (the M0's is a library call).
#[inline(always)]
pub(super) fn sar64_words(v: i64, s: u32) -> i64 {
    let (hi, lo) = ((v >> 32) as i32, v as u32);
    if s >= 32 {
        // s − 32 < 32 (s < 64).
        (hi >> ((s - 32) & 31)) as i64
    } else {
        // hi << (32 − s) in two shifts, each below 32 (0 for s = 0).
        let low = (lo >> s) | (((hi as u32) << 1) << (31 - s));
        (((hi >> s) as i64) << 32) | low as i64
    }
}

/// [`shl64`] in 32-bit words (the M0's 64-bit shift is a library call).
#[inline(always)]
pub(super) fn shl64_words(v: u64, z: u32) -> u64 {
    let (hi, lo) = ((v >> 32) as u32, v as u32);
    if z >= 32 {
        // z − 32 < 32 (z < 64).
        ((lo << ((z - 32) & 31)) as u64) << 32
    } else {
        // lo >> (32 − z) in two shifts, each below 32 (0 for z = 0).
        let top = (hi << z) | ((lo >> 1) >> (31 - z));
        ((top as u64) << 32) | (lo << z) as u64
    }
}

/// `v` saturated to i32: the high word says whether it fits (it is the
/// low word's sign extension), without two 64-bit comparisons.
#[inline(always)]
pub(super) fn sat32(v: i64) -> i32 {
    let (hi, lo) = ((v >> 32) as i32, v as i32);
    if hi == lo >> 31 {
        lo
    } else if hi < 0 {
        i32::MIN
    } else {
        i32::MAX
    }
}

/// A length in U, S24 / S18, from metres (I32F32), saturating. Per frame:
/// out of line (inlined at its many uses it cost the M0 8 KB of flash).
#[inline(never)]
pub(super) fn len_s(q: Q, unit_exp: i32, frac: i32) -> i32 {
    // q_bits 2^-32 m = q_bits 2^(-32 - e) U → S(frac): shift by frac - 32 - e.
    let sh = frac - 32 - unit_exp;
    let b = q.to_bits() as i128;
    let v = if sh >= 0 {
        b << sh.min(64)
    } else {
        b >> (-sh).min(127)
    };
    v.clamp(i32::MIN as i128, i32::MAX as i128) as i32
}

/// A unit-vector component (I32F32) in S30.
pub(super) fn unit_s30(q: Q) -> i32 {
    sat32(q.to_bits() >> 2)
}

/// `1/v` for a positive length `v` (I32F32 m) in U⁻¹ as a mantissa and the
/// right shift that turns `w · m` (w in S18) into S30 — or `None` if the
/// length is below `2^-10 U`.
pub(super) fn recip_len(v: Q, unit_exp: i32) -> Option<(u32, u32)> {
    // v in U, S24 (v ≥ 2^-10 U ⇒ ≥ 2^14).
    let s = len_s(v, unit_exp, 24);
    if s < 1 << 14 {
        return None;
    }
    // 1/v = 2^54 / s in S30, as m 2^e; w (S18) · m 2^e in S30 is
    // w · m · 2^(e + 12): a right shift by −(e + 12).
    let p = Pf::new((1u64 << 54).checked_div(s as u64)?, -30);
    let sh = -(p.e + 12);
    (0..64).contains(&sh).then_some((p.m, sh as u32))
}

/// `1/n_z` of a unit vector in S30 as [`recip`] gives it (`(0, 0)` for
/// `n_z = 0`: parallel rays never meet that plane).
pub(super) fn recip_z(n: [i32; 3]) -> (u32, u32) {
    NonZeroU32::new(n[2].unsigned_abs()).map_or((0, 0), recip)
}

/// `v · 2^e` metres in I32F32 (saturating).
pub(super) fn shl_q(v: i64, e: i32) -> Q {
    let b = v << 32;
    Q::from_bits(if e >= 0 {
        b.checked_shl(e as u32)
            .filter(|x| x >> e == b)
            .unwrap_or(i64::MAX)
    } else {
        b >> (-e).min(63)
    })
}

/// `√v` for an I32F32 area (m²) in metres.
pub(super) fn isqrt_q(v: Q) -> Q {
    let s = (v.to_bits().max(0) as u128) << 32;
    Q::from_bits(crate::num::isqrt_u128(s).min(i64::MAX as u128) as i64)
}

#[cfg(test)]
mod tests {
    #[test]
    fn mul32_equals_the_fixed_crate() {
        use fixed::types::{I16F16, I6F26};
        let mut next = crate::num::scalar::spread_i32();
        for _ in 0..200_000 {
            let (a, b) = (next(), next());
            assert_eq!(
                super::mul32::<16>(a, b),
                I16F16::from_bits(a)
                    .saturating_mul(I16F16::from_bits(b))
                    .to_bits()
            );
            assert_eq!(
                super::mul32::<26>(a, b),
                I6F26::from_bits(a).saturating_mul(I6F26::from_bits(b)).to_bits()
            );
        }
    }

    /// The Cortex-M0's products and counts of leading zeros, and the
    /// 32-bit normalizations every target uses, are the exact ones, at the
    /// extremes and on a spread of values.
    #[test]
    fn m0_products_and_counts_are_exact() {
        let edges = [
            i32::MIN,
            i32::MIN + 1,
            -65_537,
            -65_536,
            -65_535,
            -1,
            0,
            1,
            65_535,
            65_536,
            i32::MAX,
        ];
        let mut x = 0x9E37_79B9u32;
        let mut values: [i32; 64] = [0; 64];
        for v in values.iter_mut() {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *v = x as i32;
        }
        for a in edges.iter().chain(values.iter()) {
            for b in edges.iter().chain(values.iter()) {
                assert_eq!(super::wmul16(*a, *b), *a as i64 * *b as i64, "{a} x {b}");
                let (a, b) = (*a as u32, *b as u32);
                assert_eq!(crate::num::umul16(a, b), a as u64 * b as u64, "{a} x {b}");
                assert_eq!(crate::num::umul16_words(a, b), a as u64 * b as u64, "{a} x {b}");
                let (wa, wb) = ((a as u64) << 32 | b as u64, (b as u64) << 32 | a as u64);
                assert_eq!(
                    crate::num::mul64_words(wa, wb),
                    wa.wrapping_mul(wb),
                    "{wa} x {wb}"
                );
                assert_eq!(super::smul_u16(a as i32, b), a as i32 as i64 * b as i64);
                assert_eq!(super::usq16(a as i32), (a as i32 as i64 * a as i32 as i64) as u64);
                assert_eq!(super::umul_h16(a, b as u16), a as u64 * (b as u16) as u64);
                for z in [0, 1, b % 32, b % 64, 31, 32, 33, 63] {
                    let v = (a as u64) << 32 | b as u64;
                    assert_eq!(super::shl64_words(v, z), v << z, "{v} << {z}");
                    assert_eq!(super::sar64_words(v as i64, z), v as i64 >> z, "{v} >> {z}");
                    if z < 32 {
                        let want = (v as i64 >> z) as i32;
                        assert_eq!(super::sar64_low_lt32(v as i64, z), want, "{v} >> {z}");
                    }
                }
                let w = (a as u64) << 32 | b as u64;
                for v in [w, b as u64, w >> (b % 64)] {
                    for s in [0, 1, b % 32, 31] {
                        assert_eq!(super::top_shl(v, s), ((v << s) >> 32) as u32, "{v} << {s}");
                    }
                    if v != 0 {
                        let z = v.leading_zeros();
                        assert_eq!(super::norm_top(v), (((v << z) >> 32) as u32, z), "{v}");
                    }
                }
            }
        }
    }
}
