//! The error model: what each candidate may get wrong (geometric px, LSB,
//! edge pixels), from the arithmetic's resolution propagated through the
//! scene's own magnitudes; the sample grid, aperture pattern and table
//! sizes it picks.

use super::geometry::{cam_direction, dot3, norm3, pow, prim_light_distance, sub3, Geometry, PrimGeom};
use super::Defocus;
use crate::num::FixedF64;
use crate::render::sensor::noise::{Z_ERR, Z_MAX};
use crate::render::Arithmetic;
use crate::scene::{Light, Scene, Shape};
use crate::Model;

/// The smallest power-of-two table whose error is within `half` (or the
/// largest table).
pub(super) fn table_entries(scene: &Scene, g: &Geometry, half: f64) -> usize {
    let mut entries = 2;
    while table_geom_err(scene, g, entries) > half && entries < crate::geom::distortion::MAX_LUT {
        entries *= 2;
    }
    entries
}

/// The geometric error of a linearly interpolated table of `entries`, px:
/// `|k2| h²/4` at the widest corner plus the entries' rounding.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
pub(super) fn table_geom_err(scene: &Scene, g: &Geometry, entries: usize) -> f64 {
    let r_max = libm::sqrt(g.u_max);
    let frac = scene
        .distortion
        .entry_frac_bits(crate::num::from_f64(g.u_max).unwrap_or(crate::scene::Q::MAX));
    let rounding = g.f_px * r_max * libm::ldexp(1.0, -(frac as i32 + 1)) + g.f_px * libm::ldexp(1.0, -31);
    g.f_px * r_max * scene.distortion.lut_interp_error(g.u_max, entries) + rounding
}

/// Defocus for `scene` ([`Defocus`]): the inverse depths `w = 1/z` of the
/// content in view — a bounded primitive's over its bounding sphere (if
/// its slope bounds meet the field), a plane's over the undistorted field's
/// bounding box (`w = n̂·(x̂, ŷ, 1) / (n̂·c)` is linear in the slopes: its
/// extremes are at the box's corners, and a horizon in view takes `w` to
/// 0) — against the depth of field's `[1/Ẑ_f, 1/Ẑ_n]`; the blur is
/// `d |w − 1/Z̃|` normalized, times `f/s`. The aperture is sampled for a
/// perspective camera with content outside the depth of field, with the
/// smallest pattern within `edge_budget_px` ([`crate::render::sensor::defocus::points_for`]).
#[inline(never)]
pub(super) fn defocus(scene: &Scene, g: &Geometry, edge_budget_px: f64) -> Defocus {
    let lens = &scene.camera.lens;
    let (d, f) = (lens.diameter().f64(), lens.focal_length().f64());
    let (zt, b) = (lens.focus_distance().f64(), lens.tolerable_blur().f64());
    let inv_focus = 1.0 / zt;
    // §4's planes as inverse depths: 1/Ẑ_n = (d f + b̃ Z̃) / (Z̃ f (d + b̃)),
    // 1/Ẑ_f = (d f − b̃ Z̃) / (Z̃ f (d − b̃)), 0 (infinite) when ≤ 0.
    let inv_near = (d * f + b * zt) / (zt * f * (d + b));
    let inv_far = ((d * f - b * zt) / (zt * f * (d - b))).max(0.0);
    let (xs, ys) = g.field;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &g.prims {
        if let Shape::Plane { .. } = p.shape {
            let Some((wmin, wmax)) = g.plane_w(p) else {
                continue;
            };
            if wmax <= 0.0 {
                continue;
            }
            lo = lo.min(wmin.max(0.0));
            hi = hi.max(wmax);
            continue;
        }
        // A disc or rectangle lies in its plane: its inverse depths are
        // within the plane's over the field too (finite where its bounding
        // sphere reaches the lens plane).
        let flat = match p.shape {
            Shape::Disc { .. } | Shape::Rectangle { .. } => g.plane_w(p),
            _ => None,
        };
        if flat.is_some_and(|(_, wmax)| wmax <= 0.0) {
            continue;
        }
        let (flat_lo, flat_hi) = flat.map_or((0.0, f64::INFINITY), |(a, b)| (a.max(0.0), b));
        // The radius widened by 1 nm: the scene's positions are rounded
        // to 2⁻³² m.
        let (c, r) = (p.c, p.r + 1e-9);
        if c[2] + r <= 0.0 {
            continue;
        }
        let near = if c[2] > r {
            // The bounding sphere's tangent slopes against the field.
            let zz = c[2] * c[2] - r * r;
            let meets = |cx: f64, half: f64| {
                let s = libm::sqrt((cx * cx + zz).max(0.0));
                (cx * c[2] - r * s) / zz <= half && (cx * c[2] + r * s) / zz >= -half
            };
            if !(meets(c[0], xs) && meets(c[1], ys)) {
                continue;
            }
            1.0 / (c[2] - r)
        } else {
            f64::INFINITY
        };
        hi = hi.max(near.min(flat_hi));
        lo = lo.min((1.0 / (c[2] + r)).max(flat_lo));
    }
    if lo > hi {
        return Defocus::NONE;
    }
    let blur_px = d * g.f_px * libm::fabs(hi - inv_focus).max(libm::fabs(lo - inv_focus));
    // The least blur of content outside the depth of field: at least the
    // tolerable blur (px), more where all content lies on one side of
    // focus beyond it.
    let least = if lo > inv_focus || hi < inv_focus {
        d * g.f_px * libm::fabs(lo - inv_focus).min(libm::fabs(hi - inv_focus))
    } else {
        0.0
    };
    let least_blur_px = least.max(b * g.f_px / f);
    let outside_dof = hi > inv_near || lo < inv_far;
    let points = if outside_dof && matches!(scene.camera.model, Model::Perspective) {
        crate::render::sensor::defocus::points_for(blur_px, edge_budget_px)
    } else {
        0
    };
    Defocus {
        blur_px,
        least_blur_px,
        outside_dof,
        points,
        err_px: if points > 0 {
            crate::render::sensor::defocus::placement(points) * blur_px
        } else {
            blur_px
        },
    }
}

