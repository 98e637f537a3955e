//! A frame's preparation shared by both arithmetics: the scene moved into
//! the camera frame (primitives with their slope-space bounds, lights), and
//! the culling tests the planner and the renderer share.

use crate::num::scalar::Scalar;
use crate::num::{from_acc, quotient, FixedF64, Norm, Wide};
use crate::render::options::{DistortionEval, Options, RenderError, RenderModel, Stages, MAX_SLOPE};
use crate::render::shading::{dot, from_q3, ShadingLight, V3};
use crate::render::vignetting;
use crate::scene::{Light, Primitive, Scene, Shape, Q};
use core::ops::{Add as _, Mul as _};
use fixed::types::I64F64;

/// A primitive in the camera frame.
/// A primitive in the camera frame, I32F32 (what [`crate::render::fast`] converts).
#[cfg(feature = "mix32")]
pub(crate) type CamPrimQ = CamPrim<Q>;
/// Its shape.
#[cfg(feature = "mix32")]
pub(crate) type CamShapeQ = CamShape<Q>;

#[derive(Clone, Copy, Debug)]
pub(crate) enum CamShape<S> {
    /// `n̂·P = dist`.
    Plane {
        n: V3<S>,
        dist: S,
    },
    Sphere {
        c: V3<S>,
        r2: S,
        inv_r: S,
    },
    Disc {
        n: V3<S>,
        dist: S,
        c: V3<S>,
        r2: S,
    },
    Rect {
        n: V3<S>,
        dist: S,
        c: V3<S>,
        u: V3<S>,
        v: V3<S>,
        hu: S,
        hv: S,
    },
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct CamChecker<S> {
    pub(crate) origin: V3<S>,
    pub(crate) u: V3<S>,
    pub(crate) v: V3<S>,
    pub(crate) inv_cell: S,
    pub(crate) material: u8,
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct CamPrim<S> {
    pub(crate) shape: CamShape<S>,
    pub(crate) material: u8,
    pub(crate) checker: Option<CamChecker<S>>,
    /// The undistorted slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` outside which
    /// no ray meets the primitive (with a margin): rays outside skip its
    /// test. `None` for planes and what reaches the lens plane.
    pub(crate) bounds: Option<[S; 4]>,
}

impl CamPrim<Q> {
    /// The primitive in another scalar type (prepared in I32F32, converted
    /// once).
    pub(crate) fn to<S: Scalar>(&self) -> CamPrim<S> {
        let shape = match self.shape {
            CamShape::Plane { n, dist } => CamShape::Plane {
                n: from_q3(n),
                dist: S::from_q(dist),
            },
            CamShape::Sphere { c, r2, inv_r } => CamShape::Sphere {
                c: from_q3(c),
                r2: S::from_q(r2),
                inv_r: S::from_q(inv_r),
            },
            CamShape::Disc { n, dist, c, r2 } => CamShape::Disc {
                n: from_q3(n),
                dist: S::from_q(dist),
                c: from_q3(c),
                r2: S::from_q(r2),
            },
            CamShape::Rect {
                n,
                dist,
                c,
                u,
                v,
                hu,
                hv,
            } => CamShape::Rect {
                n: from_q3(n),
                dist: S::from_q(dist),
                c: from_q3(c),
                u: from_q3(u),
                v: from_q3(v),
                hu: S::from_q(hu),
                hv: S::from_q(hv),
            },
        };
        CamPrim {
            shape,
            material: self.material,
            bounds: self.bounds.map(|b| b.map(S::from_q)),
            checker: self.checker.map(|k| CamChecker {
                origin: from_q3(k.origin),
                u: from_q3(k.u),
                v: from_q3(k.v),
                inv_cell: S::from_q(k.inv_cell),
                material: k.material,
            }),
        }
    }
}

pub(crate) fn q(w: Wide) -> Q {
    w.narrow::<Q>().value
}

pub(crate) fn v3_world_to_cam(scene: &Scene, p: crate::geom::frame::WorldPoint) -> V3 {
    let c = scene.camera.extrinsics.world_to_camera(p).value;
    [Q::from_num(c.x), Q::from_num(c.y), Q::from_num(c.z)]
}

/// Rotates a world direction into the camera frame (`R d`).
pub(crate) fn dir_to_cam(scene: &Scene, d: [Norm; 3]) -> V3 {
    let r = scene.camera.extrinsics.rotation();
    r.map(|row| {
        q(Wide::of(row[0])
            .mul(Wide::of(d[0]))
            .add(Wide::of(row[1]).mul(Wide::of(d[1])))
            .add(Wide::of(row[2]).mul(Wide::of(d[2]))))
    })
}

/// What every frame is prepared from, once, whichever arithmetic renders
/// it: the pixel grid's slopes, the stages, the distortion polynomial and
/// its limit, the parallel rays' origin scale and the exposure's gain, in
/// I32F32 (camera frame). Each arithmetic's state is filled from it
/// (`WideFrame::fill`, `Mix32::fill`); neither builds the other's.
#[derive(Clone, Copy)]
pub(crate) struct Prepared {
    pub(crate) width: u16,
    pub(crate) height: u16,
    pub(crate) stages: Stages,
    /// `x̂_d` of column 0 and its step per column, `ŷ_d` of line 0 and its
    /// step per line, I64F64 raw.
    pub(crate) x0: i128,
    pub(crate) dx: i128,
    pub(crate) y0: i128,
    pub(crate) dy: i128,
    /// If distortion is modelled (or every stage kept): `k1`, `k2`, the `u`
    /// beyond which a pixel is outside the lens field (`Q::MAX`: none), and
    /// the largest `u` a table must span.
    pub(crate) distortion: Option<Poly>,
    /// Parallel rays' origin scale (`Z̄` or `f/m`); `None`: perspective.
    pub(crate) origin_scale: Option<Q>,
    /// `K π/4 (d/f)²` per channel (with the channel's full-scale factor):
    /// DN per unit radiance on the axis.
    pub(crate) gain: V3,
    /// The principal point is the sensor's centre, `o_x = (W − 1)/2`
    /// exactly: column `W − 1 − i` sees the mirror image of column `i`'s
    /// slopes.
    #[cfg_attr(not(feature = "mix32"), allow(dead_code))]
    pub(crate) centred: bool,
}

/// The distortion polynomial a frame renders with ([`Prepared::distortion`]).
#[derive(Clone, Copy)]
pub(crate) struct Poly {
    pub(crate) k: [Q; 2],
    pub(crate) limit: Q,
    pub(crate) u_max: Q,
}

impl Prepared {
    /// `scene` prepared for `opts`: the stages checked (sample grid and
    /// aperture sizes, what the build holds), the slopes, the distortion's
    /// range over the sensor, the origin scale and the gain.
    #[inline(never)]
    pub(crate) fn new(scene: &Scene, opts: &Options) -> Result<Prepared, RenderError> {
        let intr = &scene.camera.intrinsics;
        let (w, h) = intr.size();
        let (fx, fy) = intr.focal_px();
        let (ox, oy) = intr.principal_point();
        let one = Wide::int(1);
        let inv_fx = one.checked_div(Wide::of(fx)).ok_or(RenderError::Degenerate)?;
        let x0 = Wide::of(ox).mul(inv_fx).narrow::<I64F64>().value.to_bits();
        let dx = inv_fx.narrow::<I64F64>().value.to_bits();
        let inv_fy = one.checked_div(Wide::of(fy)).ok_or(RenderError::Degenerate)?;
        let y0 = Wide::of(oy).mul(inv_fy).narrow::<I64F64>().value.to_bits();
        let dy = inv_fy.narrow::<I64F64>().value.to_bits();
        let mut stages = Stages {
            model: opts.model,
            distortion: None,
            distortion_lut: None,
            vignetting: !matches!(opts.model, RenderModel::Orthographic { .. }),
            relative_illumination: false,
            specular: scene.has_specular() || opts.keep_all_stages,
            format: scene.format,
            arithmetic: opts.arithmetic,
            samples: opts.samples.clamp(1, crate::render::sensor::sampling::MAX_GRID),
            adaptive: opts.adaptive && opts.samples > 1,
            aperture: opts.aperture,
            noise: scene.noise.is_some(),
            // (Set where the frame's shadow tests are proved:
            // `render::shadows::of_frame`.)
            shadows: false,
        };
        if !matches!(stages.samples, 1 | 2 | 4 | 8 | 16) {
            return Err(RenderError::Degenerate);
        }
        let aperture = opts.aperture > 0;
        if aperture
            && (!crate::render::sensor::defocus::is_size(opts.aperture)
                || !matches!(opts.model, RenderModel::Perspective))
        {
            return Err(RenderError::Degenerate);
        }
        if cfg!(not(feature = "sensor")) && (stages.samples > 1 || stages.noise || aperture) {
            return Err(RenderError::NotBuilt);
        }
        // Distortion over [0, u_max], u_max = min(fold, corner maximum). With
        // every stage kept, a lens without distortion runs the identity
        // (`k1 = k2 = 0`, g = 1).
        let mut distortion = None;
        let calibrated = scene.calibrated().is_some();
        if !scene.distortion.is_none() || calibrated || opts.keep_all_stages {
            let dist = scene.distortion;
            let mut u_corner = Q::ZERO;
            for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
                let (xd, yd) = (from_acc(x0 - dx * i as i128), from_acc(y0 - dy * j as i128));
                u_corner = u_corner.max(Scalar::add(Scalar::mul(xd, xd), Scalar::mul(yd, yd)));
            }
            let fold = dist.fold_u().map(Q::saturating_from_num);
            let (u_max, limit) = match fold {
                Some(f) if f < u_corner => (f, f),
                _ => (u_corner, Q::MAX),
            };
            // A calibrated lens is solved per sample (its `k` stay 0 here).
            stages.distortion = Some(if calibrated {
                DistortionEval::Polynomial
            } else {
                opts.distortion_eval
            });
            stages.relative_illumination = opts.relative_illumination;
            let (k1, k2) = dist.coefficients();
            let k = [k1, k2].map(Q::saturating_from_num);
            distortion = Some(Poly { k, limit, u_max });
        }
        let origin_scale = match opts.model {
            RenderModel::Perspective => None,
            RenderModel::WeakPerspective { mean_depth } => Some(Q::saturating_from_num(mean_depth)),
            RenderModel::Orthographic { scale } => Some(q(Wide::of(intr.focal_length())
                .checked_div(Wide::of(scale))
                .ok_or(RenderError::Degenerate)?)),
        };
        // Constants: gain = K π/4 (d/f)².
        let lens = &scene.camera.lens;
        let dof = Wide::of(lens.diameter())
            .checked_div(Wide::of(lens.focal_length()))
            .ok_or(RenderError::Degenerate)?;
        let gain = [0, 1, 2].map(|c| vignetting::gain(scene.exposure, dof, scene.format.channel_scale(c)));
        let p = Prepared {
            width: w,
            height: h,
            stages,
            x0,
            dx,
            y0,
            dy,
            distortion,
            origin_scale,
            gain,
            centred: intr.is_centred_x(),
        };
        // A table's corners are checked where the table is built; a
        // calibrated lens's field ends within reach (geom::calibrated).
        if !calibrated && (opts.distortion_eval == DistortionEval::Polynomial || p.distortion.is_none()) {
            p.corners_within()?;
        }
        Ok(p)
    }

    /// [`RenderError::FieldTooWide`] if an undistorted sensor corner lies
    /// beyond [`MAX_SLOPE`], by the polynomial in I32F32 (a corner outside
    /// the lens field is none).
    fn corners_within(&self) -> Result<(), RenderError> {
        let (w, h) = (self.width, self.height);
        for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
            let (xd, yd) = (
                from_acc(self.x0 - self.dx * i as i128),
                from_acc(self.y0 - self.dy * j as i128),
            );
            let xy = match &self.distortion {
                Some(d) => undistort_poly(xd, yd, d.k, d.limit),
                None => Some((xd, yd)),
            };
            if let Some((x, y)) = xy {
                let lim = Q::from_num(MAX_SLOPE);
                if Scalar::abs(x) > lim || Scalar::abs(y) > lim {
                    return Err(RenderError::FieldTooWide);
                }
            }
        }
        Ok(())
    }
}

