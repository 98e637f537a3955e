//! What the coverage grid's rays find: the fractions of the sensor each
//! kind of primitive covers (the cost model's areas), and the content's
//! extent (the fast arithmetic's length unit).

use super::geometry::{dot3, norm3, FromOrigin, PrimGeom, Reach, Reaches, COVERAGE_GRID};
use crate::num::FixedF64;
use crate::scene::{Scene, Shape};

/// The content's extent from the camera and from where the fast
/// arithmetic's rays start (the fast path's `parallel_start` and
/// `content_extent`), metres.
#[inline(always)]
pub(super) fn extents(
    reaches: &Reaches,
    lights: &[Option<[f64; 3]>],
    origin_scale: Option<f64>,
) -> (f64, f64) {
    // The content's extent from where the rays start, z = z0.
    let extent_at = |z0: f64| {
        let at = |c: [f64; 3]| norm3([c[0], c[1], c[2] - z0]);
        let mut e = match origin_scale {
            Some(k) if z0 > 0.0 => k / 8.0,
            _ => 0.0,
        };
        for (reach, checker) in reaches {
            e = e.max(match *reach {
                Reach::Plane(d) => d,
                Reach::Around(c, r) => at(c) + r,
            });
            if let Some(o) = checker {
                e = e.max(at(*o));
            }
        }
        for p in lights.iter().flatten() {
            e = e.max(at(*p));
        }
        e
    };
    let extent = extent_at(0.0);
    let near = (reaches.iter())
        .map(|(reach, _)| match *reach {
            Reach::Plane(_) => f64::NEG_INFINITY,
            Reach::Around(c, r) => c[2] - r,
        })
        .fold(f64::INFINITY, f64::min);
    let z0 = libm::ceil(near) - 1.0;
    let fast_extent = if origin_scale.is_some() && near.is_finite() && z0 > 0.0 {
        extent_at(z0).min(extent)
    } else {
        extent
    };
    (extent, fast_extent)
}

/// The fractions of the sensor the coverage grid's rays find
/// ([`Geometry`]'s `*_area` fields), in grid rays.
#[derive(Default)]
pub(super) struct Coverage {
    pub(super) hits: u32,
    pub(super) bounded: u32,
    pub(super) closed_hits: u32,
    pub(super) lobe_hits: u32,
    pub(super) facing_hits: u32,
    pub(super) closed_facing_hits: u32,
    pub(super) flat_hits: u32,
    pub(super) closed_flat_hits: u32,
}

impl Coverage {
    /// A grid of [`COVERAGE_GRID`] rays over the sensor (distortion
    /// ignored), each tested against every primitive; `closed` the plane
    /// shaded in closed form.
    #[inline(always)]
    pub(super) fn of(
        scene: &Scene,
        prims: &[PrimGeom],
        lights: &[Option<[f64; 3]>],
        origin_scale: Option<f64>,
        closed: Option<usize>,
    ) -> Coverage {
        let intr = &scene.camera.intrinsics;
        let (fx, fy) = intr.focal_px();
        let (fx, fy) = (fx.f64(), fy.f64());
        let (w, h) = intr.size();
        let (ox, oy) = intr.principal_point();
        let (ox, oy) = (ox.f64(), oy.f64());
        let (gx, gy) = COVERAGE_GRID;
        let mut cov = Coverage::default();
        // Directional lights alone: a flat primitive's shading is one sum
        // (`mix32::Mix32::shade_flat`).
        let directional = lights.iter().all(Option::is_none);
        // Facing: the fast arithmetic's S30 normal has n_x = n_y = 0 (to
        // within these f64 components' rounding, which need not be the
        // fixed-point frame's: half an S30 unit either way). Once a
        // primitive, not per hit: soft-float compares on the driven
        // camera, which plans every frame.
        const S30_HALF_UNIT: f64 = 1.0 / (1u64 << 31) as f64;
        let mut facing = [false; crate::scene::MAX_PRIMITIVES];
        for (f, p) in facing.iter_mut().zip(prims) {
            *f = !matches!(p.shape, Shape::Sphere { .. })
                && libm::fabs(p.n[0]) < S30_HALF_UNIT
                && libm::fabs(p.n[1]) < S30_HALF_UNIT;
        }
        // The origin's terms: once a primitive for perspective rays, once
        // a ray and primitive for parallel ones.
        let mut at = [FromOrigin::default(); crate::scene::MAX_PRIMITIVES];
        if origin_scale.is_none() {
            for (k, p) in at.iter_mut().zip(prims) {
                *k = p.seen_from([0.0; 3]);
            }
        }
        // The rows' slopes, once.
        let mut ys = [0.0f64; COVERAGE_GRID.1 as usize];
        for (b, y) in ys.iter_mut().enumerate() {
            *y = (oy - (b as f64 + 0.5) * h as f64 / gy as f64) / fy;
        }
        for a in 0..gx {
            let x = (ox - (a as f64 + 0.5) * w as f64 / gx as f64) / fx;
            // A perspective ray's `v·d = (v₀ x̂ + v₁ ŷ) + v₂` (`dot3`'s
            // order, `d₂ = 1`), with `v₀ x̂` once a column.
            let xx = x * x;
            for k in &mut at {
                k.vx = k.v[0] * x;
            }
            for &y in &ys {
                let (o, d) = match origin_scale {
                    None => ([0.0; 3], [x, y, 1.0]),
                    Some(k) => ([x * k, y * k, 0.0], [0.0, 0.0, 1.0]),
                };
                let dd = match origin_scale {
                    None => (xx + y * y) + 1.0,
                    Some(_) => dot3(d, d),
                };
                if origin_scale.is_some() {
                    for (k, p) in at.iter_mut().zip(prims) {
                        *k = p.seen_from(o);
                    }
                }
                cov.ray(prims, &at, &facing, closed, directional, (d, dd, y), origin_scale);
            }
        }
        cov
    }

    /// One grid ray `d` (`dd = d·d`; its slope `y`) against every
    /// primitive.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn ray(
        &mut self,
        prims: &[PrimGeom],
        at: &[FromOrigin],
        facing: &[bool],
        closed: Option<usize>,
        directional: bool,
        (d, dd, y): ([f64; 3], f64, f64),
        origin_scale: Option<f64>,
    ) {
        let (mut any, mut others) = (false, false);
        let mut nearest: Option<(f64, &PrimGeom)> = None;
        for (i, (p, k)) in prims.iter().zip(at).enumerate() {
            let vd = match origin_scale {
                None => (k.vx + k.v[1] * y) + k.v[2],
                Some(_) => dot3(k.v, d),
            };
            if let Some(t) = p.hit(k, d, dd, vd) {
                any = true;
                self.bounded += !matches!(p.shape, Shape::Plane { .. }) as u32;
                if facing.get(i) == Some(&true) {
                    if closed == Some(i) {
                        self.closed_facing_hits += 1;
                    } else {
                        self.facing_hits += 1;
                    }
                }
                others |= closed != Some(i);
                if nearest.is_none_or(|(tn, _)| t < tn) {
                    nearest = Some((t, p));
                }
            }
        }
        self.hits += any as u32;
        self.closed_hits += (any && !others) as u32;
        self.lobe_hits += nearest.is_some_and(|(_, p)| p.ks > 0.0) as u32;
        if directional
            && nearest.is_some_and(|(_, p)| p.ks == 0.0 && !matches!(p.shape, Shape::Sphere { .. }))
        {
            if any && !others {
                self.closed_flat_hits += 1;
            } else {
                self.flat_hits += 1;
            }
        }
    }
}
