//! What the planner knows of a scene's geometry in the camera frame:
//! each primitive's reach, screen coverage and depths (f64).

use crate::geom::projection::{weak_perspective_bound, DepthBox};
use crate::num::FixedF64;
use crate::render::Arithmetic;
use crate::scene::{Scene, Shape};
use crate::{CameraPoint, Len};

/// The fast arithmetic's length unit `U = 2^e`: the smallest with content
/// of `extent` metres within 8 U (e in [−20, 20]).
pub(super) fn unit_exp(extent: f64) -> i32 {
    let mut e = -20;
    while e < 20 && extent > libm::ldexp(8.0, e) {
        e += 1;
    }
    e
}

/// What the planner knows of the scene in the camera frame, in f64.
pub(super) struct Geometry {
    /// Largest focal length in pixels.
    pub(super) f_px: f64,
    /// The focal length along a row (`f_x`), pixels.
    pub(super) f_row: f64,
    /// The focal length along a column (`f_y`), pixels.
    pub(super) f_col: f64,
    /// Largest `u = r_d²` over the sensor (clipped to the fold).
    pub(super) u_max: f64,
    /// Largest |distorted slope| at the corners (x, y).
    pub(super) slope_d: [f64; 2],
    /// The undistorted field's box of slopes, half-widths (x, y)
    /// ([`crate::render::prepare::field_box`]).
    pub(super) field: (f64, f64),
    /// Largest `g` over `[0, u_max]`.
    pub(super) g_max: f64,
    /// A bound of `|J − 1|`, the area factor's, over the field
    /// (`g_max h_max − 1`; 0 without distortion).
    pub(super) area_dev: f64,
    /// A calibrated lens's solve error over the field, normalized units
    /// ([`crate::geom::calibrated::Calibrated::solve_bound`]; 0 without).
    pub(super) solve_err: f64,
    /// Largest |undistorted slope|.
    pub(super) slope: f64,
    /// Parallel rays' origin scale, metres (`None`: perspective).
    pub(super) origin_scale: Option<f64>,
    /// Content extent (primitives, point lights) from the camera, and
    /// from where the fast arithmetic's rays start, metres; that
    /// arithmetic's length unit `U = 2^e`.
    pub(super) extent: f64,
    pub(super) fast_extent: f64,
    pub(super) unit: f64,
    /// Through the aperture (defocus): its radius `d/2`, metres, and
    /// `d/(2Z̃)`, the largest shift of a ray's slopes from its chief ray's.
    pub(super) aperture: Option<(f64, f64)>,
    /// Per primitive: kind, camera-frame centre (or a point), distance of
    /// its centre, radius (spheres, discs; 0 otherwise), smallest length
    /// the fast path must resolve (radius, cell).
    pub(super) prims: heapless::Vec<PrimGeom, { crate::scene::MAX_PRIMITIVES }>,
    /// Per light: camera-frame position (point lights) or `None`.
    pub(super) lights: heapless::Vec<Option<[f64; 3]>, { crate::scene::MAX_LIGHTS }>,
    /// Largest per-channel gain: DN per unit radiance on the axis.
    pub(super) gain: f64,
    /// Largest DN of any channel.
    pub(super) dn_max: f64,
    /// Fraction of the sensor whose rays hit a primitive (sampled).
    pub(super) coverage: f64,
    /// Sum over the bounded primitives of the fraction of the sensor whose
    /// rays hit each (sampled).
    pub(super) bounded_area: f64,
    /// Fraction of the sensor whose rays see the plane the fast arithmetic
    /// shades in closed form (`mix32::Closed`) and no other primitive
    /// (sampled; 0 without such a plane).
    pub(super) closed_area: f64,
    /// Fraction of the sensor whose rays first meet a primitive with a
    /// specular lobe (sampled).
    pub(super) lobe_area: f64,
    /// Sum over the flat primitives facing the camera (normal along the
    /// optical axis: `mix32::flat_pass` takes one `t` a chunk for them)
    /// of the fraction of the sensor whose rays hit each (sampled), the
    /// plane shaded in closed form (`closed_area`'s) left out...
    pub(super) facing_area: f64,
    /// ... and that plane's, if it faces the camera.
    pub(super) closed_facing_area: f64,
    /// Fraction of the sensor whose rays first meet a flat primitive (a
    /// plane, disc or rectangle) without a lobe in a scene lit by
    /// directional lights alone: its shading is kept from hit to hit
    /// (`Mix32::shade_flat`), the plane in closed form (`closed_area`'s)
    /// left out...
    pub(super) flat_area: f64,
    /// ... and that plane's.
    pub(super) closed_flat_area: f64,
    /// Some surface takes a shadow test ([`crate::render::shadows`]).
    pub(super) shadows: bool,
    /// Shadow tests a pixel takes on average (each surface's share of the
    /// sensor, from the coverage grid, times its occluders over the lights).
    pub(super) shadow_tests: f64,
    /// Of those, the tests a pixel takes on average that the fast
    /// arithmetic's pre-test leaves to the exact one
    /// (`super::survey::Coverage::exact_tests`).
    pub(super) shadow_exact: f64,
    /// That plane's index among the primitives.
    pub(super) closed: Option<usize>,
}