/// The undistorted point `(x̂, ŷ) = g(u) (x̂_d, ŷ_d)` by the polynomial
/// `g = 1 + u (k1 + k2 u)`, `u = x̂_d² + ŷ_d²`; `None` beyond `limit`
/// (outside the lens field).
#[inline(always)]
pub(crate) fn undistort_poly<S: Scalar>(xd: S, yd: S, k: [S; 2], limit: S) -> Option<(S, S)> {
    let u = xd.mul(xd).add(yd.mul(yd));
    if u > limit {
        return None;
    }
    let g = S::ONE.add(u.mul(k[0].add(u.mul(k[1]))));
    Some((xd.mul(g), yd.mul(g)))
}

/// What the culling keeps to spare, absolute and relative (metres, slopes):
/// 2⁻¹⁰, far more than any arithmetic's rounding moves a hit
/// ([`slope_bounds`], [`behind_lens`], [`plane_unseen`]).
const SPARE: f64 = 1.0 / 1024.0;

/// The undistorted slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` of the rays that can
/// meet a bounded primitive (its bounding sphere), widened by 2⁻¹⁰ plus
/// 2⁻¹⁰ relative — far more than any arithmetic's rounding moves a hit —
/// or `None` (a plane the rays reach; a bounding sphere that reaches the
/// lens plane). Perspective rays: bounds no slope lies within,
/// `[MAX, MIN, MAX, MIN]`, for a plane no ray in the field reaches
/// ([`plane_unseen`]) and a bounding sphere behind the lens plane
/// ([`behind_lens`]); else the tangents from the centre of projection,
/// `(c_x c_z ± r √(c_x² + c_z² − r²)) / (c_z² − r²)`, widened with
/// `blur = (d/2, 1/Z̃)` (defocus) by `(d/2) max |1/z − 1/Z̃|` over the
/// sphere's depths; parallel rays of origin scale `k`: `(c_x ± r) / k`.
/// Computed once a frame, in f64.
fn slope_bounds(
    scene: &Scene,
    shape: &CamShape<Q>,
    origin_scale: Option<Q>,
    blur: Option<(f64, f64)>,
) -> Option<[Q; 4]> {
    const NONE: [Q; 4] = [Q::MAX, Q::MIN, Q::MAX, Q::MIN];
    let f = |q: Q| q.f64();
    let (c, r) = match *shape {
        CamShape::Plane { .. } if origin_scale.is_some() => return None,
        CamShape::Plane { n, dist } => {
            // Through the aperture (radius d/2, focused at Z̃) a ray's slope is
            // its chief ray's shifted by up to (d/2)/Z̃.
            let (a, shift) = blur.map_or((0.0, 0.0), |(half_d, inv_focus)| (half_d, half_d * inv_focus));
            let (x, y) = field_box(scene);
            return plane_unseen(n.map(f), f(dist), (x + shift, y + shift), a).then_some(NONE);
        }
        CamShape::Sphere { c, r2, .. } => (c.map(f), libm::sqrt(f(r2))),
        CamShape::Disc { c, r2, .. } => (c.map(f), libm::sqrt(f(r2))),
        CamShape::Rect { c, hu, hv, .. } => (c.map(f), libm::sqrt(f(hu) * f(hu) + f(hv) * f(hv))),
    };
    let widen = |lo: f64, hi: f64| {
        let m = SPARE;
        (lo - m - m * libm::fabs(lo), hi + m + m * libm::fabs(hi))
    };
    let [(x0, x1), (y0, y1)] = match origin_scale {
        // No ray meets it: bounds that no slope lies within.
        None if behind_lens(c[2], r) => return Some(NONE),
        None => {
            let zz = c[2] * c[2] - r * r;
            if c[2] <= r || zz <= 1e-3 * c[2] * c[2] {
                return None;
            }
            let spread = blur.map_or(0.0, |(half_d, inv_focus)| {
                let w = |z: f64| libm::fabs(1.0 / z - inv_focus);
                half_d * w(c[2] - r).max(w(c[2] + r))
            });
            let range = |cx: f64| {
                let s = libm::sqrt((cx * cx + zz).max(0.0));
                (
                    (cx * c[2] - r * s) / zz - spread,
                    (cx * c[2] + r * s) / zz + spread,
                )
            };
            [range(c[0]), range(c[1])]
        }
        Some(k) => {
            let k = f(k);
            if k <= 0.0 {
                return None;
            }
            [((c[0] - r) / k, (c[0] + r) / k), ((c[1] - r) / k, (c[1] + r) / k)]
        }
    };
    let ((x0, x1), (y0, y1)) = (widen(x0, x1), widen(y0, y1));
    // Finite here; a NaN would leave the primitive unbounded rather than
    // panic in the conversion.
    if [x0, x1, y0, y1].iter().any(|v| v.is_nan()) {
        return None;
    }
    let q = |v: f64| crate::num::from_f64(v).unwrap_or(if v < 0.0 { Q::MIN } else { Q::MAX });
    Some([q(x0), q(x1), q(y0), q(y1)])
}

