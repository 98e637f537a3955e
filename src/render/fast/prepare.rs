//! The fast arithmetic's preparation: the camera-frame scene
//! ([`crate::render::prepare`]) in the fast formats, with the frame's
//! length unit, and what the formats cannot hold refused.

use super::aperture::aperture_terms;
use super::arith::{isqrt_q, len_s, recip_len, recip_z, sat32, shl_q, unit_s30, wmul, zip3, Pf};
use super::intersect::{Inner, MixChecker, MixPrim, MixShape};
use super::rays::{undistort_k, undistort_kj};
use super::shade::lobe_below;
use super::{Aperture, Input, Mix32, MixLight, ALONG_S42};
use crate::num::{div_q, from_acc, mul_sat};
use crate::render::shading::{Brdf, ShadingLight, V3};
use crate::render::{RenderError, Unfit};
use crate::scene::{PixelFormat, Q};

impl Input<'_> {
    /// The scene's primitives in the camera frame (culled unless every
    /// stage is kept).
    pub(super) fn prims(&self) -> impl Iterator<Item = crate::render::prepare::CamPrimQ> + '_ {
        let cull = !self.specular_all;
        // With defocus the slope bounds widen by the blur.
        let blur = (self.aperture > 0).then(|| crate::render::prepare::lens_blur(self.scene));
        (self.scene.primitives.iter())
            .map(move |p| crate::render::prepare::cam_prim(self.scene, p, self.origin_scale, cull, blur))
    }

    /// [`Input::prims`] without their slope bounds (for the extents).
    pub(super) fn shapes(&self) -> impl Iterator<Item = crate::render::prepare::CamPrimQ> + '_ {
        (self.scene.primitives.iter())
            .map(move |p| crate::render::prepare::cam_prim(self.scene, p, self.origin_scale, false, None))
    }

    /// The scene's lights in the camera frame.
    pub(super) fn lights(&self) -> impl Iterator<Item = ShadingLight> + '_ {
        (self.scene.lights.iter()).map(|l| crate::render::prepare::shading_light(self.scene, l))
    }

    /// The scene's materials, folded with its ambient light.
    pub(super) fn materials(&self) -> impl Iterator<Item = Brdf> + '_ {
        (self.scene.materials.iter()).map(|m| Brdf::new(m, self.scene.ambient))
    }
}

/// `c` in a frame moved along the axis to `z = z0`, metres.
pub(super) fn at(c: V3, z0: Q) -> V3 {
    [c[0], c[1], c[2].saturating_sub(z0)]
}

/// A primitive in the camera frame moved along the axis to `z = z0`
/// (planes are never moved: [`parallel_start`]).
pub(super) fn ahead(mut p: crate::render::prepare::CamPrimQ, z0: Q) -> crate::render::prepare::CamPrimQ {
    use crate::render::prepare::CamShapeQ as S;
    if z0 == Q::ZERO {
        return p;
    }
    match &mut p.shape {
        S::Plane { .. } => {}
        S::Sphere { c, .. } => *c = at(*c, z0),
        S::Disc { n, dist, c, .. } | S::Rect { n, dist, c, .. } => {
            *c = at(*c, z0);
            *dist = crate::render::shading::dot(*n, *c);
        }
    }
    if let Some(k) = &mut p.checker {
        k.origin = at(k.origin, z0);
    }
    p
}

/// A bounded primitive's centre and how far its points lie from it (the
/// radius; `hu + hv` for a rectangle); `None` for a plane. Inlined, as its
/// callers.
#[inline(always)]
pub(super) fn centre_and_reach(shape: &crate::render::prepare::CamShapeQ) -> Option<(V3, Q)> {
    use crate::render::prepare::CamShapeQ as S;
    match *shape {
        S::Plane { .. } => None,
        S::Sphere { c, r2, .. } | S::Disc { c, r2, .. } => Some((c, isqrt_q(r2))),
        S::Rect { c, hu, hv, .. } => Some((c, hu.saturating_add(hv))),
    }
}

