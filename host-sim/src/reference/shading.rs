//! Reference shading (camera-model.md §6): the mixed BRDF, point and
//! directional lights, ambient term.

use super::{dot, V3};
use std::f64::consts::PI;

/// A material in f64, per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// `ρ`.
    pub albedo: [f64; 3],
    /// `ρ_s`.
    pub specular: [f64; 3],
    /// `n`.
    pub mix: f64,
    /// `s`.
    pub exponent: u16,
}

/// A light in f64 (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Intensity `I` per channel at a position.
    Point {
        /// Position.
        position: V3,
        /// W/sr.
        intensity: [f64; 3],
    },
    /// Irradiance `E₀` per channel from a direction.
    Directional {
        /// Unit direction towards the light.
        towards: V3,
        /// W/m².
        irradiance: [f64; 3],
    },
}

/// `BRDF = n ρ/π + (1 − n) ρ_s (s + 2)/(2π) max(0, r̂·v̂)^s`,
/// `r̂ = 2 (n̂·l̂) n̂ − l̂`.
pub fn brdf(m: &Material, c: usize, n: V3, l: V3, v: V3) -> f64 {
    let nl = dot(n, l);
    let r = [
        2.0 * nl * n[0] - l[0],
        2.0 * nl * n[1] - l[1],
        2.0 * nl * n[2] - l[2],
    ];
    let lobe = dot(r, v).max(0.0).powi(m.exponent as i32);
    m.mix * m.albedo[c] / PI + (1.0 - m.mix) * m.specular[c] * (m.exponent as f64 + 2.0) / (2.0 * PI) * lobe
}

/// Radiance towards the viewer (unit `v` from the point to the viewer) of a
/// point `p` with unit normal `n`: `Σ BRDF E_i + ρ A`, the sum over the
/// lights not shadowed there (bit `i` of `shadowed` set: light `i` is).
pub fn radiance(
    m: &Material,
    lights: &[Light],
    ambient: [f64; 3],
    (p, n, v): (V3, V3, V3),
    shadowed: u8,
) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let mut l_sum = m.albedo[c] * ambient[c];
        for (i, light) in lights.iter().enumerate() {
            if shadowed & (1 << i) != 0 {
                continue;
            }
            let (l, e) = match *light {
                Light::Point { position, intensity } => {
                    let d = [position[0] - p[0], position[1] - p[1], position[2] - p[2]];
                    let r2 = dot(d, d);
                    let r = r2.sqrt();
                    let l = [d[0] / r, d[1] / r, d[2] / r];
                    (l, intensity[c] / r2 * dot(n, l).max(0.0))
                }
                Light::Directional { towards, irradiance } => {
                    (towards, irradiance[c] * dot(n, towards).max(0.0))
                }
            };
            if e > 0.0 {
                l_sum += brdf(m, c, n, l, v) * e;
            }
        }
        *o = l_sum;
    }
    out
}