/// How far a primitive's points lie from the camera, in the camera frame:
/// a plane's distance `|n·c|` (planes keep the rays at the camera), or a
/// centre and a radius around it (`r`; `a + b` for a rectangle), metres.
#[derive(Clone, Copy)]
pub(super) enum Reach {
    Plane(f64),
    Around([f64; 3], f64),
}

/// The coverage sample grid (columns, rows): the sampled features'
/// resolution (a sample is 1/108 of the sensor): coarser, a principal
/// point moved by a few pixels moved a scene's sampled coverage, and its
/// predicted cost, far more than its measured cost moved; finer, planning
/// costs more for little better predictions (`docs/cost-model.md`).
pub(super) const COVERAGE_GRID: (u32, u32) = (12, 9);

impl PrimGeom {
    /// What [`PrimGeom::hit`] takes of a ray's origin `o`, whatever its
    /// direction: once a primitive for perspective rays (all from `o = 0`).
    pub(super) fn seen_from(&self, o: [f64; 3]) -> FromOrigin {
        let oc = sub3(self.c, o);
        let cc = dot3(oc, oc);
        FromOrigin {
            o,
            v: match self.shape {
                Shape::Sphere { .. } => oc,
                _ => self.n,
            },
            vx: 0.0,
            inside: cc <= self.r * self.r,
            cc_rr: cc - self.r * self.r,
            noc: dot3(self.n, oc),
        }
    }

    /// Where the ray `o + t d`, `t > 0`, first meets the primitive (a
    /// rectangle as the disc through its corners: coverage, not shading):
    /// its `t` (0 from inside a sphere), or `None`. `k` is
    /// [`PrimGeom::seen_from`] `o`, `dd` is `d·d` and `vd` is `k.v·d`.
    pub(super) fn hit(&self, k: &FromOrigin, d: [f64; 3], dd: f64, vd: f64) -> Option<f64> {
        match self.shape {
            Shape::Sphere { .. } => {
                let t = vd;
                if k.inside {
                    Some(0.0)
                } else if t > 0.0 {
                    let disc = t * t - dd * k.cc_rr;
                    (disc >= 0.0).then(|| (t - libm::sqrt(disc)) / dd)
                } else {
                    None
                }
            }
            _ => {
                let den = vd;
                if libm::fabs(den) < 1e-12 {
                    return None;
                }
                let t = k.noc / den;
                if matches!(self.shape, Shape::Plane { .. }) {
                    return (t > 0.0).then_some(t);
                }
                let o = k.o;
                let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
                (t > 0.0 && norm3(sub3(p, self.c)) <= self.r).then_some(t)
            }
        }
    }
}

/// A ray origin's terms for one primitive ([`PrimGeom::seen_from`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct FromOrigin {
    /// The origin `o`, camera frame.
    pub(super) o: [f64; 3],
    /// What a ray's direction `d` is dotted with: `c − o` (a sphere's), or
    /// the normal (a flat shape's).
    pub(super) v: [f64; 3],
    /// `v₀ x̂` for the perspective rays of one column (`x̂` its slope).
    pub(super) vx: f64,
    /// `|c − o| ≤ r` (a sphere's).
    pub(super) inside: bool,
    /// `|c − o|² − r²`.
    pub(super) cc_rr: f64,
    /// `n·(c − o)`.
    pub(super) noc: f64,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct PrimGeom {
    pub(super) shape: Shape,
    /// A point of the primitive (its centre) in the camera frame.
    pub(super) c: [f64; 3],
    /// Unit normal (flat shapes), camera frame.
    pub(super) n: [f64; 3],
    /// Radius (sphere, disc), half-diagonal (rectangle), 0 (plane).
    pub(super) r: f64,
    /// Largest diffuse and specular constants (n ρ/π, (1−n) ρ_s (s+2)/2π)
    /// over its materials, and the largest exponent of a lobe.
    pub(super) kd: f64,
    pub(super) ks: f64,
    pub(super) exponent: u16,
    /// No perspective ray meets it: behind the lens plane
    /// ([`crate::render::prepare::behind_lens`], [`crate::render::prepare::plane_unseen`]).
    pub(super) unseen: bool,
    /// A checkered plane's, disc's or rectangle's texture.
    pub(super) cells: Option<Cells>,
}

