//! Number formats and the wide intermediate arithmetic of the per-point paths.
//!
//! # Formats
//!
//! Each quantity has one storage format, chosen for its range and the accuracy
//! the contract asks of it:
//!
//! | alias | format | unit | range | resolution | used for |
//! |---|---|---|---|---|---|
//! | [`Len`] | I24F40 | m | ±8.4·10⁶ m | 0.91 pm | world, camera and image-plane coordinates, lens distances |
//! | [`Norm`] | I16F48 | 1 | ±32 768 | 3.6·10⁻¹⁵ | normalized image coordinates `x̂ = x/f`, ray slopes |
//! | [`Px`] | I16F16 | px | ±32 768 px | 1.5·10⁻⁵ px | pixel coordinates |
//! | [`Rot`] | I2F62 | 1 | ±2 | 2.2·10⁻¹⁹ | rotation matrix entries (a 10⁸ px telephoto needs 10⁻¹² of `R`) |
//! | [`Gain`] | I32F32 | varies | ±2.1·10⁹ | 2.3·10⁻¹⁰ | scale factors: px per metre, focal length in px, F-number |
//! | [`Angle`] | I4F60 | rad | ±8 rad | 8.7·10⁻¹⁹ rad | angles of view |
//! | [`Pitch`] | I4F60 | m | ±8 m | 8.7·10⁻¹⁹ m | pixel pitch (0.1 µm pitches must keep 10⁻¹⁰ relative) |
//!
//! Lengths share one format so that no conversion sits between a world point
//! and the lens law; 40 fractional bits keep a 1 µm blur circle to 10⁻⁶
//! relative while 24 integer bits cover any terrestrial scene.
//!
//! # Wide intermediates
//!
//! Products and quotients of the per-point paths are computed in [`Wide`], a
//! 128-bit integer mantissa with a binary point tracked at run time. Every
//! operation keeps at least 62 significant bits, so the error of a chain of a
//! few operations is far below one unit of the output format; the only
//! rounding that matters is the final narrowing into a storage format, which
//! saturates (and reports it through [`Sat`]) instead of wrapping. There is
//! no floating point in it: it is integer arithmetic throughout.
//!
//! A chain of stages (world → camera → image plane → pixel) is evaluated in
//! [`Wide`] end to end and rounded once, into the output format: the
//! intermediate frames are not narrowed on the way.
//!
//! The per-pixel renderer does not use [`Wide`]; it has 32-bit formats of its
//! own, chosen per frame.

pub mod scalar;
pub(crate) mod vec3;

use core::ops::{Add, Mul, Neg, Sub};
use fixed::types::{I16F16, I16F48, I24F40, I2F62, I32F32, I4F28, I4F60, I64F64};

use crate::target::M0;

/// `a · b` (u32 × u32 → u64) from four 16 × 16-bit products: the cross
/// terms' sum may carry into bit 32. The M0's route (tested exact); compiled
/// everywhere so that the tests check it.
#[inline(always)]
pub(crate) const fn umul16(a: u32, b: u32) -> u64 {
    let (ah, al) = (a >> 16, a & 0xFFFF);
    let (bh, bl) = (b >> 16, b & 0xFFFF);
    let cross = (ah * bl) as u64 + (al * bh) as u64;
    (((ah * bh) as u64) << 32) + (cross << 16) + (al * bl) as u64
}

/// [`umul16`] in 32-bit words, as `mix32::wmul16`: each cross term's
/// `c 2¹⁶` added to the low word with its carry, `c >> 16` to the high
/// word (which cannot overflow). The same bits; which of the two is
/// cheaper on the M0 depends on the registers around the product, so the
/// per-pixel sites that measured it cheaper take this one (`mix32::umul_px`).
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
#[inline(always)]
pub(crate) fn umul16_words(a: u32, b: u32) -> u64 {
    let (ah, al) = (a >> 16, a & 0xFFFF);
    let (bh, bl) = (b >> 16, b & 0xFFFF);
    let (c1, c2) = (ah * bl, al * bh);
    let (lo, k1) = (al * bl).overflowing_add(c1 << 16);
    let (lo, k2) = lo.overflowing_add(c2 << 16);
    let hi = (ah * bh) + (c1 >> 16) + (c2 >> 16) + k1 as u32 + k2 as u32;
    ((hi as u64) << 32) | lo as u64
}

