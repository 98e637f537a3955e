//! The per-pixel number type: the one thing the speed/accuracy variants of
//! the renderer change.
//!
//! The renderer ([`crate::render::Frame`]), shading, vignetting and the
//! distortion table are generic over [`Scalar`]. Everything per frame
//! (poses, tables, folded constants) is prepared in the wide formats of
//! [`crate::num`] and converted once; only the per-pixel arithmetic runs in
//! the scalar type.
//!
//! | type | bits | range | resolution | note |
//! |---|---|---|---|---|
//! | [`I32F32`] | 64 | ±2.1·10⁹ | 2.3·10⁻¹⁰ | the wide arithmetic: the planner's fallback where the fast one's formats do not hold a scene |
//! | `f32` | 32 | ±3.4·10³⁸ | 24-bit mantissa | soft-float on M0/M3, the FPU on M4F; `sqrt` through `libm` |
//!
//! (The 32-bit single-format types I16F16 and I12F20 were measured and
//! dropped: dominated by the fast arithmetic, `crate::render::fast`, on every
//! scene.) The fixed type saturates (never wraps); `f32` overflows to infinity, and
//! a non-finite value quantizes to a clamped DN (NaN to 0) — nothing panics.

use core::num::{NonZeroU32, NonZeroU64};

use crate::target::M0;

pub use fixed::types::I32F32;

/// A number the per-pixel pipeline runs in.
pub trait Scalar: Copy + PartialOrd + core::fmt::Debug + Send + Sync {
    /// Name used in variant names (`"i32f32"`, `"f32"`).
    const NAME: &'static str;
    /// Zero.
    const ZERO: Self;
    /// One.
    const ONE: Self;
    /// One half.
    const HALF: Self;
    /// The largest value.
    const MAX: Self;
    /// Converts from I32F32, saturating.
    fn from_q(q: I32F32) -> Self;
    /// Converts to I32F32, saturating (non-finite floats: NaN to 0).
    fn to_q(self) -> I32F32;
    /// An integer, saturating.
    fn from_int(i: i32) -> Self;
    /// The value as f64 (exact), for analysis on the host.
    fn to_f64(self) -> f64;
    /// `bits / 2^frac` (a table entry), rounded to nearest.
    fn from_fixed_bits(bits: i32, frac: u32) -> Self;
    /// Sum (saturating).
    fn add(self, o: Self) -> Self;
    /// Difference (saturating).
    fn sub(self, o: Self) -> Self;
    /// Product (saturating).
    fn mul(self, o: Self) -> Self;
    /// Quotient; `None` for a zero divisor or an overflow.
    fn div(self, o: Self) -> Option<Self>;
    /// Square root; `None` for a negative argument.
    fn sqrt(self) -> Option<Self>;
    /// Absolute value (saturating).
    fn abs(self) -> Self;
    /// Negation (saturating).
    fn neg(self) -> Self;
    /// The largest integer not above `self`, saturated to `i64` (NaN: 0).
    fn floor_int(self) -> i64;
    /// The Phong lobe `max(0, min(1, x))ⁿ` in whatever form
    /// [`Scalar::scale_lobe`] takes.
    type Lobe: Copy;
    /// `max(0, min(1, x))ⁿ`, by squaring.
    fn lobe(x: Self, n: u16) -> Self::Lobe;
    /// `k` times a lobe.
    fn scale_lobe(k: Self, lobe: Self::Lobe) -> Self;
}

/// `max(0, min(1, x))ⁿ` by squaring, in `S` itself.
#[inline]
fn powi_clamped<S: Scalar>(x: S, mut n: u16) -> S {
    let mut base = if x > S::ONE {
        S::ONE
    } else if x > S::ZERO {
        x
    } else {
        S::ZERO
    };
    let mut acc = S::ONE;
    while n > 0 {
        if n & 1 == 1 {
            acc = acc.mul(base);
        }
        base = base.mul(base);
        n >>= 1;
    }
    acc
}