/// A flat primitive's checker texture, camera frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Cells {
    /// Its axes (unit). In f32, as `seen`: an estimate needs no more, and
    /// the driven camera plans with up to 16 primitives on its stack (in
    /// f64, with `seen` an `Option`, its peak RAM grew by 584 B on the M3
    /// and 396 B on the M0 in the fresh-clone run of 8853415).
    pub(super) u: [f32; 3],
    pub(super) v: [f32; 3],
    /// Its cell, metres.
    pub(super) cell: f64,
    /// The box of undistorted slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` that holds
    /// the shape's image (a disc's, its bounding square's), rounded
    /// outward, or infinite: any slope (a plane; a shape reaching the lens
    /// plane).
    pub(super) seen: [f32; 4],
}

impl Cells {
    pub(super) fn new(u: [f64; 3], v: [f64; 3], cell: f64, seen: Option<[f64; 4]>) -> Cells {
        let (down, up) = (|x: f64| (x as f32).next_down(), |x: f64| (x as f32).next_up());
        Cells {
            u: u.map(|x| x as f32),
            v: v.map(|x| x as f32),
            cell,
            seen: seen.map_or(
                [f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY],
                |[a, b, c, d]| [down(a), up(b), down(c), up(d)],
            ),
        }
    }
}

/// The box of slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` of the rectangle centred
/// on `c` with half-axes `a u`, `b v` (camera frame, metres): its corners'
/// (all in front of the lens, the image of the rectangle lies within
/// their hull); `None` where one is not in front by 10⁻⁶ of its distance.
pub(super) fn corner_slopes(c: [f64; 3], u: [f64; 3], v: [f64; 3], a: f64, b: f64) -> Option<[f64; 4]> {
    let mut bx = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    for (su, sv) in [(-a, -b), (a, -b), (-a, b), (a, b)] {
        let at = |k: [f64; 3]| dot3(k, [1.0, su, sv]);
        let p = [
            at([c[0], u[0], v[0]]),
            at([c[1], u[1], v[1]]),
            at([c[2], u[2], v[2]]),
        ];
        if !p.iter().all(|v| v.is_finite()) || p[2] <= 1e-6 * norm3(p) {
            return None;
        }
        let (x, y) = (p[0] / p[2], p[1] / p[2]);
        bx = [bx[0].min(x), bx[1].max(x), bx[2].min(y), bx[3].max(y)];
    }
    Some(bx)
}

pub(super) fn norm3(v: [f64; 3]) -> f64 {
    libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
}

pub(super) fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `x^y` for `x > 0`, as `e^(y ln x)`: within a few units of the last
/// place times `|y ln x|` (10⁻¹¹ relative at `s = 65 535`), which the
/// estimates here do not feel. libm's `pow` took 2.6 KB of the driven M0
/// camera's flash, which plans on the device; `exp` and `log` take less.
pub(super) fn pow(x: f64, y: f64) -> f64 {
    libm::exp(y * libm::log(x))
}

/// The sensor corners' distorted slopes: the largest |x̂_d|, |ŷ_d| and the
/// largest `u = r_d²`.
#[inline(always)]
pub(super) fn corner_slopes_d(scene: &Scene) -> ([f64; 2], f64) {
    let intr = &scene.camera.intrinsics;
    let (fx, fy) = intr.focal_px();
    let (fx, fy) = (fx.f64(), fy.f64());
    let (w, h) = intr.size();
    let (ox, oy) = intr.principal_point();
    let (ox, oy) = (ox.f64(), oy.f64());
    let mut slope_d = [0.0f64; 2];
    let mut u_corner: f64 = 0.0;
    for (i, j) in [
        (0.0, 0.0),
        (w as f64 - 1.0, 0.0),
        (0.0, h as f64 - 1.0),
        (w as f64 - 1.0, h as f64 - 1.0),
    ] {
        let xd = (ox - i) / fx;
        let yd = (oy - j) / fy;
        slope_d[0] = slope_d[0].max(libm::fabs(xd));
        slope_d[1] = slope_d[1].max(libm::fabs(yd));
        u_corner = u_corner.max(xd * xd + yd * yd);
    }
    (slope_d, u_corner)
}

