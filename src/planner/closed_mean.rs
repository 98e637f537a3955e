//! The closed plane's interpolated sums ([`crate::render::ClosedMean`]):
//! their error bound and what they save.

use super::geometry::{dot3, norm3, prim_light_distance, Geometry};
use crate::num::FixedF64;
use crate::render::ClosedMean;
use crate::scene::{Light, Scene};

/// The bound of `closed_mean_err` (the pairs') times what the
/// interpolation `m` multiplies it by: over `s` rays its largest
/// curvature term is `s²/8 · max|φ''|` (`M`), 4 times the pairs' over 4
/// rays, 16 over 8; 0 without it. The means of means below it stay
/// within it: over 8 rays the rays 4 apart are within `8M`, those 2
/// apart within `2M + 8M/2`, the odd ones within `M/2 + (6M + 8M)/2`;
/// over 4, `2M` and `M/2 + 2M/2`. (The roundings down, one a level, are
/// within the `2⁻¹⁵` it scales.)
pub fn closed_mean_factor(m: ClosedMean) -> f64 {
    let s = f64::from(m.span());
    if m.on() {
        s * s / 4.0
    } else {
        0.0
    }
}

/// The share of the closed plane's light terms that the interpolation `m`
/// leaves out in a chunk of 32 rays ([`ClosedMean::shaded`]), in units of
/// the pairs' (15 of 32 left out): `Quads` leaves out 22 and `Octs` 25,
/// so 22/15 and 25/15.
pub fn closed_mean_skipped(m: ClosedMean) -> f64 {
    const RAYS: usize = 32;
    let left_out = |m: ClosedMean| (RAYS - m.shaded(RAYS)) as f64;
    left_out(m) / left_out(ClosedMean::Pairs)
}

/// A bound, DN, on what the closed plane's mean (`mix32::mean`,
/// [`Options::closed_mean`]) moves a pixel's sum: the plane's term under
/// its one point light, `T = D (h/r)³` (`D` at the light's foot, `h` its
/// height, `r = |p − P_L|`), taken at a ray between two as their mean.
/// Along a row `φ(i) = T(p(i))`, and `|φ(i) − (φ(i−1) + φ(i+1))/2| ≤
/// max|φ''|/2`, with `φ'' = p'ᵀ H p' + ∇T·p''`. The hit moves on the
/// plane, so `H` and `∇T` are those of `T` on the plane, a function of the
/// hit's distance `ρ = σ h` from the light's foot `F`: `T = D (1 +
/// s)^(−3/2)`, `s = σ²`, whose Hessian has the eigenvalues `−(3D/h²)(1 +
/// s)^(−5/2)` and `(3D/h²)(4s − 1)(1 + s)^(−7/2)` and whose gradient is
/// `(3D/h) σ (1 + σ²)^(−5/2)` (each bounded over a cell's `σ` range at its
/// largest point: the second is within the first for `s ≤ 2/3` and peaks
/// at `s = 3/4`, the gradient peaks at `σ = 1/2`; the 3-D bounds `12T/r²`
/// and `3T/r` gave the standard scene 0.404 LSB over 4 rays, these
/// 0.066). With the hit `p = t d` (`d = (x̂, ŷ, 1)`, `t ≤ R`, its distance
/// `R ≥ dist` from the camera) and `t' = −t κ`, `κ = n·d'/n·d` (`|n·d| =
/// dist/t`): `|p'| ≤ R (d₁ + R ν₁/dist)` and `|p''| ≤ R d₂ + 2R² ν₁
/// d₁/dist + R (2R² ν₁²/dist² + R ν₂/dist)`, where `d₁, d₂` bound `|d'|,
/// |d''|` along a row and `ν₁, ν₂` bound `|n·d'|, |n·d''|` (from `x̂ =
/// x̂_d g(u)`, `ŷ = ŷ_d g(u)` term by term: `|x̂'| ≤ (g + 2u(|k1| +
/// 2|k2|u))/f_x`, `|ŷ'| ≤ u(|k1| + 2|k2|u)/f_x`, `|x̂''| ≤ √u(6|k1| +
/// 20|k2|u)/f_x²`, `|ŷ''| ≤ √u(2|k1| + 12|k2|u)/f_x²`; `g`, `u` the
/// distortion's largest, [`Geometry`]). The hit lies `√(R² − dist²)` from
/// the camera's foot on the plane, and `F` at `foot` from it, so `ρ` lies
/// within that ring's nearest and farthest from `F`. The largest over
/// cells of `R` up to 10³ times the scene's distances (the bound falls as
/// `1/R` beyond): 10 % wide up to 4 times the distance at which the hit
/// passes the light's foot, 25 % beyond; before the noise
/// ([`noise_moved`] adds what it does). `None` without the plane, or with
/// more than one point light (no mean then). (The camera plans every
/// pose: some 50 cells, a few divisions and square roots each, the cells
/// past the fine ones cut short by [`MeanCells::worst`].)
/// [`closed_mean_factor`] scales it to an interpolation over more rays.
#[inline(never)]
pub(super) fn closed_mean_err(scene: &Scene, g: &Geometry) -> Option<f64> {
    let p = g.prims.get(g.closed?)?;
    let mut points = scene
        .lights
        .iter()
        .zip(&g.lights)
        .filter_map(|(l, lp)| match (l, lp) {
            (Light::Point { intensity, .. }, Some(pos)) => Some((*intensity, *pos)),
            _ => None,
        });
    let (intensity, pos) = points.next()?;
    if points.next().is_some() {
        return None;
    }
    let i = intensity.iter().map(|v| v.f64()).fold(0.0, f64::max);
    let dist = libm::fabs(dot3(p.c, p.n)).max(1e-300);
    let h = prim_light_distance(p, pos).max(1e-300);
    let l = norm3(pos);
    let foot = libm::sqrt((l * l - (h - dist) * (h - dist)).max(0.0));
    let d = g.gain * p.kd * i / (h * h);
    let (u, f) = (g.u_max, g.f_row);
    let (k1, k2) = scene.distortion.coefficients();
    // (|k1| and |k2| u.)
    let (k1, k2u) = (libm::fabs(k1.f64()), libm::fabs(k2.f64()) * u);
    // Along a row (x̂ = x̂_d g(u), ŷ = ŷ_d g(u), u = x̂_d² + ŷ_d², x̂_d
    // stepping 1/f): ∂x̂/∂x̂_d = g + 2x̂_d² g', ∂ŷ/∂x̂_d = 2x̂_d ŷ_d g',
    // ∂²x̂/∂x̂_d² = 6x̂_d g' + 8k2 x̂_d³, ∂²ŷ/∂x̂_d² = ŷ_d (2g' + 8k2 x̂_d²),
    // with g' = k1 + 2k2 u, x̂_d² ≤ u and 2|x̂_d ŷ_d| ≤ u.
    let (x1, y1) = (
        (g.g_max + 2.0 * u * (k1 + 2.0 * k2u)) / f,
        u * (k1 + 2.0 * k2u) / f,
    );
    let (x2, y2) = (
        libm::sqrt(u) * (6.0 * k1 + 20.0 * k2u) / (f * f),
        libm::sqrt(u) * (2.0 * k1 + 12.0 * k2u) / (f * f),
    );
    let (nx, ny) = (libm::fabs(p.n[0]), libm::fabs(p.n[1]));
    let (d1, d2) = (libm::sqrt(x1 * x1 + y1 * y1), libm::sqrt(x2 * x2 + y2 * y2));
    let (n1, n2) = (nx * x1 + ny * y1, nx * x2 + ny * y2);
    let cells = MeanCells::new((dist, foot, h, l), d, (d1, d2, n1, n2));
    Some(cells.worst(true).0 + libm::ldexp(1.0, -15))
}