/// Leading zeros of a `u32` (32 for 0): on the M0 [`clz32_table`].
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
#[inline(always)]
pub(crate) fn clz32(x: u32) -> u32 {
    if M0 {
        clz32_table(x)
    } else {
        x.leading_zeros()
    }
}

/// Leading zeros of a `u64` (64 for 0): on the M0 [`clz64_table`].
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
#[inline(always)]
pub(crate) fn clz64(x: u64) -> u32 {
    if M0 {
        clz64_table(x)
    } else {
        x.leading_zeros()
    }
}

/// [`clz32`] from the highest non-zero byte's count in a table (the M0 has
/// no `clz`; the library's routine is a loop). Compiled everywhere, like
/// the M0's other routines, so that the tests check it.
#[inline(always)]
fn clz32_table(x: u32) -> u32 {
    let (byte, n) = if x >> 16 != 0 {
        if x >> 24 != 0 {
            (x >> 24, 0)
        } else {
            (x >> 16, 8)
        }
    } else if x >> 8 != 0 {
        (x >> 8, 16)
    } else {
        (x, 24)
    };
    // (Masked: an index in bounds without a test, which the three lower
    // bytes' took on the M0.)
    n + CLZ8.get((byte & 0xFF) as usize).copied().unwrap_or(0) as u32
}

/// [`clz64`] from [`clz32_table`].
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
#[inline(always)]
fn clz64_table(x: u64) -> u32 {
    let hi = (x >> 32) as u32;
    if hi == 0 {
        32 + clz32_table(x as u32)
    } else {
        clz32_table(hi)
    }
}

/// Leading zeros of a byte (8 for 0), for [`clz32_table`].
#[allow(clippy::indexing_slicing)]
const CLZ8: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        t[i] = (i as u8).leading_zeros() as u8;
        i += 1;
    }
    t
};

/// Leading zeros of a `u128` (128 for 0): on the M0 [`clz128_words`] (the
/// library's 128-bit count is four calls of a bit loop there; per-frame
/// preparation only).
pub(crate) fn clz128(v: u128) -> u32 {
    if M0 {
        clz128_words(v)
    } else {
        v.leading_zeros()
    }
}

/// [`clz128`] from the top non-zero word's [`clz32_table`].
fn clz128_words(v: u128) -> u32 {
    let mut n = 0;
    let mut w = v;
    while n < 96 && (w >> 96) == 0 {
        w <<= 32;
        n += 32;
    }
    n + clz32_table((w >> 96) as u32)
}

/// `⌊√v⌋`, two bits of `v` a step (the digit-by-digit method): a few
/// hundred bytes of code where the library's `u128::isqrt` is over 2 KB
/// of flash on Cortex-M. After `k` steps the root is below `2^k` and the
/// remainder at most twice it, so the first 61 steps run in 64-bit words
/// (half the M0's work of 128-bit ones), the last three at most in 128.
/// Its users run once a frame (preparation), not a pixel.
#[inline(never)]
pub(crate) fn isqrt_u128(v: u128) -> u128 {
    // Steps: the bit pairs from the highest non-zero one; the pairs are
    // taken from the top of (hi, lo), shifted two bits a step.
    let steps = (129 - clz128(v)) / 2;
    if steps == 0 {
        return 0;
    }
    let x = v << (128 - 2 * steps);
    let (mut hi, mut lo) = ((x >> 64) as u64, x as u64);
    let mut pair = || {
        let p = hi >> 62;
        hi = (hi << 2) | (lo >> 62);
        lo <<= 2;
        p
    };
    // One step: the next pair into the remainder, a bit of the root.
    macro_rules! step {
        ($root:ident, $rem:ident, $t:ty) => {
            $rem = ($rem << 2) | pair() as $t;
            let trial = ($root << 2) | 1;
            $root <<= 1;
            if $rem >= trial {
                $rem -= trial;
                $root |= 1;
            }
        };
    }
    let (mut root, mut rem) = (0u64, 0u64);
    let narrow = steps.min(61);
    for _ in 0..narrow {
        // rem ≤ 2 root < 2^(k+1): rem·4 + 3 < 2^64 for k ≤ 60.
        step!(root, rem, u64);
    }
    let (mut root, mut rem) = (root as u128, rem as u128);
    for _ in narrow..steps {
        step!(root, rem, u128);
    }
    root
}

