//! Shading (camera-model.md §6): the mixed BRDF, point and directional
//! lights, the ambient term — per pixel, in any [`Scalar`] (I32F32 by
//! default) with saturating arithmetic.
//!
//! Radiance towards the viewer of a point `P` with unit normal `n̂`, unit
//! direction to the viewer `v̂`:
//! `L = Σ BRDF · E_i + ρ A`, `BRDF = n ρ/π + (1 − n) ρ_s (s+2)/(2π) max(0, r̂·v̂)^s`,
//! `r̂ = 2 (n̂·l̂) n̂ − l̂`; `E_i = I/r² max(0, n̂·l̂)` (point) or
//! `E₀ max(0, n̂·l̂)` (directional).

use crate::num::scalar::Scalar;
use crate::num::{quotient, Angle, Wide};
use crate::scene::{Material, Q};
use core::ops::{Mul as _, Sub as _};

/// A vector of three per-pixel values (a point, direction or colour).
pub type V3<S = Q> = [S; 3];

#[inline(always)]
pub(crate) fn dot<S: Scalar>(a: V3<S>, b: V3<S>) -> S {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}
/// [`dot`] of a frame's constant `k` (a plane's normal, a rectangle's or a
/// checker's axis) and `v`, leaving out `k`'s zero components: the same
/// sum (a product by zero is zero, and adding zero never saturates),
/// without their products, which axis-aligned geometry has two of each.
#[inline(always)]
pub(crate) fn dot_k<S: Scalar>(k: V3<S>, v: V3<S>) -> S {
    let term = |a: S, b: S| if a == S::ZERO { S::ZERO } else { a.mul(b) };
    term(k[0], v[0]).add(term(k[1], v[1])).add(term(k[2], v[2]))
}
#[inline(always)]
pub(crate) fn sub3<S: Scalar>(a: V3<S>, b: V3<S>) -> V3<S> {
    [a[0].sub(b[0]), a[1].sub(b[1]), a[2].sub(b[2])]
}
#[inline(always)]
pub(crate) fn axpy<S: Scalar>(t: S, d: V3<S>, o: V3<S>) -> V3<S> {
    [
        o[0].add(t.mul(d[0])),
        o[1].add(t.mul(d[1])),
        o[2].add(t.mul(d[2])),
    ]
}
#[inline(always)]
pub(crate) fn scale3<S: Scalar>(t: S, d: V3<S>) -> V3<S> {
    [t.mul(d[0]), t.mul(d[1]), t.mul(d[2])]
}

/// A light in the frame shading works in (the renderer's: the camera frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadingLight<S: Scalar = Q> {
    /// Point light at `p` with intensity `i` per channel (W/sr).
    Point {
        /// Position, metres.
        p: V3<S>,
        /// Intensity per channel, W/sr.
        i: V3<S>,
    },
    /// Directional light: unit direction `l` towards it, irradiance `e`
    /// per channel (W/m²).
    Directional {
        /// Unit direction towards the light.
        l: V3<S>,
        /// Irradiance per channel, W/m².
        e: V3<S>,
    },
}

/// A material with its constants folded once per frame:
/// `kd = n ρ/π`, `ks = (1 − n) ρ_s (s + 2)/(2π)`, `ka = ρ A`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Brdf<S: Scalar = Q> {
    /// Diffuse constant per channel.
    pub kd: V3<S>,
    /// Specular constant per channel.
    pub ks: V3<S>,
    /// Ambient radiance per channel.
    pub ka: V3<S>,
    /// Phong exponent `s`.
    pub exponent: u16,
}

/// An I32F32 vector in another scalar type (saturating).
#[inline(always)]
pub(crate) fn from_q3<S: Scalar>(v: V3) -> V3<S> {
    v.map(S::from_q)
}

impl ShadingLight {
    /// The same light with values in `S` (prepared in I32F32, converted
    /// once a frame).
    pub fn to<S: Scalar>(&self) -> ShadingLight<S> {
        match *self {
            ShadingLight::Point { p, i } => ShadingLight::Point {
                p: from_q3(p),
                i: from_q3(i),
            },
            ShadingLight::Directional { l, e } => ShadingLight::Directional {
                l: from_q3(l),
                e: from_q3(e),
            },
        }
    }
}

impl<S: Scalar> Brdf<S> {
    /// All constants 0 (no light leaves the surface).
    pub const ZERO: Brdf<S> = Brdf {
        kd: [S::ZERO; 3],
        ks: [S::ZERO; 3],
        ka: [S::ZERO; 3],
        exponent: 0,
    };
}