/// [`closed_mean_err`]'s cells of `R`: the plane's distance `dist`, the
/// light's foot `foot` from the camera's and its height `h` (m), `D`, the
/// bounds `d₁, d₂` on `|d'|, |d''|` and `ν₁ dist, ν₂ dist` on `|n·d'|,
/// |n·d''|` along a row, and the cells' end `top` and the end of the fine
/// ones `fine` (m).
#[derive(Clone, Copy, Debug)]
pub(super) struct MeanCells {
    pub(super) dist: f64,
    pub(super) foot: f64,
    pub(super) h: f64,
    pub(super) d: f64,
    pub(super) d1: f64,
    pub(super) d2: f64,
    pub(super) n1: f64,
    pub(super) n2: f64,
    pub(super) top: f64,
    pub(super) fine: f64,
}

impl MeanCells {
    /// The cells for the plane `dist` from the camera, the light `h` from
    /// the plane and `l` from the camera, its foot `foot` from the
    /// camera's (m): cells of R (each bounded at its worst ends) up to 10³
    /// times the scene's distances, where the bound falls as 1/R — 10 %
    /// wide up to 4 times the distance at which the hit passes the light's
    /// foot (the bound's largest lie there), 25 % beyond.
    pub(super) fn new(
        (dist, foot, h, l): (f64, f64, f64, f64),
        d: f64,
        (d1, d2, n1, n2): (f64, f64, f64, f64),
    ) -> MeanCells {
        MeanCells {
            dist,
            foot,
            h,
            d,
            d1,
            d2,
            n1,
            n2,
            top: 1e3 * (dist + l + h),
            fine: 4.0 * libm::sqrt(foot * foot + dist * dist),
        }
    }