/// Whether a bounding sphere (centre depth `c_z`, radius `r`, metres, camera
/// frame) lies wholly behind the lens plane, with 2⁻¹⁰ m and 2⁻¹⁰ of its
/// size to spare: no perspective ray meets it, since every one (the chief
/// ray from the centre of projection, an aperture ray from the lens) runs
/// forward from `z = 0`. Its primitive is then tested on no chunk
/// ([`slope_bounds`]) and costs the planner nothing.
pub(crate) fn behind_lens(c_z: f64, r: f64) -> bool {
    let m = SPARE;
    c_z + r + m + m * (libm::fabs(c_z) + r) < 0.0
}

/// The half-widths `(x̂, ŷ)` of a box of undistorted slopes that holds every
/// pixel's rays (its centre's and up to half a pixel beyond it, the pixel
/// area's samples; perspective rays through the centre of projection): the
/// distorted corners' largest |slopes| and half a pixel, times the
/// polynomial's largest gain `1 + (|k₁| + |k₂| u) u` there. f64, once a
/// plane a preparation (and once a plan).
pub(crate) fn field_box(scene: &Scene) -> (f64, f64) {
    let intr = &scene.camera.intrinsics;
    let (fx, fy) = intr.focal_px();
    let (fx, fy) = (fx.f64().max(1e-300), fy.f64().max(1e-300));
    let (w, h) = intr.size();
    let (ox, oy) = intr.principal_point();
    let far = |o: f64, n: u16| libm::fabs(o).max(libm::fabs(o - (f64::from(n) - 1.0))) + 0.5;
    let (x, y) = (far(ox.f64(), w) / fx, far(oy.f64(), h) / fy);
    if let Some(c) = scene.calibrated() {
        return c.extent((x, y)).slopes;
    }
    let u = x * x + y * y;
    let (k1, k2) = scene.distortion.coefficients();
    let gain = 1.0 + (libm::fabs(k1.f64()) + libm::fabs(k2.f64()) * u) * u;
    (x * gain, y * gain)
}

