//! Vignetting and exposure (camera-model.md §5), per pixel in I32F32.
//!
//! `E = L π/4 (d/f)² cos⁴α`, `cos⁴α = 1 / (1 + x̂² + ŷ²)²` for the
//! undistorted normalized point (no root, no trigonometry);
//! `DN = min(DN_max, floor(K E + 1/2))`. Telecentric (orthographic) cameras
//! have no `cos⁴` fall-off: the renderer leaves the stage out.

use crate::num::{quotient, Angle, Wide};
use crate::scene::Q;
use core::ops::Mul as _;

/// `cos⁴α = 1 / (1 + x̂² + ŷ²)²` (saturating; 0 only for slopes beyond the
/// renderer's range).
#[inline(always)]
pub fn cos4(x: Q, y: Q) -> Q {
    let w = Q::ONE
        .saturating_add(x.saturating_mul(x))
        .saturating_add(y.saturating_mul(y));
    Q::ONE.checked_div(w.saturating_mul(w)).unwrap_or(Q::ZERO)
}

/// The per-frame gain `K π/4 (d/f)² · num/den`: DN per unit radiance on the
/// axis (`num/den` is the channel's full-scale factor,
/// [`crate::scene::PixelFormat::channel_scale`]). `d_over_f` is `d/f`.
pub fn gain(exposure: Q, d_over_f: Wide, (num, den): (u32, u32)) -> Q {
    let pi = Wide::of(Angle::PI);
    let base = Wide::of(exposure).mul(pi).mul(d_over_f).mul(d_over_f);
    quotient::<Q>(base.mul(Wide::int(num as i64)), Wide::int(4 * den as i64)).value
}

/// `DN = min(DN_max, floor(gain · L · cos4 + 1/2))`, never negative, never
/// wrapped.
#[inline(always)]
pub fn quantize(gain: Q, radiance: Q, cos4: Q, dn_max: u32) -> u32 {
    let half = Q::from_bits(1 << 31);
    let v = gain
        .saturating_mul(radiance)
        .saturating_mul(cos4)
        .saturating_add(half);
    v.to_num::<i64>().clamp(0, dn_max as i64) as u32
}
