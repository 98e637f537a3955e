//! Shading (camera-model.md §6): the mixed BRDF, point and directional
//! lights, the ambient term — per pixel, in I32F32 with saturating
//! arithmetic.
//!
//! Radiance towards the viewer of a point `P` with unit normal `n̂`, unit
//! direction to the viewer `v̂`:
//! `L = Σ BRDF · E_i + ρ A`, `BRDF = n ρ/π + (1 − n) ρ_s (s+2)/(2π) max(0, r̂·v̂)^s`,
//! `r̂ = 2 (n̂·l̂) n̂ − l̂`; `E_i = I/r² max(0, n̂·l̂)` (point) or
//! `E₀ max(0, n̂·l̂)` (directional).

use crate::num::{quotient, Angle, Wide};
use crate::scene::{Material, Q};
use core::ops::{Mul as _, Sub as _};

/// A vector of three I32F32 values (a point, direction or colour).
pub type V3 = [Q; 3];

/// Saturating I32F32 product. Kept out of line: inlined at every use it made
/// each pixel loop 25 KB on Cortex-M (the 64-bit product with its saturation
/// checks is long there).
#[inline(never)]
pub(crate) fn mul(a: Q, b: Q) -> Q {
    a.saturating_mul(b)
}
#[inline(always)]
pub(crate) fn add(a: Q, b: Q) -> Q {
    a.saturating_add(b)
}
#[inline(always)]
pub(crate) fn sub(a: Q, b: Q) -> Q {
    a.saturating_sub(b)
}
#[inline(always)]
pub(crate) fn dot(a: V3, b: V3) -> Q {
    add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
}
#[inline(always)]
pub(crate) fn sub3(a: V3, b: V3) -> V3 {
    [sub(a[0], b[0]), sub(a[1], b[1]), sub(a[2], b[2])]
}
#[inline(always)]
pub(crate) fn axpy(t: Q, d: V3, o: V3) -> V3 {
    [
        add(o[0], mul(t, d[0])),
        add(o[1], mul(t, d[1])),
        add(o[2], mul(t, d[2])),
    ]
}
#[inline(always)]
pub(crate) fn scale3(t: Q, d: V3) -> V3 {
    [mul(t, d[0]), mul(t, d[1]), mul(t, d[2])]
}

/// A light in the frame shading works in (the renderer's: the camera frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingLight {
    /// Point light at `p` with intensity `i` per channel (W/sr).
    Point {
        /// Position, metres.
        p: V3,
        /// Intensity per channel, W/sr.
        i: V3,
    },
    /// Directional light: unit direction `l` towards it, irradiance `e`
    /// per channel (W/m²).
    Directional {
        /// Unit direction towards the light.
        l: V3,
        /// Irradiance per channel, W/m².
        e: V3,
    },
}

/// A material with its constants folded once per frame:
/// `kd = n ρ/π`, `ks = (1 − n) ρ_s (s + 2)/(2π)`, `ka = ρ A`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Brdf {
    /// Diffuse constant per channel.
    pub kd: V3,
    /// Specular constant per channel.
    pub ks: V3,
    /// Ambient radiance per channel.
    pub ka: V3,
    /// Phong exponent `s`.
    pub exponent: u16,
}

impl Brdf {
    /// Folds a material's constants, with ambient `A` per channel.
    pub fn new(m: &Material, ambient: V3) -> Brdf {
        let pi = Wide::of(Angle::PI);
        let n = Wide::of(m.mix);
        let ns = Wide::int(1).sub(n);
        let lobe = Wide::int(m.exponent as i64 + 2);
        let mut b = Brdf {
            exponent: m.exponent,
            ..Brdf::default()
        };
        for c in 0..3 {
            let (Some(rho), Some(rhos), Some(amb)) = (m.albedo.get(c), m.specular.get(c), ambient.get(c))
            else {
                continue;
            };
            if let (Some(kd), Some(ks), Some(ka)) = (b.kd.get_mut(c), b.ks.get_mut(c), b.ka.get_mut(c)) {
                *kd = quotient::<Q>(n.mul(Wide::of(*rho)), pi).value;
                *ks = quotient::<Q>(ns.mul(Wide::of(*rhos)).mul(lobe), pi.mul(Wide::int(2))).value;
                *ka = Wide::of(*rho).mul(Wide::of(*amb)).narrow::<Q>().value;
            }
        }
        b
    }
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
#[inline]
pub fn powi(x: Q, mut n: u16) -> u64 {
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

/// `v · f` for a fraction `f` with 63 fractional bits, rounded.
#[inline(always)]
fn scale63(v: Q, f: u64) -> Q {
    Q::from_bits(((v.to_bits() as i128 * f as i128 + (1i128 << 62)) >> 63) as i64)
}

/// Radiance per channel leaving `point` (unit `normal`, facing the viewer)
/// towards the viewer (unit `view`). With `SPEC = false` the specular lobe
/// is left out (the scene has none).
///
/// Relative error ≤ 10⁻⁶ + (s + 2)·10⁻⁹ / r², `r` (metres) the distance to
/// the nearest point light: the Phong lobe turns the 2⁻³² absolute rounding
/// of `r²` into `s` times as much relative error (measured by
/// `tests/shading.rs`).
#[inline]
pub fn radiance<const SPEC: bool>(
    mat: &Brdf,
    lights: &[ShadingLight],
    point: V3,
    normal: V3,
    view: V3,
) -> V3 {
    let mut l = mat.ka;
    for light in lights {
        let (ldir, e) = match *light {
            ShadingLight::Point { p, i } => {
                let lv = sub3(p, point);
                let r2 = dot(lv, lv);
                let Some(r) = r2.checked_sqrt() else { continue };
                let Some(inv_r) = Q::ONE.checked_div(r) else {
                    continue;
                };
                let ldir = scale3(inv_r, lv);
                let cos = dot(normal, ldir);
                if cos <= Q::ZERO {
                    continue;
                }
                let k = cos.checked_div(r2).unwrap_or(Q::MAX);
                (ldir, scale3(k, i))
            }
            ShadingLight::Directional { l, e } => {
                let cos = dot(normal, l);
                if cos <= Q::ZERO {
                    continue;
                }
                (l, scale3(cos, e))
            }
        };
        let lobe = if SPEC {
            let nl = dot(normal, ldir);
            let rv = sub(mul(add(nl, nl), dot(normal, view)), dot(ldir, view));
            powi(rv.max(Q::ZERO), mat.exponent)
        } else {
            0
        };
        for c in 0..3 {
            let (Some(kd), Some(ks), Some(ec), Some(lc)) =
                (mat.kd.get(c), mat.ks.get(c), e.get(c), l.get_mut(c))
            else {
                continue;
            };
            let mut v = mul(*kd, *ec);
            if SPEC {
                v = add(v, scale63(mul(*ks, *ec), lobe));
            }
            *lc = add(*lc, v);
        }
    }
    l
}