/// Whether no perspective ray with undistorted slopes in the box `(x, y)`
/// (`|x̂| ≤ x`, `|ŷ| ≤ y`), from the lens plane within `a` (metres) of its
/// centre, meets the plane `n̂·P = dist` (camera frame): `t = (dist −
/// n̂·o)/(n̂·d)` takes the sign of `dist` (`|n̂·o| ≤ a |n̂_xy|`), and `n̂·d`, linear
/// in the slopes, has the other sign over the whole box — with 2⁻¹⁰ (m,
/// and of the slopes) to spare. The plane then lies behind the view, as
/// the wall behind a camera in a room: it is tested on no chunk
/// ([`slope_bounds`]) and costs the planner nothing.
pub(crate) fn plane_unseen(n: [f64; 3], dist: f64, (x, y): (f64, f64), a: f64) -> bool {
    let m = SPARE;
    let s = if dist > 0.0 { 1.0 } else { -1.0 };
    // The largest of s n̂·(x̂, ŷ, 1) over the box, at a corner.
    let toward = s * n[2] + libm::fabs(n[0]) * x + libm::fabs(n[1]) * y;
    let nxy = libm::sqrt(n[0] * n[0] + n[1] * n[1]);
    libm::fabs(dist) > a * nxy + m && toward < -m * (1.0 + x + y)
}