/// `a · b mod 2⁶⁴` (the noise generator's hash): on the M0
/// `mul64_words`, elsewhere the one instruction sequence.
#[inline(always)]
pub(crate) const fn wrapping_mul64(a: u64, b: u64) -> u64 {
    if M0 {
        mul64_words(a, b)
    } else {
        a.wrapping_mul(b)
    }
}

/// [`wrapping_mul64`] from the low words' full product ([`umul16`]) and the
/// cross words' low products (the high words' product is all above 2⁶⁴).
#[inline(always)]
pub(crate) const fn mul64_words(a: u64, b: u64) -> u64 {
    let (al, ah, bl, bh) = (a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32);
    let cross = al.wrapping_mul(bh).wrapping_add(ah.wrapping_mul(bl));
    umul16(al, bl).wrapping_add((cross as u64) << 32)
}

/// Lengths in metres: I24F40 (±8.4·10⁶ m, resolution 0.91 pm).
pub type Len = I24F40;
/// Normalized image coordinates and ray slopes (dimensionless): I16F48.
pub type Norm = I16F48;
/// Pixel coordinates: I16F16 (±32 768 px, resolution 1.5·10⁻⁵ px).
pub type Px = I16F16;
/// Rotation matrix entries (dimensionless): I2F62.
pub type Rot = I2F62;
/// Scale factors (px per metre, focal length in px, F-number): I32F32.
pub type Gain = I32F32;
/// Angles in radians: I4F60.
pub type Angle = I4F60;
/// Pixel pitch in metres: I4F60 (the same format as [`Angle`]).
pub type Pitch = I4F60;

/// A value computed in fixed point, with whether any step had to saturate.
///
/// When `saturated` is true, `value` is the nearest representable value (the
/// end of the format's range in the direction of the true result); it is never
/// a wrapped value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[must_use]
pub struct Sat<T> {
    /// The result, or the end of the range it was clamped to.
    pub value: T,
    /// True if the true result lay outside the output format.
    pub saturated: bool,
}

impl<T> Sat<T> {
    /// A result that did not saturate.
    pub const fn exact(value: T) -> Self {
        Sat {
            value,
            saturated: false,
        }
    }

    /// Applies `f` to the value, keeping the flag.
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Sat<U> {
        Sat {
            value: f(self.value),
            saturated: self.saturated,
        }
    }

    /// Combines with another result: the flag is set if either saturated.
    pub fn zip<U>(self, other: Sat<U>) -> Sat<(T, U)> {
        Sat {
            value: (self.value, other.value),
            saturated: self.saturated || other.saturated,
        }
    }

    /// Returns the value if it did not saturate.
    pub fn ok(self) -> Option<T> {
        if self.saturated {
            None
        } else {
            Some(self.value)
        }
    }
}

/// A fixed-point storage format that [`Wide`] can read and narrow into.
pub trait Format: Copy {
    /// Fractional bits.
    const FRAC: i32;
    /// Smallest raw value.
    const MIN_RAW: i128;
    /// Largest raw value.
    const MAX_RAW: i128;
    /// The raw bits, widened.
    fn raw(self) -> i128;
    /// From raw bits already known to be in range.
    fn from_raw_in_range(raw: i128) -> Self;
}

macro_rules! impl_format {
    ($t:ty, $bits:ty, $frac:expr) => {
        impl Format for $t {
            const FRAC: i32 = $frac;
            const MIN_RAW: i128 = <$bits>::MIN as i128;
            const MAX_RAW: i128 = <$bits>::MAX as i128;
            #[inline]
            fn raw(self) -> i128 {
                self.to_bits() as i128
            }
            #[inline]
            fn from_raw_in_range(raw: i128) -> Self {
                // In range by the caller's clamp; the cast cannot truncate.
                <$t>::from_bits(raw as $bits)
            }
        }
    };
}