/// The largest distance of the content from the camera, and from the
/// origin of the frame moved to `z = z0` (there, with parallel rays, 8
/// times their origins' scale as well, so that the scale stays within
/// 64 U), metres. One pass; inlined, so that its primitive shares the
/// caller's stack slot.
#[inline(always)]
pub(super) fn content_extent(f: &Input, z0: Q) -> (Q, Q) {
    use crate::render::prepare::CamShapeQ as S;
    let (mut here, mut moved) = (Q::ZERO, Q::ZERO);
    let mut grow = |c: V3, r: Q| {
        here = here.max(v_len(c).saturating_add(r));
        moved = moved.max(v_len(at(c, z0)).saturating_add(r));
    };
    for p in f.shapes() {
        match (centre_and_reach(&p.shape), p.shape) {
            (Some((c, r)), _) => grow(c, r),
            // |n·c| (with a plane, z0 is 0).
            (None, S::Plane { dist, .. }) => grow([Q::ZERO, Q::ZERO, dist], Q::ZERO),
            (None, _) => {}
        }
        if let Some(k) = &p.checker {
            grow(k.origin, Q::ZERO);
        }
    }
    for l in f.lights() {
        if let ShadingLight::Point { p, .. } = l {
            grow(p, Q::ZERO);
        }
    }
    if let (Some(k), true) = (f.origin_scale, z0 > Q::ZERO) {
        moved = moved.max(k >> 3);
    }
    (here, moved)
}

/// Where parallel rays may start along the axis, metres: the whole metre
/// below the nearest point of every primitive (so nothing they meet lies
/// behind it); 0 for perspective rays or a scene with a plane (unbounded in
/// depth). [`Mix32::fill`] starts them there if the content's extent is
/// then smaller. Inlined, as [`content_extent`].
#[inline(always)]
pub(super) fn parallel_start(f: &Input) -> Q {
    if f.origin_scale.is_none() {
        return Q::ZERO;
    }
    let mut near: Option<Q> = None;
    for p in f.shapes() {
        let Some((c, reach)) = centre_and_reach(&p.shape) else {
            return Q::ZERO;
        };
        let z = c[2].saturating_sub(reach);
        near = Some(near.map_or(z, |n| n.min(z)));
    }
    // ⌈near⌉ − 1 < near.
    near.map_or(Q::ZERO, |n| {
        n.saturating_ceil().saturating_sub(Q::ONE).max(Q::ZERO)
    })
}

#[inline(never)]
pub(super) fn v_len(v: V3) -> Q {
    // |v| ≤ 8.4·10⁶ m for scene content: √ of the I32F32 square sum in f64-free
    // integer form (one-off, per frame).
    let s: u128 = v
        .iter()
        .map(|c| (c.to_bits() as i128 * c.to_bits() as i128) as u128)
        .sum();
    // √ of 2^-64 m² → 2^-32 m.
    Q::from_bits(crate::num::isqrt_u128(s).min(i64::MAX as u128) as i64)
}

/// The fast arithmetic's length unit for the frame: where its rays start
/// (`z0`), `e` with the content within `8 U = 2^(e+3)` m, and the
/// aperture's radius and focus distance ([`Aperture::lens`]); refused
/// where no `e` in [−20, 20] holds the content.
#[inline(always)]
fn frame_unit(f: &Input) -> Result<(Q, i32, (Q, Q)), Unfit> {
    // The unit: content within 8 U of where the rays start.
    let z0 = parallel_start(f);
    let (here, moved) = content_extent(f, z0);
    let (z0, extent) = if z0 > Q::ZERO && moved < here {
        (z0, moved)
    } else {
        (Q::ZERO, here)
    };
    // Through the aperture, rays start up to its radius off the axis
    // (and their slopes are the chief ray's shifted by up to d/(2Z̃)).
    let (ap_r, ap_z) = Aperture::lens(f);
    let extent = extent.saturating_add(ap_r);
    // U = 2^e with extent ≤ 8 U, e in [−20, 20].
    let mut e: i32 = -20;
    while e < 20 && extent > shl_q(8, e) {
        e += 1;
    }
    if extent > shl_q(8, e) {
        return Err(Unfit::TooFar);
    }
    Ok((z0, e, (ap_r, ap_z)))
}

