//! The last stages of the fast arithmetic's pixel: `cos⁴α` and the
//! exposure's rounding to DN (`vignette_dn`), the sensor's noise
//! (`noisy`), and the pixel's words and bytes (`word`, `store`).

use super::arith::{norm_top_even, rsqrt_top, smul_u, umul};
use super::chans;
use super::rays::CHUNK;
use crate::num::umul16_words;
use crate::scene::Q;
use crate::target::{M0, M0_COMPACT};

/// `DN = floor(sum · cos⁴α + ½)` for a sum in S15 DN (≤ [`SUM_CAP`]) and
/// `cos⁴α` in S31, exactly, capped at `max` (a channel's full scale, below
/// 2¹⁶). The common case, a sum below 2³² (below 2¹⁷ DN: any pixel that
/// is not saturated), is one product's high word in line; a larger sum
/// takes [`vignette_dn_high`], out of line. In line on the M0 too (out of
/// line there it saved 2.0 KB of flash for 4.0 instructions a pixel on the
/// standard scene, 606.6 against 602.6, which the M0 / M3 ≤ 3 gate needs
/// once the M3's closed plane keeps one channel's sums in the chunk
/// buffers: 201.8 a pixel).
#[inline(always)]
pub(super) fn vignette_dn(sum: u64, c4: u32, max: u32) -> u32 {
    // ⌊(lo c4 + 2^45) / 2^46⌋ = (⌊lo c4 / 2^32⌋ + 2^13) >> 14 (2^45 is a
    // multiple of 2^32); ⌊lo c4 / 2^32⌋ < 2^31 (c4 ≤ 2^31).
    match u32::try_from(sum) {
        Ok(lo) => vignette_dn_lo(lo, c4, max),
        Err(_) => vignette_dn_high(sum, c4).min(max),
    }
}

/// [`vignette_dn`] of a sum below 2³² (`lo`).
#[inline(always)]
pub(super) fn vignette_dn_lo(lo: u32, c4: u32, max: u32) -> u32 {
    let dn = if M0 {
        round_c4_words(lo, c4)
    } else {
        ((umul(lo, c4) >> 32) as u32 + (1 << 13)) >> 14
    };
    dn.min(max)
}

/// [`vignette_dn`] of a sum of 2³² or more (a saturated pixel), before its
/// cap: [`vignette_dn_words`].
#[inline(never)]
#[cold]
pub(super) fn vignette_dn_high(sum: u64, c4: u32) -> u32 {
    vignette_dn_words(sum, c4)
}

/// `⌊(sum · cos⁴α + 2⁴⁵) / 2⁴⁶⌋` for any sum up to [`SUM_CAP`] (at most
/// `u32::MAX`), branch-free: the sum's two 32-bit halves times `cos⁴α`
/// (the x86-64 lanes' form, which the compiler vectorizes).
#[inline(always)]
pub(super) fn vignette_dn_words(sum: u64, c4: u32) -> u32 {
    // (hi 2^32 + lo) c4 + 2^45 over 2^46 = (hi c4 + ⌊(lo c4 + 2^45) / 2^32⌋) / 2^14
    // (nested floors of integers); hi c4 < 2^46.
    let (hi, lo) = ((sum >> 32) as u32, sum as u32);
    let dn = (umul(hi, c4) + ((umul(lo, c4) + (1 << 45)) >> 32)) >> 14;
    dn.min(u32::MAX as u64) as u32
}

/// [`vignette_dn`] of a sum below 2³² (`lo`) on the M0: `⌊(lo c4 + 2⁴⁵)
/// / 2⁴⁶⌋ = (⌊lo c4 / 2³²⌋ + 2¹³) >> 14` from three 16 × 16-bit products
/// — the high word less the low word's carries, 0 to 2 — and from all
/// four where those carries could reach bit 14 (2 values in 2¹⁴).
#[inline(always)]
pub(super) fn round_c4_words(lo: u32, c4: u32) -> u32 {
    let (ah, al) = (lo >> 16, lo & 0xFFFF);
    let (bh, bl) = (c4 >> 16, c4 & 0xFFFF);
    // c4 ≤ 2^31: ah bh < 2^31, and the sum stays below 2^32.
    let t = ah * bh + ((ah * bl) >> 16) + ((al * bh) >> 16) + (1 << 13);
    if t & 0x3FFF < 0x3FFE {
        t >> 14
    } else {
        round_c4_exact(lo, c4)
    }
}