impl_format!(Len, i64, 40);
impl_format!(Norm, i64, 48);
impl_format!(Px, i32, 16);
impl_format!(Rot, i64, 62);
impl_format!(Gain, i64, 32);
impl_format!(Angle, i64, 60);
impl_format!(I4F28, i32, 28);
impl_format!(fixed::types::I32F0, i32, 0);
impl_format!(I64F64, i128, 64);

/// Significant bits a mantissa is normalized to before a multiplication.
const MUL_BITS: u32 = 63;
/// Significant bits a mantissa is normalized to before an addition or as a
/// dividend.
const ADD_BITS: u32 = 125;

/// A wide intermediate: `mant · 2^-frac`, with at least 62 significant bits
/// kept by every operation. Integer arithmetic only.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wide {
    mant: i128,
    frac: i32,
}

/// Shifts right by `s` with rounding to nearest (ties towards +∞).
/// `m` must have at most 126 significant bits. Out of line: per frame only,
/// and inlined its 128-bit shifts cost the M0 12 KB of flash.
#[inline(never)]
fn shr_round(m: i128, s: u32) -> i128 {
    if s == 0 {
        m
    } else if s >= 127 {
        0
    } else {
        (m + (1i128 << (s - 1))) >> s
    }
}

fn sig_bits(m: i128) -> u32 {
    128 - clz128(m.unsigned_abs())
}

/// `⌊n / d⌋`, `None` for `d = 0`. For a divisor of 63 bits (`d` in
/// `[2⁶², 2⁶³)`, as [`Wide::checked_div`] normalizes it) and a quotient
/// below 2⁶⁴, by restoring division in 64-bit words: the remainder stays
/// below `d`, the quotient's bits fill the dividend's low word as it shifts
/// out (about 1 000 M0 instructions, where the 128-bit division the
/// compiler writes out takes 2 to 3 times as many). Otherwise the 128-bit
/// division.
fn div_by_63_bits(n: u128, d: u128) -> Option<u128> {
    let (hi, lo) = ((n >> 64) as u64, n as u64);
    match u64::try_from(d) {
        Ok(d64) if d64 >> 62 == 1 && hi < d64 => {
            let (mut r, mut x) = (hi, lo);
            for _ in 0..64 {
                // r < d < 2⁶³: r·2 + 1 fits.
                let top = x >> 63;
                x <<= 1;
                r = (r << 1) | top;
                if r >= d64 {
                    r -= d64;
                    x |= 1;
                }
            }
            Some(x as u128)
        }
        _ => n.checked_div(d),
    }
}

/// `a · b` for `|a|, |b| < 2⁶³` (mantissas [`Wide::normalized`] to
/// [`MUL_BITS`]) from four 32 × 32-bit products ([`umul16`]): on the M0
/// the library's 128-bit product is calls of its 64-bit one.
#[inline(never)]
fn mul_63_words(a: i128, b: i128) -> i128 {
    let (x, y) = (a.unsigned_abs() as u64, b.unsigned_abs() as u64);
    let (xh, xl, yh, yl) = ((x >> 32) as u32, x as u32, (y >> 32) as u32, y as u32);
    // Each cross product is below 2⁶³: their sum fits u64.
    let cross = umul16(xh, yl) + umul16(xl, yh);
    let p = ((umul16(xh, yh) as u128) << 64) + ((cross as u128) << 32) + umul16(xl, yl) as u128;
    if (a < 0) != (b < 0) {
        -(p as i128)
    } else {
        p as i128
    }
}

impl Wide {
    /// Zero.
    pub const ZERO: Wide = Wide { mant: 0, frac: 0 };

    /// Reads a fixed-point value exactly.
    #[inline]
    pub fn of<T: Format>(x: T) -> Wide {
        Wide {
            mant: x.raw(),
            frac: T::FRAC,
        }
    }

    /// An integer, exactly.
    #[inline]
    pub const fn int(i: i64) -> Wide {
        Wide {
            mant: i as i128,
            frac: 0,
        }
    }

