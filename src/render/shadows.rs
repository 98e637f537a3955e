//! Cast shadows (camera-model.md §6): which primitives can shadow which
//! surface under which light — proved once a frame, so that a scene, a
//! surface or a light that needs no test pays nothing — and the segment
//! test both arithmetics run at a shaded point.
//!
//! A light reaches a point `P` unless a primitive meets the segment from
//! `P` to the light (point light) or the ray from `P` towards it
//! (directional light) farther than [`EPSILON`] from `P`. A primitive seen
//! from outside never shadows its own points: every shape is convex (a
//! plane, a disc, a rectangle, a sphere), so the segment from a point that
//! faces the light leaves it at once — the test skips it rather than rely
//! on `ε` against its own rounding. Only a sphere the camera may be inside
//! is tested against itself. `ε` then matters only where two primitives touch (a
//! box's faces along their edges, a sphere resting on a floor): an
//! occluder within `ε` of the point does not shadow it, which moves a
//! shadow's edge by at most `ε` along the occluder (0.24 mm).

use crate::num::scalar::Scalar;
use crate::render::prepare::{cam_prim, lens_blur, shading_light, CamPrim, CamShape};
use crate::render::shading::{axpy, dot, dot_k, sub3, ShadingLight, V3};
use crate::render::Options;
use crate::scene::{Scene, MAX_LIGHTS, MAX_PRIMITIVES, Q};

/// `ε`, metres: a primitive met within this distance of the shaded point
/// does not shadow it (2⁻¹² m).
pub const EPSILON: f64 = 1.0 / 4096.0;

/// `ε²` in I32F32 bits (2⁻²⁴ m²).
const EPSILON2_BITS: i64 = 1 << 8;

/// What the planner keeps to spare in the proofs, metres and relative
/// (2⁻¹⁰): far more than any arithmetic's rounding moves a point.
const SPARE: f64 = 1.0 / 1024.0;

/// The occluders each surface is tested against under each light: bit `o`
/// of `[light][surface]` set if primitive `o` may lie between a point of
/// `surface` and `light`. A bit clear is a proof (in f64, with
/// 2⁻¹⁰ to spare) that it does not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Occluders {
    mask: [[u16; MAX_PRIMITIVES]; MAX_LIGHTS],
}

impl Occluders {
    /// No test anywhere (shadows off, or nothing can cast one).
    pub(crate) const NONE: Occluders = Occluders {
        mask: [[0; MAX_PRIMITIVES]; MAX_LIGHTS],
    };

    /// The occluders of `surface` under `light`.
    #[inline(always)]
    pub(crate) fn of(&self, light: usize, surface: usize) -> u16 {
        self.mask
            .get(light)
            .and_then(|m| m.get(surface))
            .copied()
            .unwrap_or(0)
    }

    /// The occluders of `surface` under each light.
    #[inline(always)]
    pub(crate) fn for_surface(&self, surface: usize) -> [u16; MAX_LIGHTS] {
        core::array::from_fn(|light| self.of(light, surface))
    }

    /// Whether any point needs a test.
    pub(crate) fn any(&self) -> bool {
        self.mask.iter().flatten().any(|m| *m != 0)
    }

    /// Tests a point of `surface` takes: the occluders over every light.
    pub(crate) fn tests_of(&self, surface: usize) -> u32 {
        (0..MAX_LIGHTS).map(|l| self.of(l, surface).count_ones()).sum()
    }

    /// The proof for a frame's primitives and lights (camera frame). A
    /// surface no ray sees (culled: bounds that hold no slope) needs none;
    /// with perspective rays from within `aperture` (metres) of the centre
    /// of projection, neither does a flat surface whose seen face a light
    /// is behind.
    #[inline(never)]
    pub(crate) fn prove(prims: &[CamPrim<Q>], lights: &[ShadingLight], aperture: Option<f64>) -> Occluders {
        let mut o = Occluders::NONE;
        for (li, light) in lights.iter().enumerate() {
            let light = Towards::of(light);
            for (si, s) in prims.iter().enumerate() {
                if s.bounds.is_some_and(|b| b[0] > b[1]) || !light.lights_seen_side(&s.shape, aperture) {
                    continue;
                }
                // A sphere the rays may see from inside shadows its own
                // points (the way to a light outside it leaves through it).
                let mut m = u16::from(inside(&s.shape, aperture)) << si;
                for (oi, occ) in prims.iter().enumerate() {
                    if oi != si && !light.clear(&s.shape, &occ.shape) {
                        m |= 1 << oi;
                    }
                }
                if let Some(slot) = o.mask.get_mut(li).and_then(|r| r.get_mut(si)) {
                    *slot = m;
                }
            }
        }
        o
    }
}