/// Saturating I32F32 product. Kept out of line: inlined at every use it made
/// each pixel loop 25 KB on Cortex-M (the 64-bit product with its saturation
/// checks is long there).
///
/// Magnitudes are multiplied as 32 × 32 → 64-bit products (one `UMULL`
/// each on Cortex-M3/M4) summed in 64 bits, rather than through the
/// library's signed 128-bit multiply; where a factor is below 1 (the
/// common case) two products suffice. The result equals `saturating_mul`'s
/// (rounded down), in fewer M3 instructions than the 128-bit sums.
#[inline(never)]
fn mul_q(a: I32F32, b: I32F32) -> I32F32 {
    let (x, y) = (a.to_bits(), b.to_bits());
    // On the M0, whose products are 16-bit ones, a zero factor (an
    // axis-aligned normal's or axis's components) returns at once. On the
    // M3 the test cost the wide calibration scenes more than it saved.
    if M0 && (x == 0 || y == 0) {
        return I32F32::ZERO;
    }
    let neg = (x < 0) != (y < 0);
    let (ux, uy) = (x.unsigned_abs(), y.unsigned_abs());
    let (xh, xl, yh, yl) = (ux >> 32, ux & 0xFFFF_FFFF, uy >> 32, uy & 0xFFFF_FFFF);
    // 32 × 32 → 64-bit products: on the M0 four 16-bit ones (the library's
    // 64-bit multiply is a call that multiplies 64 by 64 bits).
    let mul = |a: u64, b: u64| {
        if M0 {
            crate::num::umul16(a as u32, b as u32)
        } else {
            a * b
        }
    };
    let ll = mul(xl, yl);
    // |a·b| / 2^32 = xh·yh·2^32 + xh·yl + xl·yh + ll/2^32, with the low 32
    // bits of ll as the fraction below; None where it reaches 2^64.
    let r = if xh == 0 || yh == 0 {
        // A factor below 1 (the common case): one cross product, the sum
        // below 2^63 (xh, yh ≤ 2^31, and xl = 0 where xh = 2^31). On the
        // M0 that one alone, and none where both are below 1 (on the M3 two
        // `UMULL`s cost less than the choice).
        let cross = if M0 {
            let (h, l) = if yh == 0 { (xh, yl) } else { (yh, xl) };
            if h == 0 {
                0
            } else {
                mul(h, l)
            }
        } else {
            mul(xh, yl) + mul(xl, yh)
        };
        Some(cross + (ll >> 32))
    } else {
        let hh = mul(xh, yh);
        // hh ≥ 2^32 would put the sum past 2^64.
        (hh >> 32 == 0)
            .then_some(hh << 32)
            .and_then(|r| r.checked_add(mul(xh, yl)))
            .and_then(|r| r.checked_add(mul(xl, yh)))
            .and_then(|r| r.checked_add(ll >> 32))
    };
    let frac = ll & 0xFFFF_FFFF != 0;
    match r {
        // floor(−|p|) = −ceil(|p|), down to −2^63.
        Some(r) if neg && (r < 1 << 63 || (r == 1 << 63 && !frac)) => {
            I32F32::from_bits((r + frac as u64).wrapping_neg() as i64)
        }
        Some(r) if !neg && r < 1 << 63 => I32F32::from_bits(r as i64),
        _ if neg => I32F32::MIN,
        _ => I32F32::MAX,
    }
}