/// The fraction of pixels an edge crosses, estimated from the edges'
/// length on the sensor (pixels, at each primitive's centre distance, seen
/// face on): a sphere's or disc's outline (`2π f r / |c|`), a rectangle's
/// (`4 f (h_u + h_v) / |c|`), a plane's horizon (the sensor's width), and a
/// checker texture's cell boundaries (two families of lines a projected
/// cell apart over the area the primitive covers; with `integrated`, not
/// those [`Geometry::cells_differing`] integrates over the field); a line
/// crosses `4/π` pixels per pixel of length on average over its
/// directions.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
pub(super) fn edge_fraction(scene: &Scene, g: &Geometry, integrated: bool) -> f64 {
    use core::f64::consts::PI;
    let (w, h) = scene.camera.intrinsics.size();
    let area = f64::from(w) * f64::from(h);
    let mut length = 0.0;
    for (p, pg) in scene.primitives.iter().zip(&g.prims) {
        let k = g.f_px / norm3(pg.c).max(1e-9);
        let covered = match p.shape {
            Shape::Plane { .. } => {
                length += f64::from(w);
                g.coverage * area
            }
            Shape::Rectangle { half, .. } => {
                let (hu, hv) = (half[0].f64() * k, half[1].f64() * k);
                length += 4.0 * (hu + hv);
                4.0 * hu * hv
            }
            _ => {
                let r = pg.r * k;
                length += 2.0 * PI * r;
                PI * r * r
            }
        };
        if let Some(ch) = p.checker.filter(|_| !(integrated && g.integrates_cells(pg))) {
            let cell = (ch.cell.f64() * k).max(1e-9);
            length += 2.0 * covered.min(area) / cell;
        }
    }
    (4.0 / PI * length / area).min(1.0)
}