/// Per primitive, for the extents: how far it reaches, and its checker's
/// origin (the primitive's point or centre).
pub(super) type Reaches = heapless::Vec<(Reach, Option<[f64; 3]>), { crate::scene::MAX_PRIMITIVES }>;

impl PrimGeom {
    /// Primitive `p` of `scene` in the camera frame, and how far it
    /// reaches; `parallel`: the rays are parallel (no perspective culling),
    /// `field` the undistorted field's box.
    #[inline(always)]
    pub(super) fn of(
        scene: &Scene,
        p: &crate::scene::Primitive,
        parallel: bool,
        field: (f64, f64),
    ) -> (PrimGeom, (Reach, Option<[f64; 3]>)) {
        let cam_pt = |p: crate::WorldPoint| cam_point(scene, p);
        let cam_dir = |d: [crate::Norm; 3]| cam_direction(scene, d);
        let mat = |i: u8| scene.materials.get(i as usize);
        // A disc's or rectangle's centre and in-plane half-axes (a
        // disc's bounding square, along its checker's axes).
        let mut flat: Option<([f64; 3], [f64; 3], f64, f64)> = None;
        let (c, n, r, reach) = match p.shape {
            Shape::Plane { point, normal } => {
                let c = cam_pt(point);
                let n = cam_dir(normal);
                // The fast path holds the plane's distance n·c.
                (c, n, 0.0, Reach::Plane(libm::fabs(dot3(n, c))))
            }
            Shape::Sphere { centre, radius } => {
                let c = cam_pt(centre);
                let r = radius.f64();
                (c, [0.0; 3], r, Reach::Around(c, r))
            }
            Shape::Disc {
                centre,
                normal,
                radius,
            } => {
                let c = cam_pt(centre);
                let r = radius.f64();
                (c, cam_dir(normal), r, Reach::Around(c, r))
            }
            Shape::Rectangle {
                centre,
                u_axis,
                v_axis,
                half,
            } => {
                let c = cam_pt(centre);
                let (a, b) = (half[0].f64(), half[1].f64());
                let (u, v) = (cam_dir(u_axis), cam_dir(v_axis));
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let r = libm::sqrt(a * a + b * b);
                flat = Some((u, v, a, b));
                (c, n, r, Reach::Around(c, a + b))
            }
        };
        let reach = (reach, p.checker.map(|_| c));
        let mut kd: f64 = 0.0;
        let mut ks: f64 = 0.0;
        let mut exponent = 0;
        let mut take = |m: Option<&crate::scene::Material>| {
            if let Some(m) = m {
                let b = crate::render::shading::Brdf::new(m, [crate::scene::Q::ZERO; 3]);
                for c in 0..3 {
                    kd = kd.max(b.kd.get(c).map_or(0.0, |v| v.f64()));
                    ks = ks.max(b.ks.get(c).map_or(0.0, |v| v.f64()));
                }
                if m.has_specular() {
                    exponent = exponent.max(m.exponent);
                }
            }
        };
        take(mat(p.material));
        let mut cells = None;
        if let Some(k) = &p.checker {
            take(mat(k.material));
            let (ku, kv) = (cam_dir(k.u_axis), cam_dir(k.v_axis));
            let seen = match p.shape {
                Shape::Plane { .. } => Some(None),
                Shape::Disc { .. } => Some(corner_slopes(c, ku, kv, r, r)),
                Shape::Rectangle { .. } => Some(flat.and_then(|(u, v, a, b)| corner_slopes(c, u, v, a, b))),
                Shape::Sphere { .. } => None,
            };
            cells = seen.map(|seen| Cells::new(ku, kv, k.cell.f64(), seen));
        }
        let unseen = !parallel
            && match p.shape {
                Shape::Plane { .. } => crate::render::prepare::plane_unseen(n, dot3(n, c), field, 0.0),
                _ => crate::render::prepare::behind_lens(c[2], r),
            };
        let g = PrimGeom {
            shape: p.shape,
            c,
            n,
            r,
            kd,
            ks,
            exponent,
            unseen,
            cells,
        };
        (g, reach)
    }
}

impl Geometry {
    /// The point lights on the side of the plane in closed form
    /// ([`Geometry::closed`]) that the camera, at the origin, sees: those
    /// whose terms `mix32::Closed` keeps. 0 without such a plane.
    pub(super) fn closed_lights(&self) -> usize {
        let Some(p) = self.closed.and_then(|i| self.prims.get(i)) else {
            return 0;
        };
        // The camera's side: the sign of `n·(0 − c)`.
        let camera = -dot3(p.c, p.n);
        let lit = |l: &[f64; 3]| dot3(sub3(*l, p.c), p.n) * camera > 0.0;
        self.lights.iter().flatten().filter(|l| lit(l)).count()
    }