/// I32F32 quotient, equal to `checked_div`'s (`(a 2³²) / b` rounded toward
/// zero; `None` for a zero divisor or a quotient outside I32F32). Out of
/// line, as [`mul_q`].
///
/// The library divides the 128-bit `a 2³²` by `b`, which on Cortex-M is a
/// bit-by-bit loop (~1 300 instructions: there is no 128-bit division
/// routine, so the compiler expands one). On magnitudes `n`, `d` this is
/// `⌊n 2³² / d⌋ = ⌊n / d⌋ 2³² + ⌊r 2³² / d⌋` (`r = n mod d`): two 64-bit
/// divisions, and for `d ≥ 2³²` an estimate of the second from `d`'s top
/// 32 bits, at most two too large (Knuth's normalized digit estimate),
/// corrected exactly. A 32-bit divisor's divisions, and the estimate, are
/// 64 by 32 bits ([`div_64_32`]): on the M3/M4F two `UDIV`s each rather
/// than the library's 64-bit routine.
#[inline(never)]
fn div_q(a: I32F32, b: I32F32) -> Option<I32F32> {
    let (x, y) = (a.to_bits(), b.to_bits());
    let (n, d) = (x.unsigned_abs(), y.unsigned_abs());
    if d == 0 {
        return None;
    }
    let (hi, lo) = if let Some(d32) = u32::try_from(d).ok().and_then(NonZeroU32::new) {
        // r < d < 2³²: r 2³² over d fits 32 bits.
        let (hi, r) = div_rem_64_32(n, d32);
        (hi, div_64_32(r, 0, d32).0 as u64)
    } else {
        let (hi, r) = (n / d, n % d);
        // Normalized: dn's top bit set, rn < dn. The estimate from the top
        // 32 bits of dn is at most 2 above ⌊rn 2³² / dn⌋ (< 2³²).
        let s = d.leading_zeros();
        let (dn, rn) = (d << s, r << s);
        let (rh, dh) = ((rn >> 32) as u32, (dn >> 32) as u32);
        // (dh ≥ 2³¹: never zero.)
        let mut q = match NonZeroU32::new(dh) {
            Some(dh) if rh < dh.get() => div_64_32(rh, rn as u32, dh).0,
            _ => u32::MAX,
        } as u64;
        let t = (rn as u128) << 32;
        let mut p = q as u128 * dn as u128;
        while p > t {
            q -= 1;
            p -= dn as u128;
        }
        (hi, q)
    };
    if hi > 1 << 31 {
        return None;
    }
    // |quotient| ≤ 2⁶³ + 2³² − 1: within I32F32 below 2⁶³, and at −2⁶³.
    let m = (hi << 32) | lo;
    match ((x < 0) != (y < 0), m) {
        (false, m) if m < 1 << 63 => Some(I32F32::from_bits(m as i64)),
        (true, m) if m <= 1 << 63 => Some(I32F32::from_bits((m as i64).wrapping_neg())),
        _ => None,
    }
}

/// Whether 32-bit division is one instruction (`UDIV`, ARMv7-M) while the
/// 64-bit one is the library's routine: then [`div_64_32`] divides by
/// 16-bit digits; elsewhere (the host; the M0, whose 32-bit division is a
/// routine too) the 64-bit division is used. The same quotients.
const UDIV32: bool = cfg!(target_arch = "arm") && !M0;

/// `n / d` and `n mod d` for a 32-bit `d > 0`.
#[inline(always)]
fn div_rem_64_32(n: u64, d: NonZeroU32) -> (u64, u32) {
    if UDIV32 {
        let (nh, nl) = ((n >> 32) as u32, n as u32);
        let (qh, rh) = (nh / d, nh % d);
        let (ql, r) = div_64_32(rh, nl, d);
        (((qh as u64) << 32) | ql as u64, r)
    } else {
        let d = NonZeroU64::from(d);
        (n / d, (n % d) as u32)
    }
}

/// `(u1 2³² + u0) / v` and its remainder for `u1 < v` (the quotient fits
/// 32 bits): with [`UDIV32`], long division by two 16-bit digits, each
/// estimated from `v`'s top digit and corrected (Knuth's algorithm D, as
/// in Hacker's Delight's `divlu`); else the 64-bit division.
#[inline(always)]
fn div_64_32(u1: u32, u0: u32, v: NonZeroU32) -> (u32, u32) {
    if !UDIV32 {
        let (n, v) = (((u1 as u64) << 32) | u0 as u64, NonZeroU64::from(v));
        return ((n / v) as u32, (n % v) as u32);
    }
    div_64_32_digits(u1, u0, v)
}