/// The frame's slopes in the fast formats: the distortion polynomial's
/// coefficients (S28), the `u` limit, the slope box's margin, the
/// parallel rays' origin scale (S24 U) and, with distortion, the `e` of
/// the `2^e` that bounds its area factor ([`Mix32::area`]); refused where
/// the slopes, `g`, `g + 2u g'` or the origins leave their formats.
#[inline(always)]
fn fast_slopes(f: &Input, e: i32, (ap_r, ap_z): (Q, Q)) -> Result<Slopes, Unfit> {
    // Slopes: |x̂_d|, |ŷ_d| < 32 at the corners (they are monotonic in
    // the pixel index), |g| < 8 and |x̂|, |ŷ| ≤ 16.
    let corner = |a: i128, d: i128, n: u16| -> Q {
        let s = |i: i128| from_acc(a - d * i).abs();
        s(0).max(s(n as i128 - 1))
    };
    let (xm, ym) = (corner(f.x0, f.dx, f.width), corner(f.y0, f.dy, f.height));
    // (and one step past the last column: the accumulator takes it).
    let step = from_acc(f.dx).abs();
    if xm.saturating_add(step) >= Q::from_num(32) || ym >= Q::from_num(32) {
        return Err(Unfit::FieldTooWide);
    }
    let (k, limit, gmax, margin, area) = match f.distortion {
        Some(([k1, k2], limit)) => {
            let u_corner = mul_sat(xm, xm).saturating_add(mul_sat(ym, ym));
            let u_max = u_corner.min(limit);
            let s = k1.abs().saturating_add(mul_sat(k2.abs(), u_max));
            let g = Q::ONE.saturating_add(mul_sat(s, u_max));
            // The area factor's `h = g + 2u g'`, `g' = k1 + 2 k2 u`, and
            // `J = g h`, bounded over the field by the coefficients'
            // magnitudes (a margin of 2⁻⁸ for the rounding); `2^e ≥ J`.
            let dg = s.saturating_add(mul_sat(k2.abs(), u_max));
            let h = g.saturating_add(mul_sat(dg, u_max).saturating_mul_int(2));
            if s >= Q::from_num(8) || g >= Q::from_num(8) || h >= Q::from_num(8) {
                return Err(Unfit::Distortion);
            }
            let jb = mul_sat(g, h).saturating_add(Q::from_bits(1 << 24));
            let area = (jb.to_bits() - 1).max(0) as u64;
            let area = (64 - area.leading_zeros()).saturating_sub(32);
            let s28 = |q: Q| sat32(q.to_bits() >> 4);
            // `undistort`'s x̂ within E units of S26 of the polynomial of
            // the exact k1, k2 (monotone in the field): g to 2⁻²⁸ (1 + u)²
            // (k1, k2 to S28; k2 u and s u truncated to S28) + 2⁻²⁰ 2s
            // (u truncated to S20), times |x̂_d|, and the product's
            // truncation: E = |x̂_d| (128 s + (1 + u)²/4) + 1. The slope
            // box's margin is 2E ([`Mix32::trace`]).
            let w = Q::ONE.saturating_add(u_max);
            let e = mul_sat(xm, s.saturating_mul_int(128).saturating_add(mul_sat(w, w) >> 2))
                .saturating_add(Q::ONE);
            let margin = e
                .saturating_mul_int(2)
                .saturating_ceil()
                .saturating_to_num::<i32>();
            (
                Some([s28(k1), s28(k2)]),
                sat32(limit.to_bits() >> 12),
                g,
                margin,
                f.relative_illumination.then_some(area),
            )
        }
        None => (None, i32::MAX, Q::ONE, 2, None),
    };
    // (Aperture rays' slopes are the chief ray's shifted by up to d/(2Z̃):
    // d/2 ≤ (16 − slope) Z̃.)
    let slope = mul_sat(xm.max(ym), gmax);
    if slope > Q::from_num(16) || ap_r > mul_sat(Q::from_num(16) - slope, ap_z) {
        return Err(Unfit::FieldTooWide);
    }
    // Parallel rays: origins within 64 U (so that n·o and the sphere's
    // offsets keep their formats), the scale in S24.
    let parallel = match f.origin_scale {
        None => None,
        Some(k) => {
            let k24 = len_s(k, e, 24);
            if k <= Q::ZERO || k24 == i32::MAX || mul_sat(slope, k) > shl_q(64, e) {
                return Err(Unfit::OriginsTooFar);
            }
            Some(k24)
        }
    };
    Ok(Slopes {
        k,
        limit,
        margin,
        parallel,
        area,
    })
}