/// The resolutions an arithmetic computes with, from which the planner
/// bounds its error in LSB.
#[derive(Clone, Copy, Debug)]
pub struct ErrorModel {
    /// Relative error of the radiometric chain (irradiance, `1/r³`,
    /// products, `cos⁴α`).
    pub rel: f64,
    /// Absolute error of a hit point, metres (rounding of `t` and of the
    /// point).
    pub point: f64,
    /// How far a flat shape's boundary test can move, metres (the hit
    /// point's components as the test reads them): this, or with
    /// [`Boundary::FastHit`] a bound at each shape (`ErrorModel::boundary_m`).
    pub boundary: Boundary,
    /// Absolute error of `b = d·c` in the sphere test: metres, plus this
    /// much times `|c|`.
    pub b: f64,
    /// Of `b`, per metre of `|c|`.
    pub b_per_c: f64,
    /// Absolute error of `a r²` in the discriminant: m², plus this much
    /// times `r`.
    pub cc: f64,
    /// Of `a r²`, per metre of `r`.
    pub cc_per_c: f64,
    /// Relative error of `a = d·d`.
    pub a_rel: f64,
    /// Absolute error of the discriminant's own roundings, m².
    pub disc: f64,
    /// Absolute error of a unit vector's components (normals, `l̂`, `v̂`).
    pub unit: f64,
    /// Absolute error per term of the pixel sum, DN (truncations).
    pub per_term_dn: f64,
    /// Through the aperture, how far a ray's start is off its aperture
    /// point, metres: it moves a hit at depth `z` by this times
    /// `|1 − z/Z̃|` (the ray still meets its chief ray at `Z̃`).
    pub ap_origin: f64,
    /// A sphere under a specular lobe takes its normal from the ray and the
    /// sphere (`mix32::fine_normal`), not from the rounded hit point.
    pub fine_normal: bool,
    /// A plane without a lobe seen by perspective rays may be shaded in
    /// closed form (`mix32::Closed`): its point lights' terms from
    /// `w = n·d` and `q = w P_L − dist d` instead of the hit point. Its
    /// length unit `U`, metres, or `None`.
    pub closed_plane: Option<f64>,
}

impl ErrorModel {
    /// The model of `a` for the scene's geometry (the fast arithmetic's
    /// lengths are in the frame's unit `U`).
    pub(super) fn of(a: Arithmetic, g: &Geometry) -> ErrorModel {
        let u = g.unit;
        let ap = if g.aperture.is_some() { 0.25 } else { 0.0 };
        let q32 = libm::ldexp(1.0, -32);
        match a {
            // S18 U hit points and t, S22 U b and d × c (from S24 U
            // centres, S26 slopes), the discriminant by Lagrange's identity
            // with r² in S24 U², S20 a, S30 unit vectors; 1/r to 2⁻¹⁹ (so E
            // to 3·2⁻¹⁹), n·l truncated 2⁻²¹, cos⁴α from 1/a (2⁻²¹,
            // squared), Pf products 2⁻³¹ each.
            // Through the aperture: each ray starts at its point rounded to
            // S18 U (`ap_origin`, ≤ 0.71·2⁻¹⁸ U off) and meets the chief
            // ray at the focused depth up to its slope shift's rounding (half
            // a unit of S26: 2⁻²⁴ U at 8 U; `n·A` truncated to S24 U).
            Arithmetic::Fast => ErrorModel {
                rel: 3.0 * libm::ldexp(1.0, -19) + libm::ldexp(1.0, -21) + libm::ldexp(1.0, -20) + 1e-8,
                point: (4.0 + ap) * libm::ldexp(u, -18),
                // Through the aperture, the bound as it was (the point's
                // S18 rounding): a flipped aperture ray moves a pixel that
                // the reference counts as smooth (it classifies by the
                // chief ray) by a share of the contrast, which a bound in
                // angle does not cover. With the shape's bound, a target
                // 6 m off focused at 20 m planned fast and 52 of its
                // smooth pixels differed by 2–3 LSB (2026-12-04).
                boundary: if g.aperture.is_some() {
                    Boundary::Fixed((2.0 + ap) * libm::ldexp(u, -18))
                } else {
                    Boundary::FastHit { unit: u }
                },
                b: libm::ldexp(u, -21) + ap * libm::ldexp(u, -23),
                ap_origin: if g.aperture.is_some() {
                    0.71 * libm::ldexp(u, -18)
                } else {
                    0.0
                },
                b_per_c: 0.0,
                cc: libm::ldexp(u * u, -24),
                cc_per_c: 2.0 * libm::ldexp(u, -24),
                a_rel: libm::ldexp(1.0, -20),
                disc: 0.0,
                unit: libm::ldexp(1.0, -28),
                per_term_dn: libm::ldexp(1.0, -14),
                fine_normal: true,
                closed_plane: Some(u),
            },
            // I32F32 throughout: 2⁻³² m per rounding (each product, the
            // camera-frame centre's components), some 40 roundings of
            // quantities below 2⁸ in the radiometric chain (2⁻²⁰ relative);
            // the sphere's discriminant by Lagrange's identity (`r²` rounded
            // once).
            Arithmetic::Wide => ErrorModel {
                rel: libm::ldexp(1.0, -20),
                point: (8.0 + 2.0 * g.extent) * q32,
                boundary: Boundary::Fixed((4.0 + g.extent) * q32),
                b: 4.0 * q32,
                b_per_c: 2.0 * q32,
                cc: 2.0 * q32,
                cc_per_c: 0.0,
                a_rel: 2.0 * q32,
                disc: 2.0 * q32,
                unit: 4.0 * q32,
                per_term_dn: q32,
                ap_origin: 0.0,
                fine_normal: false,
                closed_plane: None,
            },
        }
    }

