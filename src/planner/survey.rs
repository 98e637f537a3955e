//! What the planner finds of a scene ([`Geometry::of`]): each primitive in
//! the camera frame, the content's extent (the fast arithmetic's length
//! unit), and what the coverage grid's rays find (the fractions of the
//! sensor each kind of primitive covers: the cost model's areas).

use super::geometry::{
    cam_point, corner_slopes_d, dot3, norm3, prim_light_distance, sub3, unit_exp, FromOrigin, Geometry,
    PrimGeom, Reach, Reaches, COVERAGE_GRID,
};
use crate::num::FixedF64;
use crate::render::RenderModel;
use crate::scene::Light;
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
    /// Grid rays whose nearest hit is each primitive.
    pub(super) nearest: [u32; crate::scene::MAX_PRIMITIVES],
    /// Shadow tests at the grid rays' nearest hits that the fast
    /// arithmetic's pre-test leaves to the exact test: the line to the
    /// light within an occluder's bounding ball and margin, or an
    /// unbounded occluder ([`Shadows::exact_tests`]).
    pub(super) exact_tests: u32,
}

/// What the survey takes of a frame's shadow tests: each surface's
/// occluders under each light, the lights (a point, or the direction
/// towards it; camera frame).
pub(super) struct Shadows<'a> {
    pub(super) occ: &'a crate::render::shadows::Occluders,
    pub(super) lights: &'a [(bool, [f64; 3])],
}

impl Shadows<'_> {
    /// The surfaces (a bit each, of the first `n`) that take a test.
    fn tested(occ: &crate::render::shadows::Occluders, n: usize) -> u16 {
        (0..n)
            .filter(|&i| cfg!(feature = "shadows") && occ.tests_of(i) > 0)
            .fold(0, |m, i| m | 1 << i)
    }

    /// A scene's lights as [`Shadows`] takes them.
    fn lights_of(scene: &Scene) -> heapless::Vec<(bool, [f64; 3]), { crate::scene::MAX_LIGHTS }> {
        let mut towards = heapless::Vec::new();
        for l in scene.lights() {
            let _ = towards.push(match crate::render::prepare::shading_light(scene, l) {
                crate::render::shading::ShadingLight::Point { p, .. } => (true, p.map(|c| c.f64())),
                crate::render::shading::ShadingLight::Directional { l, .. } => (false, l.map(|c| c.f64())),
            });
        }
        towards
    }

    /// The tests at `pt` (camera frame) of surface `i` that the fast
    /// pre-test ([`crate::render::fast`]'s `Shadow::ball`) does not clear:
    /// its margin `r/1024 + |oc|/1024 + 2⁻¹⁰` m taken as `|oc|/512`
    /// (its `|oc|_∞` share) and 1 mm; a point light within 1/16 m, an
    /// unbounded occluder, always.
    fn exact_tests(&self, prims: &[PrimGeom], i: usize, pt: [f64; 3]) -> u32 {
        let mut n = 0;
        for (li, &(point, l)) in self.lights.iter().enumerate() {
            let mut bits = self.occ.of(li, i);
            let d = if point { sub3(l, pt) } else { l };
            let dd = dot3(d, d);
            let near = point && libm::fabs(d[0]).max(libm::fabs(d[1])).max(libm::fabs(d[2])) < 1.0 / 16.0;
            while bits != 0 {
                let o = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let Some(q) = prims.get(o) else { continue };
                if near || matches!(q.shape, Shape::Plane { .. }) {
                    n += 1;
                    continue;
                }
                let oc = sub3(q.c, pt);
                let along = dot3(oc, d);
                let oc2 = dot3(oc, oc);
                let dist2 = (oc2 - along * along / dd).max(0.0);
                let reach = q.r * (1.0 + 1.0 / 1024.0) + 1.0 / 1024.0 + libm::sqrt(oc2) / 512.0;
                n += u32::from(dist2 <= reach * reach);
            }
        }
        n
    }
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
        (closed, tested): (Option<usize>, u16),
        shadows: &Shadows,
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
                cov.ray(
                    prims,
                    &at,
                    &facing,
                    (closed, tested),
                    directional,
                    (o, d, dd, y),
                    (origin_scale, shadows),
                );
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
        (closed, tested): (Option<usize>, u16),
        directional: bool,
        (o, d, dd, y): ([f64; 3], [f64; 3], f64, f64),
        (origin_scale, shadows): (Option<f64>, &Shadows),
    ) {
        let (mut any, mut others) = (false, false);
        let mut nearest: Option<(f64, &PrimGeom, usize)> = None;
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
                if nearest.is_none_or(|(tn, _, _)| t < tn) {
                    nearest = Some((t, p, i));
                }
            }
        }
        self.hits += any as u32;
        self.closed_hits += (any && !others) as u32;
        self.lobe_hits += nearest.is_some_and(|(_, p, _)| p.ks > 0.0) as u32;
        if let Some((t, _, i)) = nearest.filter(|_| cfg!(feature = "shadows")) {
            if let Some(c) = self.nearest.get_mut(i) {
                *c += 1;
            }
            if tested & (1 << i) != 0 {
                let pt = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
                self.exact_tests += shadows.exact_tests(prims, i, pt);
            }
        }
        if directional
            && nearest.is_some_and(|(_, p, i)| {
                p.ks == 0.0 && !matches!(p.shape, Shape::Sphere { .. }) && tested & (1 << i) == 0
            })
        {
            if any && !others {
                self.closed_flat_hits += 1;
            } else {
                self.flat_hits += 1;
            }
        }
    }
}