/// The shadow tests of a frame of `scene` rendered with `opts`, its rays of
/// origin scale `origin_scale` (`None`: perspective): through the aperture
/// and culled as its primitives are.
pub(crate) fn of_frame(scene: &Scene, opts: &Options, origin_scale: Option<Q>) -> Occluders {
    let blur = (opts.aperture > 0).then(|| lens_blur(scene));
    occluders(scene, origin_scale, blur, !opts.keep_all_stages)
}

/// The shadow tests of `scene` with rays of origin scale `origin_scale`
/// (`None`: perspective), through the aperture with `blur` (`(d/2, 1/Z̃)`),
/// culled (`cull`) as the renderer's primitives are: none with shadows off.
#[inline(never)]
pub(crate) fn occluders(
    scene: &Scene,
    origin_scale: Option<Q>,
    blur: Option<(f64, f64)>,
    cull: bool,
) -> Occluders {
    if cfg!(not(feature = "shadows")) || !scene.shadows() || scene.lights().is_empty() {
        return Occluders::NONE;
    }
    let mut prims: heapless::Vec<CamPrim<Q>, MAX_PRIMITIVES> = heapless::Vec::new();
    for p in scene.primitives() {
        let _ = prims.push(cam_prim(scene, p, origin_scale, cull, blur));
    }
    let mut lights: heapless::Vec<ShadingLight, MAX_LIGHTS> = heapless::Vec::new();
    for l in scene.lights() {
        let _ = lights.push(shading_light(scene, l));
    }
    let aperture = origin_scale.is_none().then(|| blur.map_or(0.0, |b| b.0));
    Occluders::prove(&prims, &lights, aperture)
}

type F3 = [f64; 3];