    /// A plane's inverse depths over the field box (the pixel centres'
    /// slopes and half a pixel more, undistorted): `w = n̂·(x̂, ŷ, 1) /
    /// (n̂·c)` is linear in the slopes, so its extremes are at the box's
    /// corners; `None` for a plane through the lens centre (seen edge on).
    pub(super) fn plane_w(&self, p: &PrimGeom) -> Option<(f64, f64)> {
        let (n, (xs, ys)) = (p.n, self.field);
        let dist = dot3(n, p.c);
        if libm::fabs(dist) < 1e-12 {
            return None;
        }
        let w =
            [(-xs, -ys), (xs, -ys), (-xs, ys), (xs, ys)].map(|(x, y)| (n[0] * x + n[1] * y + n[2]) / dist);
        Some(w.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        }))
    }

    /// Whether the cell lines of `p`, a checkered plane, disc or
    /// rectangle, are estimated over the field
    /// ([`Geometry::cells_differing`]): perspective rays (under parallel
    /// rays a plane's cells project at one size).
    pub(super) fn integrates_cells(&self, p: &PrimGeom) -> bool {
        p.cells.is_some() && !p.unseen && self.origin_scale.is_none()
    }

    /// The expected fraction of pixels at which a look sees the other side
    /// of one of the cell lines of `p` (a checkered plane, disc or
    /// rectangle), for `looks` a pixel placed within `geom` pixels by
    /// arithmetic `a`: the mean over the field box of `min(1, looks Σ
    /// δu/c)`, `δu` a family's coordinate error where the plane is seen and
    /// within the box of a disc's or rectangle's image ([`Cells::seen`],
    /// counted as covered throughout; 0 elsewhere; other primitives in
    /// front ignored), `c` the cell.
    ///
    /// With `w = n̂·d / dist` (`d = (x̂, ŷ, 1)`, `n̂·P = dist` the plane:
    /// seen where `w > 0`, the horizon at `w = 0`), a family's coordinate
    /// is `u = â·P = t (â·d)`, `t = 1/w`. Its error is the placement's,
    /// `geom |∇u|` — the slope gradient `∂u/∂x̂ = (â_x w dist − (â·d) n̂_x)
    /// / (w² dist)` per pixel (`/f_x`, `/f_y`): `|∇u| ≤ α/w + β/w²`, `α =
    /// |(â_x/f_x, â_y/f_y)|`, `β = |â·d| |(n̂_x/f_x, n̂_y/f_y)| / |dist|` —
    /// plus the arithmetic's own on `t` (relative `ε_t`, and `ε_w` of `n̂·d`
    /// absolute), on `â·d` (`ε_a`) and where `t` and the coordinate are
    /// stored (`δ`, metres): `δu ≤ (|â·d| ε_t + ε_a)/w + |â·d| ε_w/(|dist|
    /// w²) + (|â·d| + 1/2 + 2⁻⁵) δ` ([`HitError`]). The placement's error
    /// moves a look by at most `geom |∇u|` in `u`: it crosses a line that
    /// passes between its two positions, `geom |∇u| / c` of the looks. The
    /// arithmetic's crosses a line at `|δu| / c` of them, and its roundings
    /// average half their bounds: the estimate takes half of `δu` (on random
    /// hits the fast arithmetic's averaged 0.26 of `δu`, its largest 0.93,
    /// in `a_hit_s_texture_coordinate_is_within_the_planner_s_hit_error`).
    /// Toward the horizon (`w → 0`) the cells pass a pixel apart and the sum
    /// passes 1. `w` is linear in the slopes: the box is cut into strips
    /// across the axis along which `w` changes more, and cells along it; in
    /// each cell the coefficients are taken at its centre and
    /// `min(1, A/w + B/w² + C)` is integrated along that axis in
    /// closed form ([`capped_mean`]).
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    pub(super) fn cells_differing(&self, p: &PrimGeom, a: Arithmetic, geom: f64, looks: f64) -> f64 {
        const CELLS: usize = 4;
        const STRIPS: usize = 8;
        let Some(Cells { u, v, cell, seen }) = p.cells.filter(|_| self.integrates_cells(p)) else {
            return 0.0;
        };
        let (a_u, a_v) = (u.map(f64::from), v.map(f64::from));
        let n = p.n;
        let dist = dot3(n, p.c);
        if libm::fabs(dist) < 1e-12 {
            return 0.0;
        }
        // The field box, or its part where a disc's or rectangle's image
        // lies.
        let (xs, ys) = self.field;
        let [lo_x, hi_x, lo_y, hi_y] = seen.map(f64::from);
        let [x0, x1, y0, y1] = [lo_x.max(-xs), hi_x.min(xs), lo_y.max(-ys), hi_y.min(ys)];
        // (NaN, from no overlap, gives 0.)
        let share = (x1 - x0).max(0.0) * (y1 - y0).max(0.0) / (4.0 * xs * ys).max(1e-300);
        if share <= 0.0 {
            return 0.0;
        }
        let e = HitError::of(a, self.unit, libm::fabs(dist));
        let (fx, fy) = (self.f_row.max(1e-300), self.f_col.max(1e-300));
        let hyp = |x: f64, y: f64| libm::sqrt(x * x + y * y);
        // Per look, both families: δu / c for the placement (`geom` a
        // bound on the move), the arithmetic's mean `|δu|` / c (half its
        // bound) for the hit's.
        let (k, kh) = (looks / cell, 0.5 * looks / cell);
        let alpha = k * geom * (hyp(a_u[0] / fx, a_u[1] / fy) + hyp(a_v[0] / fx, a_v[1] / fy));
        let beta = (k * geom * hyp(n[0] / fx, n[1] / fy) + kh * e.w) / libm::fabs(dist);
        // `w = w0 + wx x̂ + wy ŷ`; `s` runs along the axis of the larger
        // change of `w` over the box, `t` across it.
        let (w0, wx, wy) = (n[2] / dist, n[0] / dist, n[1] / dist);
        let along_x = libm::fabs(wx) * (x1 - x0) >= libm::fabs(wy) * (y1 - y0);
        let ((s0, s1, ws), (t0, t1, wt)) = if along_x {
            ((x0, x1, wx), (y0, y1, wy))
        } else {
            ((y0, y1, wy), (x0, x1, wx))
        };
        let seg = (s1 - s0) / CELLS as f64;
        let mut sum = 0.0;
        for j in 0..STRIPS {
            let t = t0 + (j as f64 + 0.5) * (t1 - t0) / STRIPS as f64;
            for i in 0..CELLS {
                let s = s0 + (i as f64 + 0.5) * seg;
                let (x, y) = if along_x { (s, t) } else { (t, s) };
                let ad = |a: [f64; 3]| libm::fabs(a[0] * x + a[1] * y + a[2]);
                let ads = ad(a_u) + ad(a_v);
                let big_a = alpha + kh * (ads * e.t + 2.0 * e.a);
                let big_b = ads * beta;
                let c = kh * (ads + 2.0 * (0.5 + 1.0 / 32.0)) * e.stored;
                let wc = w0 + ws * s + wt * t;
                sum += capped_mean((big_a, big_b, c), wc, libm::fabs(ws) * seg / 2.0);
            }
        }
        share * sum / (CELLS * STRIPS) as f64
    }

    /// Through the aperture, the largest `|1 − z/Z̃|` over `p`'s depths
    /// (camera-frame `z`; a plane's up to the content's extent); 0 without.
    pub(super) fn defocus_factor(&self, p: &PrimGeom) -> f64 {
        let Some((r, rz)) = self.aperture else {
            return 0.0;
        };
        let focus = r / rz.max(1e-300);
        let (near, far) = match p.shape {
            Shape::Plane { .. } => (0.0, self.extent),
            _ => (p.c[2] - p.r, p.c[2] + p.r),
        };
        libm::fabs(1.0 - near / focus).max(libm::fabs(1.0 - far / focus))
    }

    /// Rays through the aperture: they start up to its radius off the axis
    /// (the fast arithmetic's unit holds the content from there too).
    pub(super) fn through_aperture(&mut self, scene: &Scene) {
        let lens = &scene.camera.lens;
        let r = lens.diameter().f64() / 2.0;
        let rz = r / lens.focus_distance().f64().max(1e-300);
        self.aperture = Some((r, rz));
        self.fast_extent += r;
        self.unit = libm::ldexp(1.0, unit_exp(self.fast_extent));
    }

    /// The pixel → undistorted error without a table, px: per axis, the
    /// slopes' rounding and the polynomial's — `u = r_d²` (δu) times
    /// `g' = k1 + 2 k2 u`, and `g` (δg), times the slope — and √2 of it for
    /// the distance. Fast: S26 slopes, `u` S20, `k`, `s`, `g` S28, all
    /// truncated; wide: I32F32, a few roundings of 2⁻³².
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    pub(super) fn direct_geom_err(&self, a: Arithmetic, scene: &Scene) -> f64 {
        let (du, dg, dx) = match a {
            Arithmetic::Fast => (
                libm::ldexp(1.0, -20) + 2.0 * self.slope * libm::ldexp(1.0, -26),
                (2.0 + self.u_max) * libm::ldexp(1.0, -28),
                (1.0 + self.g_max) * libm::ldexp(1.0, -26),
            ),
            Arithmetic::Wide => (
                libm::ldexp(3.0, -32),
                libm::ldexp(3.0, -32),
                libm::ldexp(2.0, -32),
            ),
        };
        let dist = if scene.calibrated().is_some() {
            // A calibrated lens's solve: its rounding through the inverse's
            // gain, the largest over the field.
            self.solve_err
        } else if scene.distortion.is_none() {
            0.0
        } else {
            let (k1, k2) = scene.distortion.coefficients();
            let deriv = libm::fabs(k1.f64()) + 2.0 * libm::fabs(k2.f64()) * self.u_max;
            self.slope_d[0].max(self.slope_d[1]) * (deriv * du + dg)
        };
        core::f64::consts::SQRT_2 * self.f_px * (dist + dx)
    }
}

