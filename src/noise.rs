//! Sensor noise (camera-model.md §9): the EMVA 1288 linear camera model,
//! from a counter-based generator, so that a pixel's noise depends on
//! (seed, frame id, pixel index, channel) only — not on the order pixels
//! are rendered in — and is the same on every target.
//!
//! **Generator** (docs/sensor.md): `mix` is the SplitMix64 finaliser
//! (`z ^= z >> 30; z *= 0xbf58476d1ce4e5b9; z ^= z >> 27;
//! z *= 0x94d049bb133111eb; z ^= z >> 31`, arithmetic mod 2⁶⁴). A frame's
//! key is `mix(seed + mix(frame_id + 1))`; draw `k` (0, 1, 2) of channel `c`
//! of pixel `p = j · width + i` is `h_k = mix(key ^ (p << 4 | c << 2 | k))`.
//! **Normal transform:** the twelve 16-bit words `u` of `h_0, h_1, h_2`
//! (least significant first) give `z = (Σ u − 393 210) / 65 536` — the
//! Irwin–Hall sum of twelve uniforms: mean 0, variance `1 − 2⁻³²`, within
//! ±6. Integer until the last step, so the reference computes the same `z`.
//!
//! **Recorded value:** with `μ_y` the noise-free pixel value (DN, before
//! rounding), `K_sys = DN_max / μ_e,sat`, the noise in DN is
//! `z · sqrt(K_sys μ_y + (K_sys σ_d)²)` (shot noise of `μ_e = μ_y / K_sys`
//! electrons plus dark noise), and
//! `DN = clamp(floor(μ_y + noise + μ_y,dark + ½), 0, DN_max)`.

use crate::scalar::Scalar;
use crate::scene::{Noise, PixelFormat, Q};