    /// Rescales the mantissa to exactly `bits` significant bits (or leaves zero
    /// alone). Shifting right rounds; the value changes by at most half a unit
    /// in the last kept place.
    // Out of line: Wide runs in per-frame preparation only, where one
    // shared copy saves flash on the boards.
    #[inline(never)]
    fn normalized(self, bits: u32) -> Wide {
        if self.mant == 0 {
            return Wide::ZERO;
        }
        let have = sig_bits(self.mant);
        if have > bits {
            let s = have - bits;
            Wide {
                mant: shr_round(self.mant, s),
                frac: self.frac.saturating_sub(s as i32),
            }
        } else {
            let s = bits - have;
            Wide {
                mant: self.mant << s,
                frac: self.frac.saturating_add(s as i32),
            }
        }
    }

    /// Sign: -1, 0 or 1.
    pub fn signum(self) -> i32 {
        self.mant.signum() as i32
    }

    /// True if the value is zero.
    pub fn is_zero(self) -> bool {
        self.mant == 0
    }

    /// Absolute value.
    pub fn abs(self) -> Wide {
        Wide {
            mant: self.mant.abs(),
            frac: self.frac,
        }
    }

    /// Quotient, with at least 62 significant bits; `None` when `o` is zero.
    // Out of line: Wide runs in per-frame preparation only, where one
    // shared copy saves flash on the boards.
    #[inline(never)]
    pub fn checked_div(self, o: Wide) -> Option<Wide> {
        if o.mant == 0 {
            return None;
        }
        let n = self.normalized(ADD_BITS);
        let d = o.normalized(MUL_BITS);
        // Round half away from zero, on magnitudes (both fit in 126 bits).
        let (un, ud) = (n.mant.unsigned_abs(), d.mant.unsigned_abs());
        let q = div_by_63_bits(un + ud / 2, ud)? as i128;
        let negative = (n.mant < 0) != (d.mant < 0);
        Some(Wide {
            mant: if negative { -q } else { q },
            frac: n.frac.saturating_sub(d.frac),
        })
    }

    /// Square root, with at least 62 significant bits; `None` for a negative
    /// value.
    pub fn sqrt(self) -> Option<Wide> {
        if self.mant < 0 {
            return None;
        }
        if self.mant == 0 {
            return Some(Wide::ZERO);
        }
        // Make the binary point even, then fill the mantissa to 125-126 bits
        // by an even shift, so that the integer root has 62-63 bits.
        let mut m = self.mant as u128;
        let mut frac = self.frac as i64;
        if frac & 1 != 0 {
            m <<= 1;
            frac += 1;
        }
        let room = clz128(m).saturating_sub(2) & !1;
        m <<= room;
        frac += room as i64;
        Some(Wide {
            mant: isqrt_u128(m) as i128,
            frac: (frac / 2) as i32,
        })
    }

    /// The larger of two values.
    pub fn max_of(self, o: Wide) -> Wide {
        if self.compare(o) == core::cmp::Ordering::Less {
            o
        } else {
            self
        }
    }

    /// Compares two values.
    pub fn compare(self, o: Wide) -> core::cmp::Ordering {
        (self - o).signum().cmp(&0)
    }

    /// Narrows to a storage format, rounding to nearest; saturates outside its
    /// range.
    pub fn narrow<T: Format>(self) -> Sat<T> {
        if self.mant == 0 {
            return Sat::exact(T::from_raw_in_range(0));
        }
        let shift = T::FRAC as i64 - self.frac as i64;
        let raw: Option<i128> = if shift >= 0 {
            // Left shift: exact unless it overflows.
            let s = shift as u32;
            if s >= 127 || sig_bits(self.mant) + s > 126 {
                None
            } else {
                Some(self.mant << s)
            }
        } else {
            // Right shift: rounds. Bring the mantissa to ≤ 126 bits first.
            let m = self.normalized(ADD_BITS);
            let s = T::FRAC as i64 - m.frac as i64;
            if s >= 0 {
                Some(m.mant << (s as u32))
            } else {
                Some(shr_round(m.mant, (-s).min(127) as u32))
            }
        };
        match raw {
            Some(r) if (T::MIN_RAW..=T::MAX_RAW).contains(&r) => Sat::exact(T::from_raw_in_range(r)),
            Some(r) if r < 0 => Sat {
                value: T::from_raw_in_range(T::MIN_RAW),
                saturated: true,
            },
            Some(_) => Sat {
                value: T::from_raw_in_range(T::MAX_RAW),
                saturated: true,
            },
            None if self.mant < 0 => Sat {
                value: T::from_raw_in_range(T::MIN_RAW),
                saturated: true,
            },
            None => Sat {
                value: T::from_raw_in_range(T::MAX_RAW),
                saturated: true,
            },
        }
    }
}