/// A world point in the camera frame, f64 metres.
pub(super) fn cam_point(scene: &Scene, p: crate::WorldPoint) -> [f64; 3] {
    scene.camera.extrinsics.world_to_camera(p).value.to_f64()
}

/// A world direction in the camera frame (`R d`), f64.
pub(super) fn cam_direction(scene: &Scene, d: [crate::Norm; 3]) -> [f64; 3] {
    scene.camera.extrinsics.rotation().map(|row| {
        (0..3)
            .map(|k| row.get(k).zip(d.get(k)).map_or(0.0, |(a, b)| a.f64() * b.f64()))
            .sum::<f64>()
    })
}

/// The weak-perspective bound (pixels) over the camera-frame box around the
/// scene's primitives, and the box's mean depth; `None` if a primitive is
/// unbounded or the box reaches the lens plane.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
pub(super) fn weak_perspective_over_scene(scene: &Scene) -> Option<(f64, Len)> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut grow = |p: [f64; 3]| {
        for k in 0..3 {
            if let (Some(l), Some(h), Some(v)) = (lo.get_mut(k), hi.get_mut(k), p.get(k)) {
                *l = l.min(*v);
                *h = h.max(*v);
            }
        }
    };
    let cam_pt = |p: crate::WorldPoint| cam_point(scene, p);
    let cam_dir = |d: [crate::Norm; 3]| cam_direction(scene, d);
    for prim in &scene.primitives {
        match prim.shape {
            Shape::Plane { .. } => return None,
            Shape::Sphere { centre, radius } => {
                let (c, r) = (cam_pt(centre), radius.f64());
                grow([c[0] - r, c[1] - r, c[2] - r]);
                grow([c[0] + r, c[1] + r, c[2] + r]);
            }
            Shape::Disc {
                centre,
                normal,
                radius,
            } => {
                // Extent of a disc along axis k: r·sqrt(1 − n_k²).
                let (c, n, r) = (cam_pt(centre), cam_dir(normal), radius.f64());
                let e = n.map(|nk| r * libm::sqrt((1.0 - nk * nk).max(0.0)));
                grow([c[0] - e[0], c[1] - e[1], c[2] - e[2]]);
                grow([c[0] + e[0], c[1] + e[1], c[2] + e[2]]);
            }
            Shape::Rectangle {
                centre,
                u_axis,
                v_axis,
                half,
            } => {
                let (c, u, v) = (cam_pt(centre), cam_dir(u_axis), cam_dir(v_axis));
                let (a, b) = (half[0].f64(), half[1].f64());
                for (su, sv) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
                    grow([
                        c[0] + su * a * u[0] + sv * b * v[0],
                        c[1] + su * a * u[1] + sv * b * v[1],
                        c[2] + su * a * u[2] + sv * b * v[2],
                    ]);
                }
            }
        }
    }
    if scene.primitives.is_empty() || lo[2] <= 0.0 {
        return None;
    }
    let min = CameraPoint::from_f64(lo).ok()?;
    let max = CameraPoint::from_f64(hi).ok()?;
    let z_bar: Len = crate::num::from_f64((lo[2] + hi[2]) / 2.0)?;
    let bound = weak_perspective_bound(&scene.camera.intrinsics, DepthBox { min, max }, z_bar).ok()?;
    if bound.saturated {
        return None;
    }
    Some((bound.value.f64(), z_bar))
}