fn f3(v: V3) -> F3 {
    v.map(|c| c.to_num::<f64>())
}
fn fdot(a: F3, b: F3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn fsub(a: F3, b: F3) -> F3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn norm(a: F3) -> f64 {
    libm::sqrt(fdot(a, a))
}

/// A light as the proof takes it: a point, or a direction towards it.
enum Towards {
    Point(F3),
    Direction(F3),
}

/// A shape's extent for the proof: its plane (flat shapes), its bounding
/// sphere (bounded ones).
struct Extent {
    plane: Option<(F3, f64)>,
    ball: Option<(F3, f64)>,
}

fn extent(s: &CamShape<Q>) -> Extent {
    let q = |v: Q| v.to_num::<f64>();
    match *s {
        CamShape::Plane { n, dist } => Extent {
            plane: Some((f3(n), q(dist))),
            ball: None,
        },
        CamShape::Sphere { c, r2, .. } => Extent {
            plane: None,
            ball: Some((f3(c), libm::sqrt(q(r2)))),
        },
        CamShape::Disc { n, dist, c, r2 } => Extent {
            plane: Some((f3(n), q(dist))),
            ball: Some((f3(c), libm::sqrt(q(r2)))),
        },
        CamShape::Rect {
            n, dist, c, hu, hv, ..
        } => Extent {
            plane: Some((f3(n), q(dist))),
            ball: Some((f3(c), libm::sqrt(q(hu) * q(hu) + q(hv) * q(hv)))),
        },
    }
}

/// The sign of `v`, 0 within `m` of 0.
fn sign(v: f64, m: f64) -> f64 {
    if v > m {
        1.0
    } else if v < -m {
        -1.0
    } else {
        0.0
    }
}

impl Towards {
    fn of(l: &ShadingLight) -> Towards {
        match *l {
            ShadingLight::Point { p, .. } => Towards::Point(f3(p)),
            ShadingLight::Directional { l, .. } => Towards::Direction(f3(l)),
        }
    }

    /// Which side of the plane `(n, dist)` light arrives from: the sign of
    /// `n·L − dist` (point) or `n·l` (direction); 0 if it grazes.
    fn side(&self, (n, dist): (F3, f64)) -> f64 {
        match *self {
            Towards::Point(p) => sign(fdot(n, p) - dist, SPARE * (1.0 + dist.abs() + norm(p))),
            Towards::Direction(l) => sign(fdot(n, l), SPARE),
        }
    }

    /// Whether the light can reach the side of a flat surface that
    /// perspective rays from within `aperture` of the origin see (a light
    /// on the other side lights only the face no ray meets). Shapes that
    /// are not flat, and parallel rays (`None`): always.
    fn lights_seen_side(&self, s: &CamShape<Q>, aperture: Option<f64>) -> bool {
        match (extent(s).plane, aperture) {
            (Some((n, dist)), Some(a)) => {
                let camera = sign(-dist, a + SPARE);
                camera == 0.0 || self.side((n, dist)) * camera >= 0.0
            }
            _ => true,
        }
    }

    /// Whether no point of `surface` is shadowed by `occ` under this light
    /// (a proof; `false` when none is found).
    fn clear(&self, surface: &CamShape<Q>, occ: &CamShape<Q>) -> bool {
        let (s, o) = (extent(surface), extent(occ));
        // The occluder's plane: the surface lies wholly on the light's side
        // of it (the segment or ray towards the light never crosses it).
        if let Some(op) = o.plane {
            let side = self.side(op);
            if side != 0.0 {
                let (n, dist) = op;
                let beyond = |c: F3, r: f64| (fdot(n, c) - dist) * side > r + SPARE * (1.0 + norm(c) + r);
                if let Some((c, r)) = s.ball {
                    if beyond(c, r) {
                        return true;
                    }
                } else if let Some((sn, sd)) = s.plane {
                    // A plane parallel to the occluder's: its points all at
                    // the same height over it.
                    let cos = fdot(sn, n);
                    if libm::fabs(cos) > 1.0 - 1e-12 && beyond([sn[0] * sd, sn[1] * sd, sn[2] * sd], 0.0) {
                        return true;
                    }
                }
            }
        }
        let Some((oc, or)) = o.ball else {
            return false;
        };
        match (s.ball, s.plane) {
            // A bounded surface: the segments (rays) from its ball towards
            // the light lie within its radius of the one from its centre.
            (Some((sc, sr)), _) => {
                let d = match *self {
                    Towards::Point(p) => segment_distance(oc, sc, fsub(p, sc), 1.0),
                    Towards::Direction(l) => segment_distance(oc, sc, l, f64::INFINITY),
                };
                d > or + sr + SPARE * (1.0 + norm(oc) + or + sr)
            }
            // A plane: the segments (rays) from it towards the light stay on
            // the light's side; an occluder wholly on the other is clear.
            (None, Some((sn, sd))) => {
                let side = self.side((sn, sd));
                side != 0.0 && (fdot(sn, oc) - sd) * side < -(or + SPARE * (1.0 + norm(oc) + or))
            }
            (None, None) => false,
        }
    }
}

/// Whether rays may start inside the sphere `s` (perspective rays from
/// within `aperture` of the origin; parallel ones from the plane `z = 0`),
/// and so see its inside: with 2⁻¹⁰ to spare. Other shapes: never.
fn inside(s: &CamShape<Q>, aperture: Option<f64>) -> bool {
    let CamShape::Sphere { c, r2, .. } = *s else {
        return false;
    };
    let (c, r) = (f3(c), libm::sqrt(r2.to_num::<f64>()));
    let m = SPARE * (1.0 + norm(c) + r);
    match aperture {
        Some(a) => norm(c) < r + a + m,
        None => libm::fabs(c[2]) < r + m,
    }
}

/// Distance from `x` to the points `o + t d`, `0 ≤ t ≤ t_max`.
fn segment_distance(x: F3, o: F3, d: F3, t_max: f64) -> f64 {
    let dd = fdot(d, d);
    let t = if dd > 0.0 {
        // (max and min, not clamp: no panic path for a NaN.)
        (fdot(fsub(x, o), d) / dd).max(0.0).min(t_max)
    } else {
        0.0
    };
    norm(fsub(x, [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]))
}

/// Whether `s` meets the points `o + t d` with `t > 0`, `t² (d·d) > ε²`
/// ([`EPSILON`]) and, if `segment`, `t < 1`; `a = d·d`.
#[inline(always)]
pub(crate) fn occludes<S: Scalar>(s: &CamShape<S>, o: V3<S>, d: V3<S>, a: S, segment: bool) -> bool {
    let eps2 = S::from_q(Q::from_bits(EPSILON2_BITS));
    let within = |t: S| t > S::ZERO && (!segment || t < S::ONE) && t.mul(t).mul(a) > eps2;
    // A flat shape's plane `n̂·P = dist`: where the line meets it.
    let flat_t = |n: V3<S>, dist: S| {
        let denom = dot_k(n, d);
        dist.sub(dot_k(n, o)).div(denom).filter(|t| within(*t))
    };
    match *s {
        CamShape::Plane { n, dist } => flat_t(n, dist).is_some(),
        CamShape::Disc { n, dist, c, r2 } => flat_t(n, dist).is_some_and(|t| {
            let rel = sub3(axpy(t, d, o), c);
            dot(rel, rel) <= r2
        }),
        CamShape::Rect {
            n,
            dist,
            c,
            u,
            v,
            hu,
            hv,
        } => flat_t(n, dist).is_some_and(|t| {
            let rel = sub3(axpy(t, d, o), c);
            dot_k(u, rel).abs() <= hu && dot_k(v, rel).abs() <= hv
        }),
        CamShape::Sphere { c, r2, .. } => {
            // a t² − 2 b t + (|oc|² − r²) = 0, b = d·oc; the discriminant
            // as a r² − |d × oc|² (Lagrange's identity, as the camera rays').
            let oc = sub3(c, o);
            let x = [
                d[1].mul(oc[2]).sub(d[2].mul(oc[1])),
                d[2].mul(oc[0]).sub(d[0].mul(oc[2])),
                d[0].mul(oc[1]).sub(d[1].mul(oc[0])),
            ];
            let (b, disc) = (dot(d, oc), a.mul(r2).sub(dot(x, x)));
            if disc < S::ZERO {
                return false;
            }
            let Some(sq) = disc.sqrt() else {
                return false;
            };
            [b.sub(sq), b.add(sq)]
                .into_iter()
                .any(|num| num.div(a).is_some_and(within))
        }
    }
}

/// The lights whose light a point at `point` (unit `normal`, facing the
/// viewer) does not receive: bit `i` set if a primitive of `occluders[i]`
/// (its surface's, [`Occluders::for_surface`]) lies between it and light
/// `i`. Lights it faces away from are left clear (they send it nothing
/// anyway).
#[inline(never)]
pub(crate) fn shadowed<S: Scalar>(
    prims: &[CamPrim<S>],
    lights: &[ShadingLight<S>],
    occluders: &[u16; MAX_LIGHTS],
    point: V3<S>,
    normal: V3<S>,
) -> u8 {
    let mut mask = 0u8;
    for ((li, light), &occ) in lights.iter().enumerate().zip(occluders) {
        if occ == 0 {
            continue;
        }
        let (d, segment) = match *light {
            ShadingLight::Point { p, .. } => (sub3(p, point), true),
            ShadingLight::Directional { l, .. } => (l, false),
        };
        if dot(normal, d) <= S::ZERO {
            continue;
        }
        let a = dot(d, d);
        let hit = prims
            .iter()
            .enumerate()
            .any(|(oi, p)| occ & (1 << oi) != 0 && occludes(&p.shape, point, d, a, segment));
        if hit {
            mask |= 1 << li;
        }
    }
    mask
}