/// The frame's slopes in the fast formats ([`fast_slopes`]).
struct Slopes {
    /// The distortion polynomial's `k1`, `k2` (S28), if distorted.
    k: Option<[i32; 2]>,
    /// The `u` limit.
    limit: i32,
    /// The slope box's margin.
    margin: i32,
    /// Parallel rays' origin scale, S24 U.
    parallel: Option<i32>,
    /// The `e` of the `2^e` that bounds the area factor ([`Mix32::area`]).
    area: Option<u32>,
}

/// A sphere's `1/r` in its format ([`recip_len`]): refused for a radius
/// below `2^-10 U`.
fn inv_radius(r: Q, e: i32) -> Result<(u32, u32), Unfit> {
    recip_len(r, e).ok_or(Unfit::TooSmall)
}

/// A checker's `1/cell` (its cell `1/inv_cell` metres) as
/// [`MixChecker::inv_cell`] holds it: refused for a cell below `2^-10 U`.
fn inv_cell(inv_cell: Q, e: i32) -> Result<(u32, u32), Unfit> {
    div_q(Q::ONE, inv_cell)
        .and_then(|cell| recip_len(cell, e))
        .and_then(|(m, sh)| Some((m, (sh + 30).checked_sub(32).filter(|k| *k < 32)?)))
        .ok_or(Unfit::TooSmall)
}

/// How the fast formats hold frame `f`: its length unit, where its rays
/// start and its slopes; or why they cannot ([`Unfit`]). With
/// [`prims_fit`], the fast arithmetic's one rule: [`Mix32::fill`] follows
/// it (its primitives through the same [`inv_radius`] and [`inv_cell`])
/// and the planner asks it of every fast candidate ([`fits`]).
#[inline(never)]
fn layout(f: &Input) -> Result<(Q, i32, (Q, Q), Slopes), Unfit> {
    if f.table {
        return Err(Unfit::Table);
    }
    if f.scene.calibrated().is_some() {
        return Err(Unfit::Calibrated);
    }
    if f.aperture > 0 && f.samples > 1 {
        return Err(Unfit::Defocus);
    }
    // (The aperture loop takes a pixel's sum from its chief ray where its
    // rays see one surface, which a shadow's edge does not change.)
    if f.aperture > 0 && f.occluders.any() {
        return Err(Unfit::Shadows);
    }
    let (z0, e, ap) = frame_unit(f)?;
    Ok((z0, e, ap, fast_slopes(f, e, ap)?))
}

/// Whether the primitives' radii and checker cells hold in a frame of
/// unit `U = 2^e` ([`Mix32::fill_prims`] refuses the same).
fn prims_fit(f: &Input, e: i32) -> Result<(), Unfit> {
    for p in f.shapes() {
        if let crate::render::prepare::CamShapeQ::Sphere { r2, .. } = p.shape {
            inv_radius(isqrt_q(r2), e)?;
        }
        if let Some(k) = &p.checker {
            inv_cell(k.inv_cell, e)?;
        }
    }
    Ok(())
}

/// Whether the fast arithmetic renders `scene` with `opts` ([`layout`],
/// [`prims_fit`]); a scene that does not prepare at all is not the
/// formats' to refuse (building its frame says why, on either
/// arithmetic). Out of line: planning runs once a frame.
#[inline(never)]
pub(crate) fn fits(scene: &crate::scene::Scene, opts: &crate::render::Options) -> Result<(), Unfit> {
    match crate::render::prepare::Prepared::new(scene, opts) {
        Ok(p) => {
            let occ = crate::render::shadows::of_frame(scene, opts, p.origin_scale);
            let f = Input::of(scene, opts, &p, occ);
            prims_fit(&f, layout(&f)?.1)
        }
        Err(_) => Ok(()),
    }
}