/// [`round_c4_words`] from all four products: out of line (2 values of
/// `t` in 2¹⁴ take it).
#[inline(never)]
#[cold]
pub(super) fn round_c4_exact(lo: u32, c4: u32) -> u32 {
    ((umul16_words(lo, c4) + (1 << 45)) >> 46) as u32
}

/// The noise-free value `sum · cos⁴α` (DN, before rounding) as I32F32,
/// exactly (saturated far above any full scale): the value
/// [`vignette_dn`] rounds.
#[inline(always)]
pub(super) fn vignette_q(sum: u64, c4: u32) -> Q {
    // sum 2^-15 · c4 2^-31 = (hi c4 2^32 + lo c4) 2^-46, in units of 2^-32;
    // a sum below 2^32 (any pixel not saturated) is `lo` alone.
    if let Ok(lo) = u32::try_from(sum) {
        return Q::from_bits((umul(lo, c4) >> 14) as i64);
    }
    let (hi, lo) = ((sum >> 32) as u32, sum as u32);
    let a = umul(hi, c4);
    let bits = if a >= 1 << 44 {
        i64::MAX
    } else {
        ((a << 18) + (umul(lo, c4) >> 14)) as i64
    };
    Q::from_bits(bits)
}

/// The recorded values of a pixel whose channels' sums before `cos⁴α` are
/// `sum` (S15 DN), with sensor noise: [`noisy_dn`] of each channel's draw
/// on the exact noise-free value, as the pixel's [`word`] (in a register:
/// three values back through memory, packed by the caller, took the M3's
/// low-light scene 383.0 instructions a pixel against 370.7). Out of line:
/// the noiseless pixel loop stays lean.
#[cfg_attr(hilcam_loops_out_of_line, inline(never))]
#[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
pub(super) fn noisy<const C: usize>(
    n: usize,
    z: &crate::render::sensor::noise::Stage<Q>,
    sum: [u64; 3],
    c4: u32,
    index: u32,
    dn_max: [u64; 3],
) -> u16 {
    // In a `compact` build (one loop for one and three channels) the
    // channels written out, as `Mix32::dn_word` takes them (a loop over
    // their count measured slower on both boards): on the M3 through
    // `each`, on the M0 each channel a value (through `each` the arrays
    // were copied a pixel again). Outside a `compact` build the value form
    // slowed the default firmware's other loops; one helper for these two
    // forms and `Mix32::dn_word`'s, the value a closure argument, slowed
    // the camera's.
    if crate::target::COMPACT && !M0_COMPACT {
        let mut dn = [0u32; 3];
        super::each::<C>(n, |c| {
            if let (Some(d), Some(&s), Some(&max)) = (dn.get_mut(c), sum.get(c), dn_max.get(c)) {
                *d = noisy_dn(z.draw(index, c), vignette_q(s, c4), max as u16);
            }
        });
        return word::<C>(n, dn);
    }
    if M0_COMPACT {
        let ([s0, s1, s2], [m0, m1, m2]) = (sum, dn_max);
        let v = |c: usize, s: u64, max: u64| noisy_dn(z.draw(index, c), vignette_q(s, c4), max as u16);
        let d0 = v(0, s0, m0);
        let dn = if chans::<C>(n) == 3 {
            [d0, v(1, s1, m1), v(2, s2, m2)]
        } else {
            [d0, 0, 0]
        };
        return word::<C>(n, dn);
    }
    let mut dn = [0u32; 3];
    for (c, ((d, s), max)) in dn.iter_mut().zip(sum).zip(dn_max).take(chans::<C>(n)).enumerate() {
        *d = noisy_dn(z.draw(index, c), vignette_q(s, c4), max as u16);
    }
    word::<C>(n, dn)
}