/// An arithmetic's error in a plane coordinate `u = t (â·d)` of a
/// perspective ray's hit, `t = dist / (n̂·d)` ([`Geometry::cells_differing`]):
/// bounds on each rounding, whose errors are each within the bound and,
/// truncations or rounding, half of it on average.
pub(super) struct HitError {
    /// `t`'s relative error.
    pub(super) t: f64,
    /// `n̂·d`'s absolute error.
    pub(super) w: f64,
    /// `â·d`'s absolute error.
    pub(super) a: f64,
    /// Where `t` and the coordinate are stored: `t`'s absolute error is
    /// this, and the stored coordinate's `|â·d| + 1/2 + 2⁻⁵` times this,
    /// metres.
    pub(super) stored: f64,
}

impl HitError {
    /// Fast (`mix32::Ray::plane_t`, `Ray::along`, `MixChecker::cell`):
    /// `n̂·d` and `â·d` truncated to S24, `1/(n̂·d)` within 2⁻²¹ and `dist`
    /// in S24 U; `t` floored to S18 U, times `â·d`, less the texture's
    /// origin (floored to S24 U: within `|â|₁ 2⁻²⁴ U < 2⁻²³ U`), and the
    /// coordinate rounded to S18 U: `(|â·d| + 1/2 + 2⁻⁵) 2⁻¹⁸ U`
    /// (`mix32::tests::a_hit_s_texture_coordinate_is_within_the_planner_s_hit_error`
    /// measures it).
    /// Wide (I32F32, `render::WideFrame::look`): `n̂·d`, `â·d`, `dist`, `t` and
    /// the point rounded to 2⁻³², a few each.
    pub(super) fn of(a: Arithmetic, unit: f64, dist: f64) -> HitError {
        match a {
            Arithmetic::Fast => HitError {
                t: libm::ldexp(1.0, -21) + libm::ldexp(unit, -24) / dist,
                w: libm::ldexp(1.0, -24),
                a: libm::ldexp(1.0, -24),
                stored: libm::ldexp(unit, -18),
            },
            Arithmetic::Wide => HitError {
                t: libm::ldexp(2.0, -32) / dist,
                w: libm::ldexp(3.0, -32),
                a: libm::ldexp(3.0, -32),
                stored: libm::ldexp(2.0, -32),
            },
        }
    }
}