impl<'a> Input<'a> {
    /// What the fast arithmetic takes of `scene` prepared (`p`) for `opts`.
    /// Out of line: one copy for the planner and the preparation.
    #[inline(never)]
    pub(crate) fn of(
        scene: &'a crate::scene::Scene,
        opts: &crate::render::Options,
        p: &crate::render::prepare::Prepared,
        occluders: crate::render::shadows::Occluders,
    ) -> Input<'a> {
        Input {
            table: p.stages.distortion.is_some()
                && opts.distortion_eval != crate::render::DistortionEval::Polynomial,
            width: p.width,
            height: p.height,
            format: scene.format,
            x0: p.x0,
            dx: p.dx,
            y0: p.y0,
            dy: p.dy,
            distortion: p.distortion.map(|d| (d.k, d.limit)),
            vignetting: p.stages.vignetting,
            relative_illumination: p.stages.relative_illumination,
            origin_scale: p.origin_scale,
            specular_all: opts.keep_all_stages,
            scene,
            background: scene.background,
            gain: p.gain,
            samples: p.stages.samples,
            adaptive: p.stages.adaptive,
            aperture: opts.aperture,
            occluders,
            closed_mean: opts.closed_mean,
            centred: p.centred,
        }
    }
}

impl Mix32 {
    /// A path with nothing in it, for [`Mix32::fill`] to fill in place.
    pub(crate) const EMPTY: Mix32 = Mix32 {
        width: 0,
        format: PixelFormat::Gray8,
        x0: 0,
        dx: 0,
        y0: 0,
        dy: 0,
        k: None,
        area: None,
        cos4_of_ra: false,
        limit: 0,
        box_margin: 0,
        vignetting: false,
        parallel: None,
        prims: heapless::Vec::new(),
        lights: heapless::Vec::new(),
        kd: [[Pf { m: 0, e: 0 }; 3]; crate::scene::MAX_MATERIALS],
        ka: [[0; 3]; crate::scene::MAX_MATERIALS],
        ks: [[Pf { m: 0, e: 0 }; 3]; crate::scene::MAX_MATERIALS],
        lobe: [None; crate::scene::MAX_MATERIALS],
        lobe_below: [0; crate::scene::MAX_MATERIALS],
        bg: [0; 3],
        noise_spec: None,
        noise: None,
        samples: 1,
        adaptive: false,
        aperture: None,
        closed: None,
        inner: None,
        mirror: false,
        uniform_on: true,
        #[cfg(feature = "shadows")]
        shadow: None,
    };

    /// Converts a prepared frame in place (the path's state is kilobytes:
    /// no copies of it on the stack) as [`layout`] says; refuses what the
    /// formats cannot hold, leaving `self` partly filled — the caller drops
    /// it then.
    pub(crate) fn fill(&mut self, f: &Input) -> Result<(), RenderError> {
        let (z0, e, ap, slopes) = layout(f).map_err(|_| RenderError::OutsideFormat)?;
        let Slopes {
            k,
            limit,
            margin,
            parallel,
            area,
        } = slopes;
        self.fill_prims(f, z0, e, ap)?;
        self.fill_lights(f, z0, e);
        self.fill_materials(f, area.unwrap_or(0));
        self.parallel = parallel;
        self.width = f.width;
        self.format = f.format;
        self.x0 = (f.x0 >> 6) as i64;
        self.dx = (f.dx >> 6) as i64;
        self.y0 = f.y0;
        self.dy = f.dy;
        self.k = k;
        self.area = area;
        self.limit = limit;
        self.box_margin = margin.max(2);
        self.vignetting = f.vignetting;
        self.cos4_of_ra = f.vignetting && area.is_none();
        // (Rebuilt from its fields: copied whole, the M3 build links
        // `memmove` for it, 1.6 KB of flash.)
        self.noise_spec = f.scene.noise.map(|n| crate::scene::Noise { ..n });
        if !matches!(f.samples, 1 | 2 | 4 | 8 | 16) {
            return Err(RenderError::Degenerate);
        }
        self.samples = f.samples;
        self.adaptive = f.adaptive && f.samples > 1;
        self.aperture = match f.aperture {
            0 => None,
            // Perspective rays through the aperture.
            _ if parallel.is_some() => return Err(RenderError::Degenerate),
            m => Some(Aperture::new(f, m, e)?),
        };
        self.mirror = f.centred && self.samples == 1 && self.aperture.is_none();
        #[cfg(feature = "shadows")]
        {
            self.shadow = super::shadow::Shadow::of(f, e, z0);
        }
        self.closed = self.closed_plane(f.closed_mean);
        self.inner = if parallel.is_none() {
            Inner::of(&self.prims)
        } else {
            None
        };
        let lobe = self.lobe;
        let has_lobe = |m: u8| lobe.get(m as usize).is_some_and(Option::is_some);
        let directional = self
            .lights
            .iter()
            .all(|l| matches!(l, MixLight::Directional { .. }));
        let tests: [u32; crate::scene::MAX_PRIMITIVES] = core::array::from_fn(|i| self.shadow_tests(i));
        for (p, tests) in self.prims.iter_mut().zip(tests) {
            // (A surface that takes a shadow test is shaded point by point.)
            p.flat = directional && !matches!(p.shape, MixShape::Sphere { .. }) && tests == 0;
            let lobed = has_lobe(p.material) || p.checker.as_ref().is_some_and(|k| has_lobe(k.material));
            // (A sphere's is the bound its chief rays are tested against,
            // whatever its shading.)
            if !matches!(p.shape, MixShape::Sphere { .. }) && (!p.flat || lobed) {
                p.spread = 0;
            }
        }
        self.set_frame_id(0);
        Ok(())
    }