/// The SplitMix64 finaliser.
#[inline]
pub const fn mix(mut z: u64) -> u64 {
    z = crate::num::wrapping_mul64(z ^ (z >> 30), 0xbf58_476d_1ce4_e5b9);
    z = crate::num::wrapping_mul64(z ^ (z >> 27), 0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A frame's key.
pub const fn frame_key(seed: u64, frame_id: u32) -> u64 {
    mix(seed.wrapping_add(mix(frame_id as u64 + 1)))
}

/// `65 536 z` for channel `c` of pixel `p` (an integer within ±393 210).
#[inline]
pub fn normal_q16(key: u64, pixel: u32, channel: u8) -> i32 {
    let base = (u64::from(pixel) << 4) | (u64::from(channel & 3) << 2);
    // The sum of the four 16-bit words of three hashes, written out: the
    // loops are not unrolled at opt-level "s" (the firmware's), which cost
    // low-light 187 M3 instructions a pixel. Loops with the `compact`
    // feature (the driven camera's, bound by flash).
    let words = |k: u64| {
        let h = mix(key ^ (base | k));
        if cfg!(feature = "compact") {
            (0..4).map(|w| (h >> (16 * w)) & 0xffff).sum::<u64>()
        } else {
            (h & 0xffff) + ((h >> 16) & 0xffff) + ((h >> 32) & 0xffff) + (h >> 48)
        }
    };
    let sum = if cfg!(feature = "compact") {
        (0..3).map(words).sum::<u64>()
    } else {
        words(0) + words(1) + words(2)
    };
    (sum as i64 - 393_210) as i32
}

/// The noise stage of a frame, in the renderer's scalar.
#[derive(Clone, Copy, Debug)]
pub struct Stage<S> {
    /// `K_sys` per channel, DN per electron.
    ksys: [S; 3],
    /// `(K_sys σ_d)²` per channel, DN².
    dark_var: [S; 3],
    /// `μ_y,dark` per channel plus ½ (the rounding), DN.
    offset: [S; 3],
    key: u64,
}

impl<S: Scalar> Stage<S> {
    /// The stage for `noise` on `format`, frame `frame_id`. The dark offset
    /// is in DN of the first channel; a channel with a larger full scale
    /// (RGB565 green) scales it like the exposure. In I32F32, saturating.
    pub fn new(noise: &Noise, format: PixelFormat, frame_id: u32) -> Stage<S> {
        let mut st = Stage {
            ksys: [S::ZERO; 3],
            dark_var: [S::ZERO; 3],
            offset: [S::HALF; 3],
            key: frame_key(noise.seed, frame_id),
        };
        for c in 0..3 {
            let [k, var, off] = channel_constants(noise, format.dn_max(c), format.dn_max(0));
            if let (Some(a), Some(b), Some(o)) =
                (st.ksys.get_mut(c), st.dark_var.get_mut(c), st.offset.get_mut(c))
            {
                *a = S::from_q(k);
                *b = S::from_q(var);
                *o = S::from_q(off);
            }
        }
        st
    }

    /// The stage of a scene's `noise` (if any) for frame `frame_id`;
    /// `None` without the `sensor` feature.
    pub fn for_frame(noise: Option<Noise>, format: PixelFormat, frame_id: u32) -> Option<Stage<S>> {
        match noise {
            Some(z) if cfg!(feature = "sensor") => Some(Stage::new(&z, format, frame_id)),
            _ => None,
        }
    }

    /// The recorded value of channel `c` of pixel `p` whose noise-free value
    /// is `mu` DN (before rounding), clamped to `[0, dn_max]`.
    #[inline]
    pub fn apply(&self, mu: S, pixel: u32, c: usize, dn_max: u32) -> u32 {
        self.apply_with(mu, pixel, c, dn_max, S::mul, |var, z| {
            var.sqrt().unwrap_or(S::ZERO).mul(z)
        })
    }

    /// The constants of channel `c` and the draw `z` of channel `c` of pixel
    /// `pixel`: what [`Stage::apply_with`] combines, for an arithmetic that
    /// combines them its own way (the fast one's [`crate::mix32`]).
    #[inline(always)]
    pub fn draw(&self, pixel: u32, c: usize) -> Draw<S> {
        Draw {
            ksys: self.ksys.get(c).copied().unwrap_or(S::ZERO),
            dark_var: self.dark_var.get(c).copied().unwrap_or(S::ZERO),
            offset: self.offset.get(c).copied().unwrap_or(S::HALF),
            z: normal_q16(self.key, pixel, c as u8),
        }
    }

    /// [`Stage::apply`] with `mul` giving `K_sys μ_y` (both ≥ 0) as
    /// [`Scalar::mul`] does, and `noise` the noise term `σ z` from `σ²` and
    /// the draw `z`: the fast arithmetic's own products and square root.
    /// Inlined into each caller: out of line (once a build has more than
    /// one), the call cost the noisy scene 14 M3 instructions a pixel.
    #[inline(always)]
    pub fn apply_with(
        &self,
        mu: S,
        pixel: u32,
        c: usize,
        dn_max: u32,
        mul: impl FnOnce(S, S) -> S,
        noise: impl FnOnce(S, S) -> S,
    ) -> u32 {
        let d = self.draw(pixel, c);
        let mu = if mu > S::ZERO { mu } else { S::ZERO };
        let z = S::from_q(Q::from_bits(i64::from(d.z) << 16));
        let v = mu.add(noise(mul(d.ksys, mu).add(d.dark_var), z)).add(d.offset);
        v.floor_int().clamp(0, i64::from(dn_max)) as u32
    }
}

/// One draw of [`Stage::draw`]: a channel's constants and the pixel's `z`.
#[derive(Clone, Copy, Debug)]
pub struct Draw<S> {
    /// `K_sys`, DN per electron (≥ 0).
    pub ksys: S,
    /// `(K_sys σ_d)²`, DN² (≥ 0).
    pub dark_var: S,
    /// `μ_y,dark + ½`, DN (≥ ½).
    pub offset: S,
    /// `65 536 z` ([`normal_q16`]: within ±393 210).
    pub z: i32,
}

/// `K_sys = dn/μ_e,sat`, `(K_sys σ_d)²` and `μ_y,dark · dn/dn0 + ½` of a
/// channel of full scale `dn` (`dn0` the first channel's), I32F32 from
/// integer arithmetic on the raw values, saturating.
#[inline(never)]
fn channel_constants(noise: &Noise, dn: u32, dn0: u32) -> [Q; 3] {
    let q = |v: u128| Q::from_bits(v.min(i64::MAX as u128) as i64);
    let raw = |v: Q| v.to_bits().max(0) as u128;
    let sat = raw(noise.saturation_e).max(1);
    let k = (u128::from(dn) << 64) / sat;
    let dark = k.saturating_mul(raw(noise.dark_noise_e)) >> 32;
    let var = dark
        .min(u128::from(u64::MAX))
        .saturating_mul(dark.min(u128::from(u64::MAX)))
        >> 32;
    let off = raw(noise.dark_offset_dn).saturating_mul(u128::from(dn)) / u128::from(dn0.max(1)) + (1 << 31);
    [q(k), q(var), q(off)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_variance_and_zero_mean() {
        let key = frame_key(7, 3);
        let n = 200_000u32;
        let (mut s, mut s2) = (0f64, 0f64);
        for p in 0..n {
            let z = f64::from(normal_q16(key, p, 0)) / 65536.0;
            s += z;
            s2 += z * z;
        }
        let mean = s / f64::from(n);
        let var = s2 / f64::from(n) - mean * mean;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "variance {var}");
    }

    #[test]
    fn draws_depend_on_every_key_part() {
        let k = frame_key(1, 0);
        let z = normal_q16(k, 5, 0);
        assert_ne!(z, normal_q16(k, 6, 0));
        assert_ne!(z, normal_q16(k, 5, 1));
        assert_ne!(z, normal_q16(frame_key(1, 1), 5, 0));
        assert_ne!(z, normal_q16(frame_key(2, 0), 5, 0));
    }
}