/// [`div_64_32`] by 16-bit digits (compiled everywhere: the tests check
/// it). Out of line: one copy for [`div_q`]'s three divisions (inlined, a
/// little faster for more flash).
#[inline(never)]
fn div_64_32_digits(u1: u32, u0: u32, v: NonZeroU32) -> (u32, u32) {
    const B: u32 = 1 << 16;
    // Normalized: v's top bit set, so its top digit vh is not zero.
    let s = v.leading_zeros();
    let v = v.get() << s;
    let (vh, vl) = (NonZeroU32::new(v >> 16).unwrap_or(NonZeroU32::MIN), v & 0xFFFF);
    // u 2^s: its top word (u1 < v keeps it below v 2^s) and low digits.
    let un32 = (u1 << s) | ((u0 >> 1) >> (31 - s));
    let un10 = u0 << s;
    let (un1, un0) = (un10 >> 16, un10 & 0xFFFF);
    // A digit from a partial remainder `u` (< v B) and the next digit `un`:
    // ⌊u / vh⌋ is at most 2 too large; corrected against vl.
    let digit = |u: u32, un: u32| {
        let mut q = u / vh;
        let mut rhat = u - q * vh.get();
        while q >= B || q * vl > ((rhat << 16) | un) {
            q -= 1;
            rhat += vh.get();
            if rhat >= B {
                break;
            }
        }
        q
    };
    let q1 = digit(un32, un1);
    let un21 = (un32 << 16).wrapping_add(un1).wrapping_sub(q1.wrapping_mul(v));
    let q0 = digit(un21, un0);
    let r = (un21 << 16).wrapping_add(un0).wrapping_sub(q0.wrapping_mul(v)) >> s;
    ((q1 << 16) | q0, r)
}

/// One, with 63 fractional bits.
const ONE63: u64 = 1 << 63;

#[inline(always)]
fn mul63(a: u64, b: u64) -> u64 {
    ((a as u128 * b as u128 + (1u128 << 62)) >> 63) as u64
}

/// `x^n` for `x ∈ [0, 1]` (clamped), by squaring, as a fraction with 63
/// fractional bits: a Phong lobe of 10⁻⁶ keeps 10⁻¹³ relative, where I32F32
/// would keep only 10⁻⁴.
pub(crate) fn powi63(x: I32F32, mut n: u16) -> u64 {
    let mut base = (x.to_bits().clamp(0, 1 << 32) as u64) << 31;
    let mut acc = ONE63;
    while n > 0 {
        if n & 1 == 1 {
            acc = mul63(acc, base);
        }
        base = mul63(base, base);
        n >>= 1;
    }
    acc
}