impl Neg for Wide {
    type Output = Wide;
    fn neg(self) -> Wide {
        Wide {
            mant: -self.mant,
            frac: self.frac,
        }
    }
}

/// Product, with at least 62 significant bits.
impl Mul for Wide {
    type Output = Wide;
    fn mul(self, o: Wide) -> Wide {
        let a = self.normalized(MUL_BITS);
        let b = o.normalized(MUL_BITS);
        Wide {
            mant: if M0 {
                mul_63_words(a.mant, b.mant)
            } else {
                a.mant * b.mant
            },
            frac: a.frac.saturating_add(b.frac),
        }
    }
}

/// Sum, exact to 2⁻¹²⁴ relative to the larger operand.
impl Add for Wide {
    type Output = Wide;
    fn add(self, o: Wide) -> Wide {
        if self.mant == 0 {
            return o;
        }
        if o.mant == 0 {
            return self;
        }
        let a = self.normalized(ADD_BITS);
        let b = o.normalized(ADD_BITS);
        // Align to the coarser binary point (the larger magnitude).
        let frac = a.frac.min(b.frac);
        let sa = (a.frac - frac) as u32;
        let sb = (b.frac - frac) as u32;
        Wide {
            mant: shr_round(a.mant, sa) + shr_round(b.mant, sb),
            frac,
        }
    }
}

/// Difference.
impl Sub for Wide {
    type Output = Wide;
    fn sub(self, o: Wide) -> Wide {
        self + (-o)
    }
}

/// `n / d` narrowed to `T`. A zero divisor (only possible if a validated
/// parameter were zero) gives the saturated end in the direction of `n`
/// rather than a panic.
pub fn quotient<T: Format>(n: Wide, d: Wide) -> Sat<T> {
    match n.checked_div(d) {
        Some(q) => q.narrow(),
        None => Sat {
            value: T::from_raw_in_range(if n.signum() < 0 { T::MIN_RAW } else { T::MAX_RAW }),
            saturated: true,
        },
    }
}

/// `x` as `f64`, rounded to the nearest (`fixed`'s `to_num`). One shared
/// copy a format: it runs where parameters are taken, once a frame or a
/// plan, and in line at each of those places it cost the default firmware
/// 3.4 KB of flash on the M3, 7.0 KB on the M0.
#[inline(never)]
pub fn to_f64<T: fixed::traits::Fixed>(x: T) -> f64 {
    x.to_num()
}

/// `a · b`, saturated. One shared copy for the code that runs once a
/// frame or a plan: in line at each use, the 128-bit products and
/// quotients ([`div_q`]) cost the M3's default firmware 2.6 KB of flash
/// (the M0's 10.1 KB with the scene data's `f64` reader, out of line in
/// the same step).
#[inline(never)]
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
pub(crate) fn mul_sat(a: I32F32, b: I32F32) -> I32F32 {
    a.saturating_mul(b)
}

/// `a / b`, `None` if `b` is 0 or the quotient is out of range. Out of
/// line, as [`mul_sat`].
#[inline(never)]
pub(crate) fn div_q(a: I32F32, b: I32F32) -> Option<I32F32> {
    a.checked_div(b)
}

/// [`to_f64`] as a method.
pub trait FixedF64 {
    /// The value as `f64`, rounded to the nearest.
    fn f64(self) -> f64;
}

impl<T: fixed::traits::Fixed> FixedF64 for T {
    #[inline(always)]
    fn f64(self) -> f64 {
        to_f64(self)
    }
}