    /// Predicted largest `|core − reference|` before the final rounding,
    /// LSB, over smooth pixels.
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    pub(super) fn lsb(&self, scene: &Scene, g: &Geometry, geom_px: f64) -> f64 {
        // The radiometric chain: relative to the value, which matters only
        // up to DN_max (a value far above it saturates in both).
        let terms = (2 + 2 * scene.lights.len()) as f64;
        let base = self.rel * g.dn_max * 1.01 + terms * self.per_term_dn;
        let mut worst: f64 = base;
        // An angle of 1/256 px: a pixel that far inside a silhouette is
        // not an edge pixel.
        let dtheta = 1.0 / (256.0 * g.f_px);
        for p in &g.prims {
            // Through the aperture, the rays' start moves their hits.
            let shift = self.ap_origin * g.defocus_factor(p);
            // Normal error, and the hit point's.
            let (dn, dp) = match p.shape {
                Shape::Sphere { .. } => {
                    // a t² − 2 b t + cc = 0 with b ≈ |c| √a, cc = |c|² − r²
                    // (a ≥ 1; the worst case is a = 1).
                    let c = norm3(p.c).max(p.r);
                    let db = self.b + self.b_per_c * c + shift;
                    // a r² − |d × c|² (Lagrange's identity; both
                    // arithmetics): |d × c| = r √a at the silhouette, its
                    // components as b's.
                    let ddisc = 2.0 * p.r * 1.8 * db
                        + p.r * p.r * self.a_rel
                        + self.cc
                        + self.cc_per_c * p.r
                        + self.disc;
                    // The discriminant a (r² − h²) at 1/256 px inside the
                    // silhouette: 2 r |c| δθ. Its error moves the hit point
                    // along the ray by δdisc / (2 √disc) (at most √δdisc).
                    // (Parallel rays: 1/256 px is k δθ sideways.)
                    let lateral = g.origin_scale.unwrap_or(c);
                    let disc_min = (2.0 * p.r * lateral * dtheta).max(1e-300);
                    if ddisc >= disc_min {
                        // The rounding can flip hit and miss farther than
                        // 1/256 px inside the silhouette: a smooth pixel may
                        // see what lies behind the sphere instead.
                        return g.dn_max * 2.0;
                    }
                    let along = ddisc / (2.0 * libm::sqrt(disc_min));
                    let dp = self.point + db + along;
                    (dp / p.r + self.unit, dp)
                }
                Shape::Disc { .. } | Shape::Rectangle { .. } => {
                    // The boundary test moves with the hit point: by more
                    // than 1/256 px where the boundary is nearest.
                    // Its distance from the lens is at least that of the
                    // plane, h, and of the circle around it in the plane.
                    let h = libm::fabs(dot3(p.c, p.n));
                    let c_in = libm::sqrt((dot3(p.c, p.c) - h * h).max(0.0));
                    let out = match p.shape {
                        Shape::Disc { .. } => libm::fabs(c_in - p.r),
                        _ => (c_in - p.r).max(0.0),
                    };
                    let nearest = libm::sqrt(h * h + out * out).max(1e-300);
                    let lateral = g.origin_scale.unwrap_or(nearest);
                    if (self.boundary_m(g, p) + shift) / lateral >= dtheta {
                        return g.dn_max * 2.0;
                    }
                    (self.unit, self.point + shift)
                }
                Shape::Plane { .. } => (self.unit, self.point + shift),
            };
            let e = if self.fine_normal && p.exponent > 0 && matches!(p.shape, Shape::Sphere { .. }) {
                // Pixels whose n̂·v̂ is at least ν take the fine normal's
                // error (A); below ν, next to the silhouette, the lobe is
                // bounded by geometry (B): r̂·v̂ = 2 (n̂·l̂)(n̂·v̂) − l̂·v̂ < 2ν
                // − λ, λ a lower bound of l̂·v̂ over the sphere. The best ν
                // of a few, or the bound without the split if smaller.
                let mut best = self.light_terms(scene, g, p, dn, dp, dn, None);
                for nu in [0.7, 0.5, 0.35, 0.25, 0.125] {
                    let (dn_a, dp_a) = self.fine_normal_err(g, p, nu, geom_px, dp);
                    let a = self.light_terms(scene, g, p, dn, dp_a, dn_a, None);
                    let b = self.light_terms(scene, g, p, dn, dp, dn, Some(nu));
                    best = best.min(a.max(b));
                }
                best
            } else {
                self.light_terms(scene, g, p, dn, dp, dn, None)
            };
            // A plane's rays that meet nothing else take the closed form.
            let e = match (self.closed_plane, p.shape, g.origin_scale) {
                (Some(u), Shape::Plane { .. }, None) => e.max(self.closed_terms(scene, g, p, dn, u)),
                _ => e,
            };
            worst = worst.max(base + e.min(g.dn_max * 2.0));
        }
        worst
    }
}