/// The wide arithmetic in I32F32: saturating, products and quotients
/// rounded once (`mul_q`, `div_q`), the lobe a 63-bit fraction.
impl Scalar for I32F32 {
    const NAME: &'static str = "i32f32";
    const ZERO: Self = I32F32::ZERO;
    const ONE: Self = I32F32::ONE;
    const HALF: Self = I32F32::from_bits(1 << 31);
    const MAX: Self = I32F32::MAX;
    #[inline(always)]
    fn from_q(q: I32F32) -> Self {
        I32F32::saturating_from_num(q)
    }
    #[inline(always)]
    fn to_q(self) -> I32F32 {
        I32F32::saturating_from_num(self)
    }
    #[inline(always)]
    fn from_int(i: i32) -> Self {
        I32F32::saturating_from_num(i)
    }
    fn to_f64(self) -> f64 {
        crate::num::to_f64(self)
    }
    #[inline(always)]
    fn from_fixed_bits(bits: i32, frac: u32) -> Self {
        // Both shifts are by less than 64; the table entry has at
        // most 30 fractional bits.
        let b = bits as i64;
        let v = if frac >= 32 {
            let s = frac - 32;
            if s == 0 {
                b
            } else {
                (b + (1 << (s - 1))) >> s
            }
        } else {
            b << (32 - frac)
        };
        I32F32::from_bits(v)
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.saturating_add(o)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.saturating_sub(o)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        mul_q(self, o)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Option<Self> {
        div_q(self, o)
    }
    // Out of line: the bit-by-bit root is long, and inlined at each
    // use it grew every pixel loop.
    #[inline(never)]
    fn sqrt(self) -> Option<Self> {
        self.checked_sqrt()
    }
    #[inline(always)]
    fn abs(self) -> Self {
        self.saturating_abs()
    }
    #[inline(always)]
    fn neg(self) -> Self {
        self.saturating_neg()
    }
    #[inline(always)]
    fn floor_int(self) -> i64 {
        self.to_num::<i64>()
    }
    type Lobe = u64;
    #[inline(always)]
    fn lobe(x: Self, n: u16) -> Self::Lobe {
        powi63(x, n)
    }
    #[inline(always)]
    fn scale_lobe(k: Self, lobe: Self::Lobe) -> Self {
        scale63(k, lobe)
    }
}

/// `p >> SH` saturated to i32 (`SH` in 1..=32): the high word says whether
/// it fits, without a 64-bit compare.
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
#[inline(always)]
pub(crate) fn shr_sat<const SH: u32>(p: i64) -> i32 {
    let hi = (p >> 32) as i32;
    if hi >> (SH - 1) == hi >> 31 {
        (p >> SH) as i32
    } else if hi < 0 {
        i32::MIN
    } else {
        i32::MAX
    }
}

/// `k · f` for a fraction `f` with 63 fractional bits, rounded: the I32F32
/// lobe keeps 63 fractional bits through the power ([`powi63`]).
#[inline(always)]
fn scale63(k: I32F32, f: u64) -> I32F32 {
    I32F32::from_bits(((k.to_bits() as i128 * f as i128 + (1i128 << 62)) >> 63) as i64)
}

impl Scalar for f32 {
    const NAME: &'static str = "f32";
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const HALF: Self = 0.5;
    const MAX: Self = f32::MAX;
    #[inline(always)]
    fn from_q(q: I32F32) -> Self {
        q.to_num::<f32>()
    }
    #[inline(always)]
    fn to_q(self) -> I32F32 {
        if self.is_nan() {
            I32F32::ZERO
        } else {
            I32F32::saturating_from_num(self)
        }
    }
    #[inline(always)]
    fn from_int(i: i32) -> Self {
        i as f32
    }
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn from_fixed_bits(bits: i32, frac: u32) -> Self {
        // 2^−frac built from its bits (exact for frac ≤ 126): a product,
        // not a quotient, on soft-float targets.
        bits as f32 * f32::from_bits((127 - frac.min(126)) << 23)
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self + o
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self - o
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self * o
    }
    #[inline(always)]
    fn div(self, o: Self) -> Option<Self> {
        let q = self / o;
        (o != 0.0 && q.is_finite()).then_some(q)
    }
    #[inline(always)]
    fn sqrt(self) -> Option<Self> {
        (self >= 0.0).then(|| libm::sqrtf(self))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    #[inline(always)]
    fn neg(self) -> Self {
        -self
    }
    type Lobe = f32;
    #[inline(always)]
    fn lobe(x: Self, n: u16) -> f32 {
        powi_clamped(x, n)
    }
    #[inline(always)]
    fn scale_lobe(k: Self, lobe: f32) -> Self {
        k * lobe
    }
    #[inline(always)]
    fn floor_int(self) -> i64 {
        // `as` saturates and maps NaN to 0.
        libm::floorf(self) as i64
    }
}

/// A deterministic sequence of `i32` whose magnitudes spread over every
/// bit length, both signs (xorshift), for the exactness tests of products.
#[cfg(test)]
pub(crate) fn spread_i32() -> impl FnMut() -> i32 {
    let mut x = 0x2545_f491_4f6c_dd1du64;
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let v = (x as u32) >> (x >> 59);
        if x & (1 << 40) != 0 {
            (v as i32).wrapping_neg()
        } else {
            v as i32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip<S: Scalar>(v: f64) -> f64 {
        S::from_q(I32F32::from_num(v)).to_q().to_num()
    }

    #[test]
    fn mul_q_equals_the_fixed_crate() {
        let mut next = spread_i32();
        for _ in 0..200_000 {
            let (a, b) = (next(), next());
            let (s1, s2) = (next() as u32 & 31, next() as u32 & 31);
            let (c, d) = (((a as i64) << s1) ^ b as i64, ((b as i64) << s2) ^ a as i64);
            for (p, q) in [
                (c, d),
                (c, b as i64),
                (i64::MIN, d),
                (c, i64::MAX),
                (c, -1),
                (i64::MIN, -1),
                // A factor below 1 in magnitude.
                (c, b as u32 as i64),
                (-(a as u32 as i64), d),
                (i64::MIN, b as u32 as i64),
                (i64::MAX, -(a as u32 as i64)),
            ] {
                let (p, q) = (I32F32::from_bits(p), I32F32::from_bits(q));
                assert_eq!(mul_q(p, q), p.saturating_mul(q), "{p:?} * {q:?}");
            }
        }
    }

    #[test]
    fn the_digit_division_is_the_64_bit_division() {
        let mut next = spread_i32();
        let edges = [
            1u32,
            2,
            3,
            0xFFFF,
            0x1_0000,
            0x1_0001,
            0x7FFF_FFFF,
            0x8000_0000,
            u32::MAX - 1,
            u32::MAX,
        ];
        let check = |u1: u32, u0: u32, v: u32| {
            let n = ((u1 as u64) << 32) | u0 as u64;
            let want = ((n / v as u64) as u32, (n % v as u64) as u32);
            let d = NonZeroU32::new(v).unwrap();
            assert_eq!(div_64_32_digits(u1, u0, d), want, "{n} / {v}");
        };
        for &v in &edges {
            for &u0 in &edges {
                for u1 in [0, 1, v / 2, v.saturating_sub(2), v - 1] {
                    check(u1.min(v - 1), u0, v);
                }
            }
        }
        for _ in 0..300_000 {
            let (a, b, c) = (next() as u32, next() as u32, next() as u32);
            let v = a.max(1);
            check(b % v, c, v);
            check(v - 1, c, v);
            // The correction's worst cases: a top digit of v just above a
            // power of two, u's top word just below v.
            let v = (v | 0x8000_0000) & 0x8000_FFFF;
            check(v - 1 - (b & 0xFF).min(v - 1), c, v);
        }
    }

    #[test]
    fn div_q_equals_the_fixed_crate() {
        let mut next = spread_i32();
        for _ in 0..300_000 {
            let (a, b) = (next(), next());
            let (s1, s2) = (next() as u32 & 63, next() as u32 & 63);
            let (c, d) = (((a as i64) << (s1 & 31)) ^ b as i64, (b as i64) >> (s2 & 31));
            let e = ((b as i64) << (s2 & 31)) ^ a as i64;
            for (p, q) in [
                (c, d),
                (c, e),
                (e, c),
                (c, b as i64),
                (c, 1),
                (c, -1),
                (c, (1 << 32) + d),
                (i64::MIN, d),
                (i64::MIN, 1 << 32),
                (i64::MIN, -(1 << 32)),
                (i64::MAX, 1 << 32),
                (i64::MIN, -1),
                (c, i64::MAX),
                (c, i64::MIN),
                (c, 0),
                (c.wrapping_shr(s1), c.wrapping_shr(s2).wrapping_add(1)),
            ] {
                let (p, q) = (I32F32::from_bits(p), I32F32::from_bits(q));
                assert_eq!(div_q(p, q), p.checked_div(q), "{p:?} / {q:?}");
            }
        }
    }

    #[test]
    fn conversions_saturate_and_lobes_agree() {
        assert_eq!(f32::from_q(I32F32::MAX), 2147483648.0);
        assert_eq!(roundtrip::<f32>(0.5), 0.5);
        assert_eq!(I32F32::from_fixed_bits(3 << 29, 30), I32F32::from_num(1.5));
        assert_eq!(f32::from_fixed_bits(-(1 << 28), 28), -1.0);
        assert_eq!(f32::NAN.floor_int(), 0);
        let x = I32F32::from_num(0.9);
        let k = I32F32::from_num(2.0);
        let want = 2.0 * 0.9f64.powi(37);
        let lobe = |k: I32F32, x: I32F32| I32F32::scale_lobe(k, I32F32::lobe(x, 37));
        for got in [
            lobe(k, x).to_num::<f64>(),
            f32::scale_lobe(2.0, f32::lobe(0.9, 37)) as f64,
        ] {
            assert!((got - want).abs() < 2e-3 * want, "{got} vs {want}");
        }
        assert!((lobe(k, x).to_num::<f64>() - want).abs() < 1e-9);
        assert_eq!(I32F32::lobe(I32F32::from_num(1.5), 3), 1 << 63);
    }
}