/// The mean of `φ(w) = min(1, a/w + b/w² + c)` (0 where `w ≤ 0`) over `w`
/// in `[wc − h, wc + h]`, `a, b, c ≥ 0`: from its antiderivative, `w` up to
/// `w*` (where `φ = 1`), then `w* + a ln(w/w*) + b (1/w* − 1/w) + c (w −
/// w*)`.
pub(super) fn capped_mean((a, b, c): (f64, f64, f64), wc: f64, h: f64) -> f64 {
    if c >= 1.0 {
        return if wc - h >= 0.0 {
            1.0
        } else if wc + h <= 0.0 {
            0.0
        } else {
            (wc + h) / (2.0 * h)
        };
    }
    let r = 1.0 - c;
    let star = (a + libm::sqrt(a * a + 4.0 * b * r)) / (2.0 * r);
    let phi = |w: f64| {
        if w <= 0.0 {
            0.0
        } else {
            (a / w + b / (w * w) + c).min(1.0)
        }
    };
    let big = |w: f64| {
        if w <= 0.0 {
            0.0
        } else if w <= star {
            w
        } else {
            star + a * libm::log(w / star) + b * (1.0 / star - 1.0 / w) + c * (w - star)
        }
    };
    if star.is_nan() || star <= 0.0 || h <= 1e-9 * libm::fabs(wc).max(star) {
        phi(wc)
    } else {
        ((big(wc + h) - big(wc - h)) / (2.0 * h)).clamp(0.0, 1.0)
    }
}

/// The distance from a point light to the nearest point of a primitive
/// (a lower bound), metres.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
pub(super) fn prim_light_distance(p: &PrimGeom, l: [f64; 3]) -> f64 {
    match p.shape {
        Shape::Plane { .. } => libm::fabs(dot3(sub3(l, p.c), p.n)),
        Shape::Sphere { .. } => (norm3(sub3(l, p.c)) - p.r).max(0.0),
        Shape::Disc { .. } | Shape::Rectangle { .. } => {
            let d = sub3(l, p.c);
            let h = libm::fabs(dot3(d, p.n));
            let lateral = (norm3(d) * norm3(d) - h * h).max(0.0);
            let out = (libm::sqrt(lateral) - p.r).max(0.0);
            libm::sqrt(h * h + out * out)
        }
    }
}