/// How far an arithmetic's flat-shape boundary test can move
/// ([`ErrorModel::boundary`]).
#[derive(Clone, Copy, Debug)]
pub enum Boundary {
    /// At most this many metres anywhere.
    Fixed(f64),
    /// The fast arithmetic's, whose lengths are in the frame's unit `U`
    /// (metres): `fast_boundary_m` at each shape.
    FastHit {
        /// `U`, metres.
        unit: f64,
    },
}

/// How far the fast arithmetic's boundary test of a disc or rectangle
/// (`mix32::MixShape::nearest`) can move its boundary, metres, for rays
/// whose direction `d` (a perspective ray's `(x̂, ŷ, 1)`, a parallel
/// ray's `(0, 0, 1)`) has an in-plane part of at most `s` and a length of
/// at most `d_len`, hits at `t ≤ t_max` (depth from where the rays start,
/// metres) with `1/|n̂·d| ≤ k` (a parallel ray's `1/|n_z|`), on a shape of
/// radius (a rectangle's half-diagonal) `r`, in a frame of unit `u`.
///
/// The test reads the hit as `t` (S18 U) times the ray's slopes or axes,
/// not as a point rounded to S18, against a centre and half sizes in S24
/// U. `t = dist/(n̂·d)` errs by `δt ≤ t 2⁻²¹` (the reciprocal) `+ 3
/// 2⁻²⁴ U k` (`dist`; a parallel ray's `n·o`, an aperture ray's `n·A`)
/// `+ t 2⁻²⁴ k` (`n̂·d`, or `n_z` in S30) `+ (2 + 2⁻⁵ k) 2⁻¹⁸ U`
/// (`mul_shr_t`'s floors, whose left shift `l` has `2^l < 2⁻⁵ k`). The hit
/// moves by `δt` along the ray: the coordinate of a rectangle's axis, or a
/// disc's distance from its centre, by `s δt`. Then a rectangle's `d·â` is truncated to S24 and its axis
/// rounded to S30 (`t (2⁻²⁴ + 2⁻³⁰ |d|)`); the centre, the point's
/// coordinates and the half sizes or radius are floored to S24 (`5 2⁻²⁴
/// U`); and a disc's distance takes the square of the error vector over
/// `2 r` (`(|d| δt + 4 2⁻²⁴ U)² / 2r`).
/// `mix32::tests::a_flat_shape_s_boundary_moves_within_the_planner_s_bound`
/// measures it.
pub(crate) fn fast_boundary_m(u: f64, s: f64, d_len: f64, t_max: f64, k: f64, r: f64) -> f64 {
    let ld = libm::ldexp;
    let dt = t_max * ld(1.0, -21)
        + 3.0 * ld(u, -24) * k
        + t_max * ld(1.0, -24) * k
        + (2.0 + ld(k, -5)) * ld(u, -18);
    let e = libm::fabs(d_len) * dt + 4.0 * ld(u, -24);
    s * dt + t_max * (ld(1.0, -24) + ld(d_len, -30)) + 5.0 * ld(u, -24) + e * e / (2.0 * r).max(1e-300)
}

