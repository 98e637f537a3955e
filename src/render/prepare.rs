//! A frame's preparation shared by both arithmetics: the scene moved into
//! the camera frame (primitives with their slope-space bounds, lights), and
//! the culling tests the planner and the renderer share.

use crate::num::scalar::Scalar;
use crate::num::{quotient, FixedF64, Norm, Wide};
use crate::render::options::ClosedMean;
use crate::render::shading::{dot, from_q3, ShadingLight, V3};
use crate::scene::{Light, Primitive, Scene, Shape, Q};
use core::ops::{Add as _, Mul as _};

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

/// What the fast path is prepared from, beyond the scene: the wide
/// preparation's geometry and constants (I32F32, camera frame).
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
pub(crate) struct FastInput {
    pub(crate) x0: i128,
    pub(crate) dx: i128,
    pub(crate) y0: i128,
    pub(crate) dy: i128,
    /// `k1`, `k2` and the `u` limit, if distortion is modelled (polynomial).
    pub(crate) distortion: Option<([Q; 2], Q)>,
    pub(crate) origin_scale: Option<Q>,
    pub(crate) specular_all: bool,
    pub(crate) gain: V3,
    pub(crate) samples: u8,
    pub(crate) adaptive: bool,
    /// Defocus: the aperture pattern's points (0: none).
    pub(crate) aperture: u16,
    /// [`Options::closed_mean`].
    pub(crate) closed_mean: ClosedMean,
    /// The principal point is the sensor's centre, `o_x = (W − 1)/2`
    /// exactly: column `W − 1 − i` sees the mirror image of column `i`'s
    /// slopes.
    pub(crate) centred: bool,
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
