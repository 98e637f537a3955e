//! Vignetting and exposure (camera-model.md §5), per pixel in any
//! [`Scalar`] (I32F32 by default).
//!
//! `E = L π/4 (d/f)² cos⁴α`, `cos⁴α = 1 / (1 + x̂² + ŷ²)²` for the
//! undistorted normalized point (no root, no trigonometry), times the
//! distortion's area factor `J` where there is distortion ([`area_factor`]);
//! `DN = min(DN_max, floor(K E + 1/2))`. Telecentric (orthographic) cameras
//! have no `cos⁴` fall-off: the renderer leaves the stage out.

use crate::num::scalar::Scalar;
use crate::num::{quotient, Angle, Wide};
use crate::scene::Q;
use core::ops::Mul as _;

/// `cos⁴α = 1 / (1 + x̂² + ŷ²)²` (saturating; 0 only for slopes beyond the
/// renderer's range).
#[inline(always)]
pub fn cos4<S: Scalar>(x: S, y: S) -> S {
    cos4_of(S::ONE.add(x.mul(x)).add(y.mul(y)))
}

/// `cos⁴α = 1/a²` from `a = 1 + x̂² + ŷ²` (the perspective ray's `d·d`,
/// which the renderer has computed already).
#[inline(always)]
pub(crate) fn cos4_of<S: Scalar>(a: S) -> S {
    S::ONE.div(a.mul(a)).unwrap_or(S::ZERO)
}

/// The relative illumination under radial distortion (camera-model.md §5):
/// the area factor `J = g (g + 2u g')` of the distorted slopes `(x̂_d,
/// ŷ_d)`, `u = x̂_d² + ŷ_d²`, `g = 1 + k1 u + k2 u²`, `g' = k1 + 2 k2 u`.
/// Irradiance is `E(x̂, ŷ) · J`: barrel corners (`J > 1`) gather the light
/// of a larger undistorted area.
#[inline(always)]
pub fn area_factor<S: Scalar>(xd: S, yd: S, [k1, k2]: [S; 2]) -> S {
    let u = xd.mul(xd).add(yd.mul(yd));
    let k2u = u.mul(k2);
    let g = S::ONE.add(u.mul(k1.add(k2u)));
    let dg = k1.add(k2u).add(k2u);
    let ug = u.mul(dg);
    g.mul(g.add(ug).add(ug))
}

/// The per-frame gain `K π/4 (d/f)² · num/den`: DN per unit radiance on the
/// axis (`num/den` is the channel's full-scale factor,
/// [`crate::scene::PixelFormat::channel_scale`]). `d_over_f` is `d/f`.
pub fn gain(exposure: Q, d_over_f: Wide, (num, den): (u32, u32)) -> Q {
    let pi = Wide::of(Angle::PI);
    let base = Wide::of(exposure).mul(pi).mul(d_over_f).mul(d_over_f);
    quotient::<Q>(base.mul(Wide::int(num as i64)), Wide::int(4 * den as i64)).value
}

/// `K E = gain · L · cos4`: the pixel value in DN before rounding.
#[inline(always)]
pub fn exposure<S: Scalar>(gain: S, radiance: S, cos4: S) -> S {
    gain.mul(radiance).mul(cos4)
}

/// `DN = min(DN_max, floor(v + 1/2))` of a value `v` in DN, never negative,
/// never wrapped.
#[inline(always)]
pub fn round_dn<S: Scalar>(v: S, dn_max: u32) -> u32 {
    v.add(S::HALF).floor_int().clamp(0, dn_max as i64) as u32
}

/// `DN = min(DN_max, floor(gain · L · cos4 + 1/2))`, never negative, never
/// wrapped.
#[inline(always)]
pub fn quantize<S: Scalar>(gain: S, radiance: S, cos4: S, dn_max: u32) -> u32 {
    round_dn(exposure(gain, radiance, cos4), dn_max)
}