    /// The frame's primitives in the fast formats, in length unit `U = 2^e`
    /// with the rays starting at `z = z0`; `ap` the aperture's radius and
    /// focus distance ([`Aperture::lens`]).
    // Out of line: its loop over the primitives inlined into `fill`
    // measured more flash.
    #[inline(never)]
    fn fill_prims(&mut self, f: &Input, z0: Q, e: i32, (ap_r, ap_z): (Q, Q)) -> Result<(), RenderError> {
        use crate::render::prepare::CamShapeQ as S;
        let bad = RenderError::OutsideFormat;
        let l24 = |q: Q| len_s(q, e, 24);
        let l18 = |q: Q| len_s(q, e, 18);
        let u3 = |v: V3| v.map(unit_s30);
        let dot48 = |a: [i32; 3], b: [i32; 3]| -> i64 { a.iter().zip(b).map(|(x, y)| wmul(*x, y)).sum() };
        // S48 → [`Ray::along`]'s format: S42 for perspective rays.
        let along = if f.origin_scale.is_some() { 0 } else { ALONG_S42 };

        let prims = &mut self.prims;
        prims.clear();
        for p in f.prims() {
            let p = ahead(p, z0);
            let shape = match p.shape {
                S::Plane { n, dist } => MixShape::Plane {
                    n: u3(n),
                    dist: l24(dist),
                    rz: recip_z(u3(n)),
                },
                S::Sphere { c, r2, .. } => {
                    let r = isqrt_q(r2);
                    let c24 = c.map(l24);
                    let r18 = l18(r) as u64;
                    MixShape::Sphere {
                        cz50: (c24[2] as i64) << 26,
                        c: c24,
                        c18: c.map(l18),
                        // r ≤ 8 U: r² ≤ 64 U², S24.
                        r2_24: sat32((l24(r) as i64 * l24(r) as i64) >> 24),
                        r2: r18 * r18,
                        r24: l24(r),
                        fine: false,
                        inv_r: inv_radius(r, e).map_err(|_| bad)?,
                    }
                }
                S::Disc { n, dist, c, r2 } => {
                    // r ≤ 8 U: r² below 2⁵⁴ in S48.
                    let r = l24(isqrt_q(r2)) as u64;
                    MixShape::Disc {
                        n: u3(n),
                        dist: l24(dist),
                        rz: recip_z(u3(n)),
                        c24: c.map(l24),
                        r2: r * r,
                    }
                }
                S::Rect {
                    n,
                    dist,
                    c,
                    u,
                    v,
                    hu,
                    hv,
                } => {
                    // The centre and half sizes in S24 U (within the
                    // content's 8 U), `c·u` S54 → `along`'s format: in S18
                    // their floors moved the edges by up to `(|u|₁ + 1)
                    // 2⁻¹⁸ U`, more than the hit's own error
                    // (`planner::fast_boundary_m`).
                    let (n, c, u, v) = (u3(n), c.map(l24), u3(u), u3(v));
                    MixShape::Rect {
                        n,
                        dist: l24(dist),
                        rz: recip_z(n),
                        u,
                        v,
                        cu: dot48(c, u) >> (along + 6),
                        cv: dot48(c, v) >> (along + 6),
                        hu: (l24(hu) as i64) << (24 - along),
                        hv: (l24(hv) as i64) << (24 - along),
                    }
                }
            };
            let checker = match &p.checker {
                Some(k) => {
                    // The origin in S24 U (within the content's 8 U: below
                    // 2²⁷), `o·u` S54 → `along`'s format, less half of
                    // S18 U, so that [`MixChecker::cell`]'s floor to S18
                    // rounds: an origin in S18 and the floor would move
                    // the cell lines by up to `(|u|₁ + 1) 2⁻¹⁸ U`, more
                    // than a hit's own rounding (`planner::HitError`).
                    let o = k.origin.map(l24);
                    let (u, v) = (u3(k.u), u3(k.v));
                    let half = 1i64 << (29 - along);
                    Some(MixChecker {
                        u,
                        v,
                        ou: (dot48(o, u) >> (along + 6)) - half,
                        ov: (dot48(o, v) >> (along + 6)) - half,
                        inv_cell: inv_cell(k.inv_cell, e).map_err(|_| bad)?,
                        material: k.material,
                    })
                }
                None => None,
            };
            let _ = prims.push(MixPrim {
                shape,
                material: p.material,
                checker,
                bounds: p.bounds.map(|b| b.map(|q| sat32(q.to_bits() >> 6))),
                nl: [0; crate::scene::MAX_LIGHTS],
                flat: false,
                spread: 0,
                depth: [i32::MIN, i32::MAX],
            });
            if let (true, Some(q)) = (f.aperture > 0, prims.last_mut()) {
                (q.spread, q.depth) = aperture_terms(&p, (ap_r, ap_z), e);
            }
        }
        Ok(())
    }