impl Geometry {
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    pub(super) fn of(scene: &Scene, model: RenderModel) -> Geometry {
        let cam = &scene.camera;
        let intr = &cam.intrinsics;
        let (fx, fy) = intr.focal_px();
        let (fx, fy) = (fx.f64(), fy.f64());
        let (slope_d, u_corner) = corner_slopes_d(scene);
        let (k1, k2) = scene.distortion.coefficients();
        let (k1, k2) = (k1.f64(), k2.f64());
        let u_max = match scene.distortion.fold_u() {
            Some(f) if !scene.distortion.is_none() => u_corner.min(f.f64()),
            _ => u_corner,
        };
        let s_max = libm::fabs(k1) + libm::fabs(k2) * u_max;
        let g_max = 1.0 + s_max * u_max;
        // The area factor's `g + 2u g'` (camera-model.md §5).
        let h_max = g_max + 2.0 * u_max * (s_max + libm::fabs(k2) * u_max);
        // |J − 1| = |2p + p² + 2u g' (1 + p)| (g = 1 + p) is at most
        // 2a + a² + 2b (1 + a) = g_max h_max − 1, a = |p| ≤ g_max − 1,
        // b = |u g'| ≤ (h_max − g_max)/2.
        let area_dev = if scene.distortion.is_none() {
            0.0
        } else {
            g_max * h_max - 1.0
        };
        let slope = slope_d[0].max(slope_d[1]) * g_max;
        // A calibrated lens: its field surveyed by its own solve.
        let (g_max, area_dev, slope, solve_err) = match scene.calibrated() {
            Some(c) => {
                let e = c.extent((slope_d[0], slope_d[1]));
                (e.gain, e.area_dev, e.slopes.0.max(e.slopes.1), e.solve_err)
            }
            None => (g_max, area_dev, slope, 0.0),
        };
        let origin_scale = match model {
            RenderModel::Perspective => None,
            RenderModel::WeakPerspective { mean_depth } => Some(mean_depth.f64()),
            RenderModel::Orthographic { scale } => Some(intr.focal_length().f64() / scale.f64().max(1e-300)),
        };
        let field = crate::render::prepare::field_box(scene);
        let mut prims = heapless::Vec::new();
        let mut reaches: Reaches = heapless::Vec::new();
        for p in &scene.primitives {
            let (g, reach) = PrimGeom::of(scene, p, origin_scale.is_some(), field);
            let _ = reaches.push(reach);
            let _ = prims.push(g);
        }
        let mut lights = heapless::Vec::new();
        for l in &scene.lights {
            let p = match *l {
                Light::Point { position, .. } => Some(cam_point(scene, position)),
                Light::Directional { .. } => None,
            };
            let _ = lights.push(p);
        }
        let (extent, fast_extent) = extents(&reaches, &lights, origin_scale);
        let e = unit_exp(fast_extent);
        let lens = &cam.lens;
        let d_over_f = lens.diameter().f64() / lens.focal_length().f64();
        let fmt = scene.format;
        let gain = (0..fmt.channels())
            .map(|c| {
                let (n, d) = fmt.channel_scale(c);
                scene.exposure.f64() * core::f64::consts::PI / 4.0 * d_over_f * d_over_f * n as f64 / d as f64
            })
            .fold(0.0, f64::max);
        let dn_max = (0..fmt.channels()).map(|c| fmt.dn_max(c)).max().unwrap_or(255) as f64;
        // The plane the fast arithmetic shades in closed form, as
        // `mix32::Mix32::closed_plane` picks it: the first plane without a
        // checker or a lobe, perspective rays, the camera and every point
        // light off it by 2⁻¹⁰ of the fast unit or more.
        let unit = libm::ldexp(1.0, e);
        // The shadow tests: a surface that takes one is shaded point by
        // point (neither in closed form nor as a flat sum).
        let occ = crate::render::shadows::occluders(
            scene,
            // (Parallel rays stay parallel whatever their scale: a NaN's
            // conversion would panic.)
            origin_scale.map(|k| crate::num::from_f64(k).unwrap_or(crate::scene::Q::MAX)),
            None,
            true,
        );
        let tested = Shadows::tested(&occ, prims.len());
        let closed = (origin_scale.is_none())
            .then(|| {
                prims
                    .iter()
                    .zip(&scene.primitives)
                    .enumerate()
                    .position(|(i, (p, sp))| {
                        matches!(p.shape, Shape::Plane { .. })
                            && tested & (1 << i) == 0
                            && !p.unseen
                            && sp.checker.is_none()
                            && p.ks == 0.0
                            && libm::fabs(dot3(p.c, p.n)) >= unit / 1024.0
                            && lights
                                .iter()
                                .flatten()
                                .all(|l| prim_light_distance(p, *l) >= unit / 1024.0)
                    })
            })
            .flatten();
        let towards = Shadows::lights_of(scene);
        let shadows = Shadows {
            occ: &occ,
            lights: &towards,
        };
        let cov = Coverage::of(scene, &prims, &lights, origin_scale, (closed, tested), &shadows);
        let n = (COVERAGE_GRID.0 * COVERAGE_GRID.1) as f64;
        // (Each surface's share of the sensor times the occluders it is
        // tested against.)
        let shadow_tests = (0..prims.len())
            .filter(|_| cfg!(feature = "shadows"))
            .map(|i| cov.nearest.get(i).map_or(0.0, |h| f64::from(*h)) * f64::from(occ.tests_of(i)))
            .sum::<f64>()
            / n;
        Geometry {
            f_px: fx.max(fy),
            f_row: fx,
            f_col: fy,
            closed,
            u_max,
            slope_d,
            field,
            g_max,
            area_dev,
            solve_err,
            slope,
            origin_scale,
            extent,
            fast_extent,
            unit,
            aperture: None,
            prims,
            lights,
            gain,
            dn_max,
            coverage: cov.hits as f64 / n,
            bounded_area: cov.bounded as f64 / n,
            closed_area: cov.closed_hits as f64 / n,
            lobe_area: cov.lobe_hits as f64 / n,
            facing_area: cov.facing_hits as f64 / n,
            closed_facing_area: cov.closed_facing_hits as f64 / n,
            flat_area: cov.flat_hits as f64 / n,
            closed_flat_area: cov.closed_flat_hits as f64 / n,
            shadows: occ.any(),
            shadow_tests,
            shadow_exact: cov.exact_tests as f64 / n,
        }
    }
}