impl Brdf {
    /// The same constants in `S` (folded in I32F32, converted once a frame).
    pub fn to<S: Scalar>(&self) -> Brdf<S> {
        Brdf {
            kd: from_q3(self.kd),
            ks: from_q3(self.ks),
            ka: from_q3(self.ka),
            exponent: self.exponent,
        }
    }
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
        // The quotients of the channel before where its albedos repeat (a
        // gray material: one division, not three), and no lobe's quotient
        // where its product is 0 — the same values, fewer 128-bit
        // divisions (the driven camera folds every material each pose it
        // plans).
        let mut last: Option<([Q; 2], [Q; 2])> = None;
        for c in 0..3 {
            let (Some(rho), Some(rhos), Some(amb)) = (m.albedo.get(c), m.specular.get(c), ambient.get(c))
            else {
                continue;
            };
            let [d, s] = match last {
                Some((albedos, k)) if albedos == [*rho, *rhos] => k,
                _ => [
                    quotient::<Q>(n.mul(Wide::of(*rho)), pi).value,
                    if *rhos == Q::ZERO || m.mix == Q::ONE {
                        Q::ZERO
                    } else {
                        quotient::<Q>(ns.mul(Wide::of(*rhos)).mul(lobe), pi.mul(Wide::int(2))).value
                    },
                ],
            };
            last = Some(([*rho, *rhos], [d, s]));
            if let (Some(kd), Some(ks), Some(ka)) = (b.kd.get_mut(c), b.ks.get_mut(c), b.ka.get_mut(c)) {
                (*kd, *ks) = (d, s);
                *ka = Wide::of(*rho).mul(Wide::of(*amb)).narrow::<Q>().value;
            }
        }
        b
    }
}

/// Radiance per channel leaving `point` (unit `normal`, facing the viewer)
/// towards the viewer (unit `view`), for the first `channels` channels (the
/// others are left at the ambient term), without the lights of bit set in
/// `shadowed` ([`crate::render::shadows`]). With `SPEC = false` the
/// specular lobe is left out (the scene has none).
///
/// In I32F32 the relative error is ≤ 10⁻⁶ + (s + 2)·10⁻⁹ / r², `r`
/// (metres) the distance to the nearest point light: the Phong lobe turns
/// the 2⁻³² absolute rounding of `r²` into `s` times as much relative error
/// (measured by `tests/shading.rs`). Other scalar types: `host-sim tradeoff`.
#[inline]
pub fn radiance<S: Scalar, const SPEC: bool>(
    mat: &Brdf<S>,
    lights: &[ShadingLight<S>],
    point: V3<S>,
    normal: V3<S>,
    view: V3<S>,
    channels: usize,
    shadowed: u8,
) -> V3<S> {
    let mut l = mat.ka;
    for (li, light) in lights.iter().enumerate() {
        if shadowed & (1 << li) != 0 {
            continue;
        }
        // The light's direction, a factor k and its per-channel strength:
        // irradiance E_c = k · strength_c (computed per rendered channel).
        let (ldir, k, strength) = match *light {
            ShadingLight::Point { p, i } => {
                let lv = sub3(p, point);
                let r2 = dot(lv, lv);
                let Some(r) = r2.sqrt() else { continue };
                let Some(inv_r) = S::ONE.div(r) else {
                    continue;
                };
                if SPEC {
                    let ldir = scale3(inv_r, lv);
                    let cos = dot(normal, ldir);
                    if cos <= S::ZERO {
                        continue;
                    }
                    let k = cos.div(r2).unwrap_or(S::MAX);
                    (ldir, k, i)
                } else {
                    // Without the lobe the direction itself is not needed:
                    // cos/r² = (n̂·l) (1/r)³, one division fewer.
                    let nl = dot(normal, lv);
                    if nl <= S::ZERO {
                        continue;
                    }
                    let k = nl.mul(inv_r).mul(inv_r).mul(inv_r);
                    (lv, k, i)
                }
            }
            ShadingLight::Directional { l, e } => {
                let cos = dot(normal, l);
                if cos <= S::ZERO {
                    continue;
                }
                (l, cos, e)
            }
        };
        let lobe = if SPEC {
            let nl = dot(normal, ldir);
            let rv = nl.add(nl).mul(dot(normal, view)).sub(dot(ldir, view));
            Some(S::lobe(rv, mat.exponent))
        } else {
            None
        };
        for c in 0..channels.min(3) {
            let (Some(kd), Some(ks), Some(sc), Some(lc)) =
                (mat.kd.get(c), mat.ks.get(c), strength.get(c), l.get_mut(c))
            else {
                continue;
            };
            let ec = k.mul(*sc);
            let mut v = kd.mul(ec);
            if let Some(f) = lobe {
                v = v.add(S::scale_lobe(ks.mul(ec), f));
            }
            *lc = lc.add(v);
        }
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use fixed::types::I32F32;

    /// `dot_k` is `dot` where the constant has zero components, on values
    /// that saturate as well as on ordinary ones (I32F32, the wide
    /// arithmetic's type).
    #[test]
    fn the_sparse_dot_is_the_dot() {
        let mut next = crate::num::scalar::spread_i32();
        let mut zeros = 0;
        for _ in 0..100_000 {
            let mut v = || {
                let (a, b) = (next(), next());
                I32F32::from_bits(((a as i64) << (b as u32 & 31)) ^ b as i64)
            };
            let mut k = [v(), v(), v()];
            let w = [v(), v(), v()];
            // Zero one or two of the constant's components, or none.
            let pick = (w[0].to_bits() as u64 % 7) as usize;
            for (i, c) in k.iter_mut().enumerate() {
                if pick & (1 << i) != 0 {
                    *c = I32F32::ZERO;
                    zeros += 1;
                }
            }
            assert_eq!(dot_k(k, w), dot(k, w), "{k:?} . {w:?}");
            assert_eq!(dot_k(k, w), dot(w, k), "{w:?} . {k:?}");
        }
        assert!(zeros > 50_000, "{zeros}");
    }
}