    /// The frame's lights in the fast formats (`I/r²` takes `r` in U), and
    /// each flat primitive's height under each point light.
    #[inline(always)]
    fn fill_lights(&mut self, f: &Input, z0: Q, e: i32) {
        let l18 = |q: Q| len_s(q, e, 18);
        let u3 = |v: V3| v.map(unit_s30);
        let dot48 = |a: [i32; 3], b: [i32; 3]| -> i64 { a.iter().zip(b).map(|(x, y)| wmul(*x, y)).sum() };
        let prims = &mut self.prims;
        // I/r² with r in U: I / U² = I 2^(−2e).
        let lights = &mut self.lights;
        lights.clear();
        for l in f.lights() {
            let m = match l {
                ShadingLight::Point { p, i } => MixLight::Point {
                    p: at(p, z0).map(l18),
                    i: i.map(|v| {
                        let p = Pf::of_q(v);
                        Pf { e: p.e - 2 * e, ..p }
                    }),
                },
                ShadingLight::Directional { l, e: irr } => MixLight::Directional {
                    l: u3(l),
                    e: irr.map(Pf::of_q),
                },
            };
            let _ = lights.push(m);
        }
        // A light's height above a planar primitive, S48 U² (|n·P_L| <
        // 2⁶², |dist 2²⁴| < 2⁵⁵). Taken only from 2⁻¹⁰ U up: there `r`,
        // from the hit point rounded to 2⁻¹⁸ U, is at least the height less
        // that rounding, so `n·l ≤ |n| r` to within far less than the
        // factor 2 that `cos_over_r3` leaves; nearer, per pixel.
        for p in prims.iter_mut() {
            let (MixShape::Plane { n, dist, .. }
            | MixShape::Disc { n, dist, .. }
            | MixShape::Rect { n, dist, .. }) = p.shape
            else {
                continue;
            };
            for (c, l) in p.nl.iter_mut().zip(lights.iter()) {
                if let MixLight::Point { p: pl, .. } = l {
                    let h = dot48(n, *pl) - ((dist as i64) << 24);
                    *c = if h.unsigned_abs() >> 38 != 0 { h } else { 0 };
                }
            }
        }
    }