/// The EMVA 1288 stage's value ([`crate::render::sensor::noise::Stage::apply_with`] with
/// [`mul_nonneg`] and [`sigma_z16`], I32F32) of a draw `d` on the noise-free
/// value `mu`, clamped to `[0, dn_max]`, without its saturating sums: both
/// of its sums are exact where `μ` and `μ_y,dark + ½` lie below 2⁶¹ (the
/// noise term is within ±2⁵²), and where either does not, both clamp to
/// `dn_max` (the value exceeds 2²⁹ − 2²⁰ DN either way: `σ z` is their only
/// negative term). Equal to `apply_with`'s (`tests`).
#[inline(always)]
pub(super) fn noisy_dn(d: crate::render::sensor::noise::Draw<Q>, mu: Q, dn_max: u16) -> u32 {
    let mu = mu.to_bits().max(0);
    let off = d.offset.to_bits();
    if (mu | off) as u64 >> 61 != 0 {
        return dn_max as u32;
    }
    // σ² = K_sys μ + (K_sys σ_d)², both ≥ 0: their u64 sum saturated at
    // i64::MAX as the scalar sum is.
    // (`K_sys` and `(K_sys σ_d)²` are non-negative: `Stage::new`.) Where
    // both factors' integer parts lie below 2^15 and `(K_sys σ_d)²` below
    // 2^61, the sum is below 2^63: neither saturates. (Not on the M0: its
    // registers took low-light 29 instructions a pixel more.)
    let (k, dark) = (d.ksys.to_bits() as u64, d.dark_var.to_bits() as u64);
    let var = if !M0 && ((k | mu as u64) >> 47) | (dark >> 61) == 0 {
        mul_small_bits(k, mu as u64) + dark
    } else {
        mul_nonneg_bits(k, mu as u64)
            .saturating_add(dark)
            .min(i64::MAX as u64)
    };
    let v = (mu + sigma_z16(var, d.z) + off) >> 32;
    if M0 {
        v.clamp(0, dn_max as i64) as u32
    } else {
        // |v| < 2^30 (μ and the offset below 2^61, σ z within ±2^52, over
        // 2^32): a word, clamped at 0 by a mask (low-light 4 M3
        // instructions a pixel fewer; 6 more on the M0), then at dn_max.
        let v = v as i32 & !(v as i32 >> 31);
        (v as u32).min(dn_max as u32)
    }
}

/// `a · b` for `a, b ≥ 0` (I32F32), equal to [`crate::num::scalar::Scalar::mul`]'s
/// (rounded down, saturated), inline: the noise stage's `K_sys μ_y` (out of
/// line, the general product cost the noisy scene 20 M3 instructions a
/// pixel more).
#[inline(always)]
#[cfg(test)]
pub fn mul_nonneg(a: Q, b: Q) -> Q {
    Q::from_bits(mul_nonneg_bits(a.to_bits().max(0) as u64, b.to_bits().max(0) as u64) as i64)
}

/// [`mul_nonneg`] of the raw values `x, y` (below 2⁶³): at most
/// `i64::MAX`.
#[inline(always)]
fn mul_nonneg_bits(x: u64, y: u64) -> u64 {
    let (xh, xl, yh, yl) = ((x >> 32) as u32, x as u32, (y >> 32) as u32, y as u32);
    // a b 2^32 / 2^64 = xh yh 2^32 + xh yl + xl yh + ⌊xl yl / 2^32⌋ (the
    // fraction below dropped: rounded down).
    if (xh | yh) >> 15 == 0 {
        return mul_small_bits(x, y);
    }
    let low = umul(xl, yl) >> 32;
    let hh = umul(xh, yh);
    let sum = (umul(xh, yl) as u128) + (umul(xl, yh) as u128) + low as u128 + ((hh as u128) << 32);
    sum.min(i64::MAX as u128) as u64
}