/// The lens's `(d/2, 1/Z̃)` (metres, 1/metres): with defocus, a primitive's
/// slope bounds widen by half its largest blur circle, since the aperture
/// ray that meets it at depth `z` has a chief ray within `(d/2)|1/z − 1/Z̃|`
/// of the hit's slope ([`slope_bounds`]).
#[inline(never)]
pub(crate) fn lens_blur(scene: &Scene) -> (f64, f64) {
    let lens = &scene.camera.lens;
    let focus = lens.focus_distance().f64();
    (lens.diameter().f64() / 2.0, 1.0 / focus)
}

/// A light in the camera frame, I32F32.
pub(crate) fn shading_light(scene: &Scene, l: &Light) -> ShadingLight {
    match *l {
        Light::Point { position, intensity } => ShadingLight::Point {
            p: v3_world_to_cam(scene, position),
            i: intensity,
        },
        Light::Directional { towards, irradiance } => ShadingLight::Directional {
            l: dir_to_cam(scene, towards),
            e: irradiance,
        },
    }
}

/// A primitive in the camera frame, with its slope-space bounds when
/// `cull` (for rays of parallel-ray origin scale `origin_scale`, or
/// perspective rays, through the aperture with `blur`: [`slope_bounds`]).
pub(crate) fn cam_prim(
    scene: &Scene,
    p: &Primitive,
    origin_scale: Option<Q>,
    cull: bool,
    blur: Option<(f64, f64)>,
) -> CamPrim<Q> {
    let to_q3 = |d: [Norm; 3]| dir_to_cam(scene, d);
    let (shape, origin) = match p.shape {
        Shape::Plane { point, normal } => {
            let n = to_q3(normal);
            let pc = v3_world_to_cam(scene, point);
            (CamShape::Plane { n, dist: dot(n, pc) }, pc)
        }
        Shape::Sphere { centre, radius } => {
            let c = v3_world_to_cam(scene, centre);
            let r = Q::from_num(radius);
            (
                CamShape::Sphere {
                    c,
                    r2: q(Wide::of(radius).mul(Wide::of(radius))),
                    inv_r: crate::num::div_q(Q::ONE, r).unwrap_or(Q::MAX),
                },
                c,
            )
        }
        Shape::Disc {
            centre,
            normal,
            radius,
        } => {
            let n = to_q3(normal);
            let c = v3_world_to_cam(scene, centre);
            (
                CamShape::Disc {
                    n,
                    dist: dot(n, c),
                    c,
                    r2: q(Wide::of(radius).mul(Wide::of(radius))),
                },
                c,
            )
        }
        Shape::Rectangle {
            centre,
            u_axis,
            v_axis,
            half,
        } => {
            let u = to_q3(u_axis);
            let v = to_q3(v_axis);
            let c = v3_world_to_cam(scene, centre);
            // n = u × v
            let x = |a: Q, b: Q, c: Q, d: Q| Scalar::sub(Scalar::mul(a, b), Scalar::mul(c, d));
            let n = [
                x(u[1], v[2], u[2], v[1]),
                x(u[2], v[0], u[0], v[2]),
                x(u[0], v[1], u[1], v[0]),
            ];
            (
                CamShape::Rect {
                    n,
                    dist: dot(n, c),
                    c,
                    u,
                    v,
                    hu: Q::from_num(half[0]),
                    hv: Q::from_num(half[1]),
                },
                c,
            )
        }
    };
    CamPrim {
        shape,
        material: p.material,
        bounds: if cull {
            slope_bounds(scene, &shape, origin_scale, blur)
        } else {
            None
        },
        checker: p.checker.map(|k| CamChecker {
            origin,
            u: to_q3(k.u_axis),
            v: to_q3(k.v_axis),
            inv_cell: quotient::<Q>(Wide::int(1), Wide::of(k.cell)).value,
            material: k.material,
        }),
    }
}