    /// The materials' constants times the exposure's gain times `2^area`
    /// (the bound of the distortion's area factor, [`Mix32::area`]) (and
    /// the background's), and which spheres take the fine normal.
    #[inline(always)]
    fn fill_materials(&mut self, f: &Input, area: u32) {
        let gain = f
            .gain
            .map(|g| Pf::new(g.to_bits().max(0) as u64, area as i32 - 32));
        self.kd = [[Pf::default(); 3]; crate::scene::MAX_MATERIALS];
        self.ka = [[0u64; 3]; crate::scene::MAX_MATERIALS];
        self.ks = [[Pf::default(); 3]; crate::scene::MAX_MATERIALS];
        self.lobe = [None; crate::scene::MAX_MATERIALS];
        self.lobe_below = [0; crate::scene::MAX_MATERIALS];
        for (i, m) in f.materials().enumerate() {
            let (Some(kd), Some(ka), Some(ks), Some(lobe), Some(below)) = (
                self.kd.get_mut(i),
                self.ka.get_mut(i),
                self.ks.get_mut(i),
                self.lobe.get_mut(i),
                self.lobe_below.get_mut(i),
            ) else {
                continue;
            };
            *kd = zip3(m.kd, gain, |k, g| Pf::of_q(k) * g);
            *ka = zip3(m.ka, gain, |k, g| (Pf::of_q(k) * g).to_sum(15));
            *ks = zip3(m.ks, gain, |k, g| Pf::of_q(k) * g);
            let has = m.ks.iter().any(|k| *k > Q::ZERO);
            *lobe = (has || f.specular_all).then_some(m.exponent);
            // (Only where the lobe is rendered: the bisection is some
            // thousands of instructions.)
            *below = if lobe.is_some() { lobe_below(m.exponent) } else { 0 };
        }
        self.bg = zip3(f.background, gain, |b, g| (Pf::of_q(b) * g).to_sum(15));
        // Spheres under a lobe take the fine normal.
        let lobe = self.lobe;
        let has_lobe = |m: u8| lobe.get(m as usize).is_some_and(Option::is_some);
        for p in self.prims.iter_mut() {
            let lobed = has_lobe(p.material) || p.checker.as_ref().is_some_and(|k| has_lobe(k.material));
            if let MixShape::Sphere { fine, .. } = &mut p.shape {
                *fine = lobed;
            }
        }
    }

    /// Traces every pixel's aperture rays, also those whose sums are known
    /// to be one (`Mix32::uniform`): the check that the rule changes no
    /// sum, and the cost it saves.
    pub fn trace_every_aperture_ray(&mut self) {
        self.uniform_on = false;
    }

    /// The index of the plane shaded in closed form, if any.
    pub fn closed_plane_index(&self) -> Option<usize> {
        self.closed.as_ref().map(|c| c.index as usize)
    }

    /// Sets the frame id the noise is keyed by (0 after preparation).
    pub fn set_frame_id(&mut self, id: u32) {
        self.noise = crate::render::sensor::noise::Stage::for_frame(self.noise_spec, self.format, id);
    }

    /// `ŷ_d` of line `j`, S26.
    #[inline(always)]
    pub(super) fn yd(&self, j: u16) -> i32 {
        ((self.y0 - self.dy * j as i128) >> 38) as i32
    }

    /// `(x̂, ŷ)` (S26) of a distorted point, or `None` beyond the fold.
    #[inline(always)]
    pub(super) fn undistort(&self, xd: i32, yd: i32, yd2: i64) -> Option<(i32, i32)> {
        match self.k {
            Some(k) => undistort_k(k, self.limit, xd, yd, yd2),
            None => Some((xd, yd)),
        }
    }

    /// [`Mix32::undistort`] with the distortion's area factor over `2^e`
    /// (S31, [`undistort_kj`]; 1 without distortion).
    #[inline(always)]
    pub(super) fn undistort_j(&self, xd: i32, yd: i32, yd2: i64) -> Option<(i32, i32, u32)> {
        match self.k {
            Some(k) => undistort_kj(k, self.limit, (xd, yd, yd2), self.area),
            None => Some((xd, yd, 1 << 31)),
        }
    }

    /// The undistorted point of pixel `(i, j)` in I32F32, or `None` outside
    /// the lens field or past the sensor's last column — the pixel loop's
    /// own arithmetic.
    pub fn undistorted(&self, i: u16, j: u16) -> Option<(Q, Q)> {
        // The right half of a mirrored frame: its left column's, mirrored.
        let m = self.width.checked_sub(i)?.checked_sub(1)?;
        let (i, sign) = if self.mirror && m < i { (m, -1) } else { (i, 1) };
        let xd = ((self.x0 - self.dx * i as i64) >> 32) as i32;
        let yd = self.yd(j);
        let (x, y) = self.undistort(xd, yd, wmul(yd, yd))?;
        Some((
            Q::from_bits(sign * ((x as i64) << 6)),
            Q::from_bits((y as i64) << 6),
        ))
    }
}