    /// The largest cell's bound, LSB, and the cells taken. With `early`,
    /// the cells beyond the fine ones stop once [`closed_mean_tail`] bounds
    /// every one left within the largest so far: the same value (`tests`),
    /// with fewer cells (the camera plans every pose, at some 5 000 M3
    /// instructions a cell in soft-float).
    pub(super) fn worst(&self, early: bool) -> (f64, u32) {
        let MeanCells {
            dist,
            foot,
            h,
            d,
            d1,
            d2,
            n1,
            n2,
            top,
            fine,
        } = *self;
        let inv_dist = 1.0 / dist;
        let (nu1, nu2) = (n1 * inv_dist, n2 * inv_dist);
        let (mut ra, mut ring_a, mut worst, mut cells) = (dist, 0.0, 0.0f64, 0);
        while ra < top {
            // Beyond the fine cells, once every cell from here on is
            // provably within `worst`, the rest cannot move it.
            if early
                && ra >= fine
                && closed_mean_tail((ra, ring_a - foot), (h, d), (d1, d2), (nu1, nu2)) <= worst
            {
                break;
            }
            let rb = ra * if ra < fine { 1.1 } else { 1.25 };
            // How far the hit lies from the camera's foot on the plane.
            let ring_b = libm::sqrt((rb * rb - dist * dist).max(0.0));
            // The hit's distance ρ from the light's foot, in units of h: σ in
            // [lo, hi].
            let (lo, hi) = (
                (ring_a - foot).max(foot - ring_b).max(0.0) / h,
                (ring_b + foot) / h,
            );
            let (s_lo, s_hi) = (lo * lo, hi * hi);
            // (1 + s)^(−5/2).
            let fall = |s: f64| 1.0 / ((1.0 + s) * (1.0 + s) * libm::sqrt(1.0 + s));
            // On the plane T = D (1 + s)^(−3/2), s = σ²: its Hessian's
            // eigenvalues are T'/ρ = −D (3/h²)(1 + s)^(−5/2), largest at s_lo,
            // and T'' = D (3/h²)(4s − 1)(1 + s)^(−7/2), within the first where
            // s ≤ 2/3 and beyond it largest at s = 3/4; its gradient is D (3/h)
            // σ (1 + σ²)^(−5/2), largest at σ = 1/2. (`max` and `min`, not
            // `clamp`, which would link a panic path.) Where the cell lies
            // beyond both peaks (s_lo ≥ 3/4, σ_lo ≥ 1/2) all three are taken
            // at s_lo: one square root, not three.
            let f_lo = fall(s_lo);
            let s = 0.75f64.max(s_lo).min(s_hi);
            let f_s = if s == s_lo { f_lo } else { fall(s) };
            let hess = 3.0 * f_lo.max(libm::fabs(4.0 * s - 1.0) * f_s / (1.0 + s)) / (h * h);
            let sg = 0.5f64.max(lo).min(hi);
            let sg2 = sg * sg;
            let f_g = if sg2 == s_lo { f_lo } else { fall(sg2) };
            let grad = 3.0 * sg * f_g / h;
            let m = rb * n1 * inv_dist;
            let dp = rb * (d1 + m);
            let ddp = rb * (d2 + 2.0 * m * d1 + 2.0 * m * m + rb * n2 * inv_dist);
            worst = worst.max(0.5 * d * (hess * dp * dp + grad * ddp));
            (ra, ring_a, cells) = (rb, ring_b, cells + 1);
        }
        (worst, cells)
    }
}

/// An upper bound on [`closed_mean_err`]'s cell values for every cell from
/// `ra` (m) on, decreasing in `ra`; infinite where it does not apply.
/// With `L = ring_a − foot ≥ κ ra` (`κ = L/ra`, which only grows with
/// `ra`) and `κ ra ≥ h/2`, every later cell `[r, r_b]` (`r_b ≤ 1.25 r`)
/// has `σ_lo ≥ L/h ≥ 1/2`, so its Hessian bound is at most `12 σ_lo⁻⁵/h²`
/// (`(1 + s)^(−5/2) ≤ σ⁻⁵`, `|4s − 1|/(1 + s) < 4`, the value at `s ≥
/// s_lo` at most that at `s_lo`) and its gradient bound `3 σ_lo⁻⁴/h`,
/// with `σ_lo ≥ κ r/h`; `|p'| ≤ 1.25 r (d₁ + 1.25 r ν₁)` and `|p''| ≤
/// 1.25 r (d₂ + 2.5 r ν₁ d₁ + 3.125 r² ν₁² + 1.25 r ν₂)` (`ν = n·d/dist`).
/// Each term is a positive multiple of `r^(−k)`, `k ≥ 1`: decreasing.
pub(super) fn closed_mean_tail(
    (ra, l): (f64, f64),
    (h, d): (f64, f64),
    (d1, d2): (f64, f64),
    (nu1, nu2): (f64, f64),
) -> f64 {
    if !(l > 0.0 && 2.0 * l >= h) {
        return f64::INFINITY;
    }
    let k = l / ra;
    let (k2, r) = (k * k, ra);
    let hess = 12.0 / (k2 * k2 * k);
    let grad = 3.75 / (k2 * k2);
    let a = 1.25 * d1 + 1.5625 * r * nu1;
    let tail = hess * a * a / (r * r * r)
        + grad * (d2 / (r * r * r) + (2.5 * nu1 * d1 + 1.25 * nu2) / (r * r) + 3.125 * nu1 * nu1 / r);
    // (A hair above, for the roundings of the values it bounds.)
    0.5 * d * h * h * h * tail * (1.0 + 1e-9)
}