impl ErrorModel {
    /// How far the boundary test of `p` (a disc or rectangle) can move,
    /// metres ([`ErrorModel::boundary`]). The fast arithmetic's from
    /// [`fast_boundary_m`] with the largest in-plane part of the rays'
    /// directions over the field box's corners (where that quadratic form
    /// is largest), `t` up to the shape's farthest depth, and `1/|n̂·d|`
    /// up to that over the plane's distance.
    pub(super) fn boundary_m(&self, g: &Geometry, p: &PrimGeom) -> f64 {
        let unit = match self.boundary {
            Boundary::Fixed(m) => return m,
            Boundary::FastHit { unit } => unit,
        };
        let n = p.n;
        let t_max = (p.c[2] + p.r).max(0.0);
        let (s, d_len, k) = match g.origin_scale {
            Some(_) => {
                let nz = libm::fabs(n[2]);
                (libm::sqrt((1.0 - nz * nz).max(0.0)), 1.0, 1.0 / nz.max(1e-300))
            }
            None => {
                let (xs, ys) = g.field;
                let mut s2: f64 = 0.0;
                for (x, y) in [(xs, ys), (xs, -ys), (-xs, ys), (-xs, -ys)] {
                    let d = [x, y, 1.0];
                    let nd = dot3(n, d);
                    s2 = s2.max(dot3(d, d) - nd * nd);
                }
                let d_len = libm::sqrt(1.0 + xs * xs + ys * ys);
                (
                    libm::sqrt(s2),
                    d_len,
                    t_max / libm::fabs(dot3(n, p.c)).max(1e-300),
                )
            }
        };
        fast_boundary_m(unit, s, d_len, t_max, k, p.r)
    }

    /// The error, DN, of the terms of every light on primitive `p`, with
    /// the normal's error `dn` (diffuse), the hit point's `dp` (metres),
    /// and for the lobe the normal's error `lobe_dn` or, with `cap = ν`,
    /// the lobe bounded by geometry: both values lie in `[0, D X^s]` with
    /// `X = 2ν − λ + δx`.
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub(super) fn light_terms(
        &self,
        scene: &Scene,
        g: &Geometry,
        p: &PrimGeom,
        dn: f64,
        dp: f64,
        lobe_dn: f64,
        cap: Option<f64>,
    ) -> f64 {
        let gain = g.gain;
        let mut e = 0.0;
        for (l, lp) in scene.lights.iter().zip(&g.lights) {
            let (strength, r_min) = match (*l, lp) {
                (Light::Point { intensity, .. }, Some(pos)) => {
                    let i = intensity.iter().map(|v| v.f64()).fold(0.0, f64::max);
                    let r = prim_light_distance(p, *pos).max(1e-9);
                    (i / (r * r), r)
                }
                (Light::Directional { irradiance, .. }, _) => (
                    irradiance.iter().map(|v| v.f64()).fold(0.0, f64::max),
                    f64::INFINITY,
                ),
                _ => (0.0, f64::INFINITY),
            };
            // cos moves by the normal's error (absolute: D δn, also
            // where a grazing pixel is dim), 1/r² by 3 δp / r relative
            // (of a value that matters only up to DN_max).
            let d = gain * p.kd * strength;
            let rel = 3.0 * dp / r_min + self.rel;
            e += d * dn + d.min(g.dn_max * 1.01) * rel;
            let d_spec = gain * p.ks * strength;
            if d_spec > 0.0 {
                // r̂·v̂ = x moves by 4 δn + 3 δl̂ + 3 δv̂; x^s by s x^(s−1)
                // δx. Where the term exceeds DN_max the pixel saturates
                // in both: x^s ≤ DN_max / D, so the error is at most
                // s δx DN_max / x with x = min(1, (DN_max / D)^(1/s)).
                let dx = 4.0 * lobe_dn + 3.0 * (dp / r_min + self.unit) + 3.0 * self.unit;
                let s = p.exponent.max(1) as f64;
                e += match cap {
                    Some(nu) => {
                        let x = 2.0 * nu - view_light_cos_min(scene, g, p, l, *lp) + dx;
                        if x <= 0.0 {
                            0.0
                        } else {
                            (d_spec * pow(x.min(1.0), s)).min(g.dn_max * 1.01)
                        }
                    }
                    None => {
                        let x = pow((g.dn_max / d_spec).min(1.0), 1.0 / s).max(1e-9);
                        d_spec * lobe_dn
                            + d_spec.min(g.dn_max * 1.01) * rel
                            + s * dx * g.dn_max.min(d_spec) / x
                    }
                };
            }
        }
        e
    }