/// [`mul_nonneg_bits`] where both integer parts lie below 2¹⁵ (the
/// noise's `K_sys` and `μ_y`, DN): `hh < 2³⁰` and the rest below 2⁴⁹, so
/// the sum lies below `2⁶² + 2³²`, exact.
#[inline(always)]
fn mul_small_bits(x: u64, y: u64) -> u64 {
    let (xh, xl, yh, yl) = ((x >> 32) as u32, x as u32, (y >> 32) as u32, y as u32);
    (u64::from(xh * yh) << 32) + umul(xh, yl) + umul(xl, yh) + (umul(xl, yl) >> 32)
}

/// `σ z` (I32F32 DN) from `σ²` (I32F32 DN²; 0 below 0) and the draw `z`
/// (a multiple of 2⁻¹⁶ within ±9.1): [`sigma_z16`], as
/// [`crate::render::sensor::noise::Stage::apply_with`] takes it (the test of [`noisy_dn`]).
#[cfg(test)]
pub(super) fn sigma_z(var: Q, z: Q) -> Q {
    Q::from_bits(sigma_z16(var.to_bits().max(0) as u64, (z.to_bits() >> 16) as i32))
}

/// `σ z` (I32F32 DN bits, within ±2⁵²) from `σ²` (I32F32 DN² bits) and
/// `65 536 z` (within ±2²⁰): `σ` from [`rsqrt_norm`] (2⁻¹⁹ relative)
/// truncated to 2⁻¹⁶ DN — below 10⁻³ DN times `|z|` where `σ < 64 DN` —
/// instead of a bitwise square root, then one exact 64-bit product.
#[inline(always)]
pub(super) fn sigma_z16(s2: u64, z: i32) -> i64 {
    if s2 == 0 {
        return 0;
    }
    // √(s2 2^-32) 2^16 = √(m/2^32) 2^(32 − e/2): (m/2^32)·y in Q2.62.
    // m y < 2^62 (the Newton step from below: y ≤ 2^62/√(m 2^32), to
    // within its truncations; `tests`), so (m y) >> 30 fits a word, and the
    // shift by e/2 ≤ 31 is a word's: no 64-bit shift by a variable amount
    // (16 M3 instructions a pixel on low-light).
    let (m, e) = norm_top_even(s2);
    let y = rsqrt_top(m);
    let s16 = ((umul(m, y) >> 30) as u32) >> (e / 2);
    // S16 · S16 → S32; |z| < 2^20 in S16: within i64. (`smul_u`: on the
    // M0 the i64 product was a library call.)
    smul_u(z, s16)
}

/// The pixel word of channel values (each ≤ `dn_max`) for the [`chans`]
/// channels: the gray value, or RGB565's `r << 11 | g << 5 | b`. [`put`]
/// writes it.
#[inline(always)]
pub(super) fn word<const C: usize>(n: usize, dn: [u32; 3]) -> u16 {
    if chans::<C>(n) == 3 {
        ((dn[0] << 11) | (dn[1] << 5) | dn[2]) as u16
    } else {
        dn[0] as u16
    }
}

/// Writes a chunk's pixel words as [`PixelFormat::pack`] does: one byte
/// each, or two little-endian; `reversed`, last word first. Once a chunk
/// rather than once a pixel, so that one copy of the line loop serves
/// Gray8 and Gray16 (a copy per byte width cost 14 KB of flash). One byte
/// each four at a time ([`quads`]).
#[inline(always)]
pub(super) fn put(words: &[u16], reversed: bool, bytes_per_pixel: usize, out: &mut [u8]) {
    if bytes_per_pixel == 1 {
        // The chunk's words: a caller may hand its whole buffer ([`CHUNK`]
        // words) for a shorter chunk, whose last pixels `quads` would
        // otherwise pair with the buffer's unused words.
        quads(words.get(..out.len()).unwrap_or(words), reversed, out);
    } else {
        let (out, _) = out.as_chunks_mut::<2>();
        if reversed {
            out.iter_mut()
                .zip(words.iter().rev())
                .for_each(|(o, w)| *o = w.to_le_bytes());
        } else {
            out.iter_mut().zip(words).for_each(|(o, w)| *o = w.to_le_bytes());
        }
    }
}