/// Converts a finite `f64` into a storage format, rounding to the nearest
/// (ties to even, as `fixed`'s `from_num`); `None` if it is not finite or
/// does not fit. For parameters converted once, at construction. Written
/// out so that no panic path comes with it (`fixed`'s float conversions
/// keep one for NaN wherever they are not inlined).
pub fn from_f64<T>(x: f64) -> Option<T>
where
    T: fixed::traits::Fixed,
    T::Bits: TryFrom<i64>,
{
    T::Bits::try_from(bits_from_f64(x, T::FRAC_NBITS)?)
        .ok()
        .map(T::from_bits)
}

/// `x 2^frac` rounded to the nearest integer (ties to even), if it is
/// within `i64`. One shared copy: it runs at construction only.
#[inline(never)]
fn bits_from_f64(x: f64, frac: u32) -> Option<i64> {
    // x 2^frac is exact (a power of two); rint rounds it to nearest-even.
    let s = libm::rint(libm::ldexp(x, frac as i32));
    // Within [−2⁶³, 2⁶³) (NaN and ±∞ fail the comparison).
    const TOP: f64 = 9_223_372_036_854_775_808.0; // 2⁶³, exact
    (-TOP..TOP).contains(&s).then_some(s as i64)
}

/// `x̂_d` or `ŷ_d` (I32F32) from its I64F64 accumulator.
#[inline(always)]
pub(crate) fn from_acc(acc: i128) -> fixed::types::I32F32 {
    fixed::types::I32F32::from_bits((acc >> 32) as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 63-bit divisor's restoring division is the 128-bit division:
    /// at the ends of its range, on random values, and outside it.
    #[test]
    fn division_by_63_bits_is_the_128_bit_division() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let ends = [1u64 << 62, (1 << 62) + 1, (1 << 63) - 2, (1 << 63) - 1];
        for i in 0..200_000 {
            let d = match i % 8 {
                0..=3 => ends.get(i % 4).copied().unwrap_or(1),
                _ => (1 << 62) | (next() >> 2),
            } as u128;
            let hi = (next() as u128) % d;
            for n in [(hi << 64) | next() as u128, hi << 64, (d << 64) - 1, 0, d - 1, d] {
                assert_eq!(div_by_63_bits(n, d), n.checked_div(d), "{n} / {d}");
            }
        }
        // Outside the fast path's range: the 128-bit division.
        for (n, d) in [
            (1u128 << 127, 1u128 << 62),
            (5, 3),
            (u128::MAX, 1u128 << 63),
            (7, 0),
        ] {
            assert_eq!(div_by_63_bits(n, d), n.checked_div(d));
        }
    }

    /// A small deterministic generator (xorshift on 128 bits).
    fn next(x: &mut u128) -> u128 {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        *x
    }

    #[test]
    fn the_table_counts_of_leading_zeros_are_the_librarys() {
        let mut x = 0x2545_F491_4F6C_DD1Du128 | (0x9E37_79B9_7F4A_7C15u128 << 64);
        for _ in 0..2000 {
            let x = next(&mut x);
            for s in [0, 1, 31, 32, 33, 63, 64, 65, 95, 96, 97, 127] {
                let v = x >> s;
                assert_eq!(clz128_words(v), v.leading_zeros(), "{v}");
                assert_eq!(clz64_table(v as u64), (v as u64).leading_zeros(), "{v}");
                assert_eq!(clz32_table(v as u32), (v as u32).leading_zeros(), "{v}");
            }
        }
        assert_eq!(clz128_words(0), 128);
        assert_eq!(clz128_words(1), 127);
        assert_eq!(clz64_table(0), 64);
        assert_eq!(clz32_table(0), 32);
    }

    #[test]
    fn the_word_product_is_the_128_bit_product() {
        let mut x = 0x9E37_79B9_7F4A_7C15u128;
        for _ in 0..20_000 {
            let (p, q, s) = (next(&mut x) as u64, next(&mut x) as u64, next(&mut x) as u64);
            let (a, b) = ((p >> 1) as i128, (q >> (1 + s % 63)) as i128);
            for (a, b) in [(a, b), (-a, b), (a, -b), (-a, -b), (a, 0), ((1 << 63) - 1, -b)] {
                assert_eq!(mul_63_words(a, b), a * b, "{a} x {b}");
            }
        }
    }

    #[test]
    fn isqrt_u128_is_the_librarys() {
        let mut x: u128 = 0x9e37_79b9_7f4a_7c15_f39c_c060_5ced_c834;
        let mut edges = vec![
            0u128,
            1,
            2,
            3,
            4,
            5,
            u128::MAX,
            u128::MAX - 1,
            1 << 126,
            (1 << 126) - 1,
        ];
        for r in [1u128, 2, 3, 0xFFFF_FFFF, 0xFFFF_FFFF_FFFF_FFFF, 1 << 40] {
            edges.extend([r * r - 1, r * r, r * r + 1]);
        }
        for v in edges {
            assert_eq!(isqrt_u128(v), v.isqrt(), "{v}");
        }
        for _ in 0..200_000 {
            let x = next(&mut x);
            let v = x >> (x % 128);
            assert_eq!(isqrt_u128(v), v.isqrt(), "{v}");
        }
    }

    fn w(x: f64) -> Wide {
        Wide::of(Len::from_num(x))
    }

    fn val(x: Wide) -> f64 {
        x.narrow::<Len>().value.to_num::<f64>()
    }

    /// `from_f64` rounds as `fixed`'s checked conversion does (nearest,
    /// ties to even) and refuses what does not fit, NaN and ±∞.
    #[test]
    fn from_f64_is_fixeds_checked_conversion() {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut values = vec![
            0.5,
            1.5,
            2.5,
            -2.5,
            2f64.powi(-41),
            3.0 * 2f64.powi(-41),
            32767.9999,
            32768.0,
            -32768.0,
        ];
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let f = f64::from_bits(x);
            if f.is_finite() {
                values.push(f);
                values.push(f % 40_000.0);
                values.push((x >> 11) as f64 * 2f64.powi(-60) - 2048.0);
            }
        }
        for v in values {
            assert_eq!(from_f64::<Len>(v), Len::checked_from_num(v), "{v:e}");
            assert_eq!(from_f64::<Norm>(v), Norm::checked_from_num(v), "{v:e}");
            assert_eq!(from_f64::<Px>(v), Px::checked_from_num(v), "{v:e}");
            assert_eq!(from_f64::<Rot>(v), Rot::checked_from_num(v), "{v:e}");
        }
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300] {
            assert_eq!(from_f64::<Len>(v), None);
        }
    }

    #[test]
    fn arithmetic_matches_exact_values() {
        assert_eq!(val(w(1.5).mul(w(-2.25))), -3.375);
        assert_eq!(val(w(3.0).checked_div(w(-4.0)).unwrap_or(Wide::ZERO)), -0.75);
        assert_eq!(val(w(3.0).add(w(-4.5))), -1.5);
        assert!(w(1.0).checked_div(Wide::ZERO).is_none());
    }

    #[test]
    fn tiny_plus_large_keeps_both() {
        let tiny = Wide::of(Norm::from_bits(1));
        let big = Wide::int(1 << 40);
        let back = big.add(tiny).sub(big);
        assert_eq!(back.narrow::<Norm>().value, Norm::from_bits(1));
    }

    #[test]
    fn narrowing_saturates_instead_of_wrapping() {
        let big = Wide::int(1 << 30);
        let s = big.narrow::<Px>();
        assert!(s.saturated);
        assert_eq!(s.value, Px::MAX);
        let s = big.neg().narrow::<Px>();
        assert!(s.saturated);
        assert_eq!(s.value, Px::MIN);
        let huge = Wide::int(i64::MAX)
            .mul(Wide::int(i64::MAX))
            .mul(Wide::int(i64::MAX));
        assert!(huge.narrow::<Len>().saturated);
    }

    #[test]
    fn division_rounds_to_nearest_for_all_signs() {
        for (n, d) in [(7, 2), (-7, 2), (7, -2), (-7, -2), (1, 3), (-1, 3)] {
            let q = Wide::int(n).checked_div(Wide::int(d)).unwrap_or(Wide::ZERO);
            let got = q.narrow::<Norm>().value.to_num::<f64>();
            assert!((got - n as f64 / d as f64).abs() < 1e-14, "{n}/{d} gave {got}");
        }
    }
}