    /// The error, DN, of the terms of every light on plane `p` shaded in
    /// closed form (`mix32::Closed`, lengths in `U = u` metres), with the
    /// normal's error `dn`. A point light at distance `L` from the camera
    /// and height `h` over the plane (distance `dist` from the camera)
    /// gives `E = D h³/r³` at distance `r = x h ≥ h` (`D` its term at `h`),
    /// and `E ∝ (|w|/|q|)³` with `|q| = |w| r` and `1/|w| ≤ (r + L)/dist`
    /// (the hit lies within `r + L` of the camera). So `w`'s error `δw`
    /// (its S24 truncation, `n`'s and `d`'s roundings: below 2⁻²³) moves
    /// `E` by `3 δw (r + L)²/(dist r) ≤ 3 δw x (h + L)²/(dist h)` relative,
    /// which grows with `r` where `E` falls: with the pixel saturating above
    /// `DN_max`, `min(E, DN_max) x ≤ min(D, DN_max) x_c`, `x_c = max(1,
    /// (D/DN_max)^⅓)` where `E` reaches `DN_max`. `q`'s roundings (its S22
    /// truncation, `dist`'s and `d`'s over `|w| r`, `P_L`'s S18 over `r`)
    /// and the rest (`1/√` three times, the products) are largest at
    /// `r = h`.
    #[inline(never)]
    pub(super) fn closed_terms(&self, scene: &Scene, g: &Geometry, p: &PrimGeom, dn: f64, u: f64) -> f64 {
        let cap = g.dn_max * 1.01;
        let dist = libm::fabs(dot3(p.c, p.n)).max(1e-300);
        let mut e = 0.0;
        for (l, lp) in scene.lights.iter().zip(&g.lights) {
            let (irradiance, pos) = match (*l, lp) {
                (Light::Point { intensity, .. }, Some(pos)) => (intensity, *pos),
                (Light::Directional { irradiance, .. }, _) => (irradiance, [f64::INFINITY; 3]),
                _ => continue,
            };
            let i = irradiance.iter().map(|v| v.f64()).fold(0.0, f64::max);
            // Directional terms are the general path's, summed once a frame.
            let (d, rel) = if pos[0].is_finite() {
                let h = prim_light_distance(p, pos).max(1e-9);
                let hl = h + norm3(pos);
                let d = g.gain * p.kd * i / (h * h);
                let rel_q = (1.74 * libm::ldexp(u, -22) + libm::ldexp(u, -24)) * hl / dist
                    + 1.74 * libm::ldexp(u, -18)
                    + 1.42 * libm::ldexp(hl, -26);
                let x_c = pow((d / cap).max(1.0), 1.0 / 3.0);
                (
                    d,
                    1e-8 + 3.0 * (rel_q + libm::ldexp(x_c * hl * hl / dist, -23)) / h,
                )
            } else {
                (g.gain * p.kd * i, 0.0)
            };
            e += d * dn + d.min(cap) * (self.rel + rel);
        }
        e
    }

    /// The error of `mix32::fine_normal` (absolute, per component) on a
    /// sphere's pixels whose `n̂·v̂ ≥ ν`, and the hit point's there (`dp`
    /// with the silhouette's along-ray term at `ν` instead of 1/256 px):
    /// the ray's direction error `δθ` (the geometric error over `f`, plus
    /// `d̂`'s 2⁻²⁸) moves `c⊥` by `2 |c| δθ` (parallel rays: their origin
    /// by `k δθ`), and `s = √(r² − |c⊥|²)` by `|c⊥| δc⊥ / s ≤ δc⊥ / ν`;
    /// roundings of a few S24 units, the square root's 2⁻²⁷.
    pub(super) fn fine_normal_err(
        &self,
        g: &Geometry,
        p: &PrimGeom,
        nu: f64,
        geom_px: f64,
        dp: f64,
    ) -> (f64, f64) {
        let u = g.unit;
        let s24 = libm::ldexp(u, -24);
        let dtheta = geom_px / g.f_px + libm::ldexp(1.0, -28);
        let (lever, rounding) = match g.origin_scale {
            None => (2.0 * norm3(p.c), 4.0 * s24),
            Some(k) => (k, libm::ldexp(u, -18)),
        };
        let r = p.r.max(1e-300);
        let e_perp = lever * dtheta + rounding;
        let e_s = e_perp / nu + r * libm::ldexp(1.0, -27) + 2.0 * s24 / nu;
        let e_sd = r * dtheta + s24;
        let dn = (e_perp + e_s + e_sd) / r + libm::ldexp(1.0, -27);
        // The S18 hit point still serves the light's direction; next to
        // the silhouette its along-ray error is at most that at ν.
        let c = norm3(p.c).max(p.r);
        let db = self.b + self.b_per_c * c;
        let ddisc = 2.0 * p.r * 1.8 * db + p.r * p.r * self.a_rel + self.cc + self.cc_per_c * p.r + self.disc;
        let disc_nu = (nu * nu * r * r - ddisc).max(1e-300);
        let dp_a = (self.point + db + ddisc / (2.0 * libm::sqrt(disc_nu))).min(dp);
        (dn, dp_a)
    }
}