/// `out[i] = src[i] as u8`, or of `src` read last first if `reversed`:
/// four bytes a step, a word each (a byte a step: the M3's
/// spheres-specular 469.4 against 461.1 instructions a pixel, standard
/// 229.4 against 228.1; the M3 camera's, a `compact` build, 228.9
/// against 226.7 for 304 B of flash) — except on the M0 (no unaligned
/// word store: there it took the standard scene 4 more), which takes a
/// byte a step.
#[inline(always)]
pub(super) fn quads<T: Copy + Into<u32>>(src: &[T], reversed: bool, out: &mut [u8]) {
    let b = |v: T| v.into() & 0xff;
    if M0 {
        if reversed {
            out.iter_mut()
                .zip(src.iter().rev())
                .for_each(|(o, s)| *o = b(*s) as u8);
        } else {
            out.iter_mut().zip(src).for_each(|(o, s)| *o = b(*s) as u8);
        }
        return;
    }
    let (o4, rest) = out.as_chunks_mut::<4>();
    if reversed {
        let mut s4 = src.rchunks_exact(4);
        for (o, s) in o4.iter_mut().zip(s4.by_ref()) {
            if let [p, q, r, t] = *s {
                *o = (b(t) | b(r) << 8 | b(q) << 16 | b(p) << 24).to_le_bytes();
            }
        }
        rest.iter_mut()
            .zip(s4.remainder().iter().rev())
            .for_each(|(o, s)| *o = b(*s) as u8);
    } else {
        let (s4, tail) = src.as_chunks::<4>();
        for (o, &[p, q, r, t]) in o4.iter_mut().zip(s4) {
            *o = (b(p) | b(q) << 8 | b(r) << 16 | b(t) << 24).to_le_bytes();
        }
        rest.iter_mut().zip(tail).for_each(|(o, s)| *o = b(*s) as u8);
    }
}

/// [`put`]s a chunk's words in `out` and its flags in `flags`, from `fl`;
/// `reversed`: the chunk's rays ran right to left (the mirrored columns of
/// [`Mix32::line_f`]). Out of line in a `compact` build: one copy for
/// every build of the loop (flash; a call a chunk).
#[cfg_attr(feature = "compact", inline(never))]
#[cfg_attr(not(feature = "compact"), inline(always))]
pub(super) fn store(
    words: &[u16],
    fl: &[u8],
    reversed: bool,
    bytes_per_pixel: usize,
    out: &mut [u8],
    flags: &mut [u8],
) {
    // Reversed as they are read, not in place: the M0 camera's opt-level z
    // build keeps `slice::reverse`'s swaps bounds-checked (a panic path).
    put(words, reversed, bytes_per_pixel, out);
    quads(fl, reversed, flags);
}

/// A line's pixels (`b` bytes each) and flags in chunks of [`CHUNK`]
/// pixels. (Not `pixels.chunks_mut(CHUNK * b)`: where the compiler keeps
/// its length out of line, it divides by the runtime chunk size there, a
/// panic path.)
pub(super) fn chunks<'a>(
    pixels: &'a mut [u8],
    flags: &'a mut [u8],
    b: usize,
) -> impl Iterator<Item = (&'a mut [u8], &'a mut [u8])> {
    let mut rest = pixels;
    flags.chunks_mut(CHUNK).map_while(move |f| {
        let (p, r) = core::mem::take(&mut rest).split_at_mut_checked(f.len() * b)?;
        rest = r;
        Some((p, f))
    })
}