/// A lower bound of `l̂·v̂` over sphere `p`'s points (`v̂` towards the
/// camera, `l̂` towards light `l`): the angle at a point between the two
/// directions exceeds that at the centre by at most `asin(r / distance)`
/// for each end (the camera's only for perspective rays); −1 if an end
/// lies within the sphere.
pub(super) fn view_light_cos_min(
    scene: &Scene,
    g: &Geometry,
    p: &PrimGeom,
    l: &Light,
    lp: Option<[f64; 3]>,
) -> f64 {
    let spread = |d: f64| {
        if d > p.r {
            libm::asin(p.r / d)
        } else {
            core::f64::consts::PI
        }
    };
    let (v, sv) = match g.origin_scale {
        None => ([-p.c[0], -p.c[1], -p.c[2]], spread(norm3(p.c))),
        Some(_) => ([0.0, 0.0, -1.0], 0.0),
    };
    let (to_l, sl) = match (*l, lp) {
        (Light::Point { .. }, Some(pos)) => {
            let d = sub3(pos, p.c);
            (d, spread(norm3(d)))
        }
        (Light::Directional { towards, .. }, _) => (cam_direction(scene, towards), 0.0),
        _ => return -1.0,
    };
    let cos0 = dot3(v, to_l) / (norm3(v) * norm3(to_l)).max(1e-300);
    let angle = libm::acos(cos0.clamp(-1.0, 1.0)) + sv + sl;
    if angle >= core::f64::consts::PI {
        -1.0
    } else {
        libm::cos(angle)
    }
}

/// A bound (LSB) on what a move `e` of the noise-free value `μ` moves a
/// recorded value by, its noise included (the move itself if the scene has
/// none): the value is `μ + σ(μ) z + …`, `σ = √(K_sys μ + (K_sys σ_d)²)`,
/// `|z| ≤ Z_MAX`, so `σ z` moves by at most `Z_MAX √(K_sys e)` (the square
/// root's modulus of continuity) and at most `Z_MAX e/(2 σ_d)` (its
/// slope, `σ ≥ K_sys σ_d`).
pub(super) fn noise_moved(scene: &Scene, g: &Geometry, e: f64) -> f64 {
    let Some(z) = scene.noise else {
        return e;
    };
    let k = g.dn_max / z.saturation_e.f64().max(1.0);
    let sd = z.dark_noise_e.f64();
    let slope = if sd > 0.0 {
        Z_MAX * e / (2.0 * sd)
    } else {
        f64::INFINITY
    };
    e + slope.min(Z_MAX * libm::sqrt(k * e))
}

/// What the core's noise draw adds to `|core − reference|` (LSB) at the
/// same noise-free value, 0 without noise: its `z` is within `Z_ERR` of the
/// reference's (its table) and its `σ` within 2⁻¹⁹ relative and 2⁻¹⁶ DN
/// (`mix32::sigma_z16`; the wide arithmetic's square root is finer), `σ ≤
/// √(DN_max²/μ_e,sat + (DN_max σ_d/μ_e,sat)²)`.
pub(super) fn noise_draw_lsb(scene: &Scene, g: &Geometry) -> f64 {
    let Some(z) = scene.noise else {
        return 0.0;
    };
    let k = g.dn_max / z.saturation_e.f64().max(1.0);
    let sd = z.dark_noise_e.f64();
    let sigma = libm::sqrt(k * g.dn_max + k * k * sd * sd);
    sigma * Z_ERR + Z_MAX * (sigma * libm::ldexp(1.0, -19) + libm::ldexp(1.0, -16))
}
