//! Cast shadows in the fast arithmetic (camera-model.md §6): a shaded
//! point's tests ([`crate::render::shadows`]) run on its hit point and
//! normal, converted from the fast formats to I32F32 (exactly, within
//! I32F32's range), against the frame's primitives and lights in I32F32 —
//! the wide arithmetic's test, the same integer operations on every
//! board. A surface that takes a test is shaded point by point: it is
//! neither the plane in closed form nor a flat primitive whose sum is
//! kept ([`Mix32::fill`]). Without the `shadows` feature, none is taken.

use super::rays::Ray;
use super::Mix32;
#[cfg(feature = "shadows")]
use {
    super::arith::{sar64_low_lt32, smul_u, zip3},
    super::intersect::MixShape,
    super::rays::{AWAY, NO_HIT},
    super::Input,
    crate::num::FixedF64,
    crate::render::prepare::{cam_prim, shading_light, CamPrim, CamShape},
    crate::render::shading::{ShadingLight, V3},
    crate::render::shadows::Occluders,
    crate::scene::{MAX_LIGHTS, MAX_PRIMITIVES, Q},
};

/// A frame's shadow tests in the fast arithmetic.
#[cfg(feature = "shadows")]
#[derive(Clone, Debug)]
pub(super) struct Shadow {
    prims: heapless::Vec<CamPrim<Q>, MAX_PRIMITIVES>,
    lights: heapless::Vec<ShadingLight, MAX_LIGHTS>,
    pub(super) occluders: Occluders,
    /// The length unit's exponent (`U = 2^e` m) and the depth the fast
    /// frame's origin moved to (parallel rays; 0 otherwise).
    e: i32,
    z0: Q,
    /// Each primitive's bounding ball for the pre-test ([`Ball`]; `None`:
    /// a plane, or out of the fast formats' range).
    balls: [Option<Ball>; MAX_PRIMITIVES],
    /// Each light for the pre-test ([`Towards`]).
    towards: [Option<Towards>; MAX_LIGHTS],
}

/// An occluder's bounding ball in S17 U (the hit points' format, S18 U,
/// halved: their differences stay within `i32`): its centre (rounded to
/// the nearest) and its radius with the pre-test's margin folded in
/// (rounded up), `r + r/1024 + m₀ + 5` units.
#[cfg(feature = "shadows")]
#[derive(Clone, Copy, Debug)]
struct Ball {
    c: [i32; 3],
    r: u32,
}

/// A light in the fast formats: a point light's position (S17 U) with the
/// least `|P − L|_∞` the pre-test takes, or a directional light's
/// direction (S30).
#[cfg(feature = "shadows")]
#[derive(Clone, Copy, Debug)]
enum Towards {
    Point { p: [i32; 3], near: u32 },
    Direction([i32; 3]),
}

/// Most significant bits the pre-test keeps of a vector: its cross
/// products then stay within `i32`, their squares' sums within `u64`.
#[cfg(feature = "shadows")]
const PRE_BITS: u32 = 14;

/// `a − b` per component (S17 U, both within ±2³⁰: no overflow).
#[cfg(feature = "shadows")]
#[inline(always)]
fn diff(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The shift that leaves `most` (and so every component at most it) at
/// most `2^PRE_BITS` in magnitude.
#[cfg(feature = "shadows")]
#[inline(always)]
fn shift_for(most: u32) -> u32 {
    (32 - most.leading_zeros()).saturating_sub(PRE_BITS)
}

/// The largest `|v_i|`.
#[cfg(feature = "shadows")]
#[inline(always)]
fn most(v: [i32; 3]) -> u32 {
    v[0].unsigned_abs()
        .max(v[1].unsigned_abs())
        .max(v[2].unsigned_abs())
}

/// `|v|²` of a normalized vector (components within `±2^PRE_BITS`) or of
/// two such vectors' cross product (within `±2^(2 PRE_BITS + 1)`).
#[cfg(feature = "shadows")]
#[inline(always)]
fn sq(v: [i32; 3]) -> u64 {
    v.iter().map(|&c| (i64::from(c) * i64::from(c)) as u64).sum()
}

#[cfg(feature = "shadows")]
impl Ball {
    /// Whether the line through `pt` (S17 U) along `d` (normalized) passes
    /// farther than the radius from the centre: then the occluder cannot
    /// lie on the segment or ray, whatever the exact test's rounding.
    #[inline(always)]
    fn missed_by(&self, pt: [i32; 3], d: [i32; 3]) -> bool {
        let oc = diff(self.c, pt);
        // The margin's share of |oc| (≥ |oc|/1024 as |oc| ≤ √3 |oc|_∞).
        let r = self.r.saturating_add(most(oc) >> 9);
        let sh = shift_for(most(oc).max(r));
        let oc = oc.map(|c| c >> sh);
        // (+2: the shift's truncation of `oc`, under √3 of its units.)
        let r = u64::from((r >> sh) + 2);
        let x = [
            d[1] * oc[2] - d[2] * oc[1],
            d[2] * oc[0] - d[0] * oc[2],
            d[0] * oc[1] - d[1] * oc[0],
        ];
        sq(x) > sq(d) * (r * r)
    }
}

#[cfg(feature = "shadows")]
impl Towards {
    /// The direction from `pt` (S17 U) towards the light, normalized; `None`
    /// where the pre-test does not hold (a point light nearer than 1/16 m).
    #[inline(always)]
    fn from(&self, pt: [i32; 3]) -> Option<[i32; 3]> {
        let d = match *self {
            Towards::Point { p, near } => {
                let d = diff(p, pt);
                if most(d) < near {
                    return None;
                }
                d
            }
            Towards::Direction(l) => l,
        };
        let sh = shift_for(most(d));
        Some(d.map(|c| c >> sh))
    }
}

#[cfg(feature = "shadows")]
impl Shadow {
    /// The tests of the frame `f` of unit `2^e` moved to `z0`, if any
    /// surface takes one.
    #[inline(never)]
    pub(super) fn of(f: &Input, e: i32, z0: Q) -> Option<Shadow> {
        if !f.occluders.any() {
            return None;
        }
        let mut s = Shadow {
            prims: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            occluders: f.occluders,
            e,
            z0,
            balls: [None; MAX_PRIMITIVES],
            towards: [None; MAX_LIGHTS],
        };
        for p in f.scene.primitives() {
            let _ = s.prims.push(cam_prim(f.scene, p, f.origin_scale, false, None));
        }
        for l in f.scene.lights() {
            let _ = s.lights.push(shading_light(f.scene, l));
        }
        for (b, p) in s.balls.iter_mut().zip(&s.prims) {
            *b = Self::ball(&p.shape, e, z0);
        }
        for (t, l) in s.towards.iter_mut().zip(&s.lights) {
            *t = Self::towards(l, e, z0);
        }
        Some(s)
    }

    /// Metres (camera frame, depth `z0` off on z) in S17 U, rounded to the
    /// nearest: `None` past ±2³⁰ units.
    fn s17(v: f64, e: i32) -> Option<i32> {
        let u = libm::rint(libm::ldexp(v, 17 - e));
        (u.abs() < (1u32 << 30) as f64).then_some(u as i32)
    }

    /// A point (metres, camera frame) in S17 U about `z0`.
    fn point17(c: V3, e: i32, z0: Q) -> Option<[i32; 3]> {
        let z = c[2].saturating_sub(z0);
        Some([
            Self::s17(c[0].f64(), e)?,
            Self::s17(c[1].f64(), e)?,
            Self::s17(z.f64(), e)?,
        ])
    }

    /// A primitive's [`Ball`] (a plane has none).
    ///
    /// The margin `m` a line's distance from the centre keeps beyond the
    /// radius covers the exact test's rounding: for a sphere it takes a
    /// miss for a hit only if `a (2 r m + m²)` is within the rounding of
    /// its discriminant `a r² − |d × oc|²`, at most
    /// `√(3a) |oc| 2⁻³⁰ + (4 + 3r²) 2⁻³²` m⁴ (I32F32 products truncate at
    /// 2⁻³²); with `m = |oc|/1024 + r/1024 + m₀`, `m₀ = 2⁻¹⁰` m and
    /// `a ≥ 2⁻⁸` m² (a point light at least 1/16 m from the point; a
    /// directional light's `a` is 1) it never is (`a m₀²`, `2 a m₀ |oc|/1024`
    /// and `2 a r²/1024` each exceed their term). A flat occluder's hit is
    /// a point of the line within its bounding ball to the same rounding.
    /// The rounding of the centre, the light, the point (halved to S17)
    /// and the normalization ([`PRE_BITS`]) are a few units and
    /// ≤ 2⁻¹¹·⁹ |oc|, within the `5` and the `|oc|/1024`.
    fn ball(s: &CamShape<Q>, e: i32, z0: Q) -> Option<Ball> {
        let q = |v: Q| v.f64();
        let (c, r) = match *s {
            CamShape::Plane { .. } => return None,
            CamShape::Sphere { c, r2, .. } | CamShape::Disc { c, r2, .. } => (c, libm::sqrt(q(r2))),
            CamShape::Rect { c, hu, hv, .. } => (c, libm::sqrt(q(hu) * q(hu) + q(hv) * q(hv))),
        };
        let m0 = 1.0 / 1024.0;
        let r = Self::s17(r + r / 1024.0 + m0, e)?.unsigned_abs() + 4 + 1;
        Some(Ball {
            c: Self::point17(c, e, z0)?,
            r,
        })
    }

    /// A light's [`Towards`].
    fn towards(l: &ShadingLight, e: i32, z0: Q) -> Option<Towards> {
        Some(match *l {
            ShadingLight::Point { p, .. } => Towards::Point {
                p: Self::point17(p, e, z0)?,
                // 1/16 m (and at least 2¹⁴ units, the normalization's).
                near: Self::s17(1.0 / 16.0, e)?.unsigned_abs().max(1 << PRE_BITS),
            },
            // (S30 of a unit vector: within ±2³⁰.)
            ShadingLight::Directional { l, .. } => Towards::Direction(l.map(|c| (c.to_bits() >> 2) as i32)),
        })
    }

    /// The lights a point of primitive `prim` does not receive (bit `i`:
    /// light `i`): its point `pt` (S18 U) and unit normal towards the
    /// viewer `nt` (S30).
    ///
    /// A pre-test in the fast formats first clears the occluders whose
    /// bounding ball the line to each light misses by a margin the exact
    /// test's rounding cannot cross ([`Shadow::ball`]); the exact test (in
    /// I32F32, as the wide arithmetic's) runs on those left, so the mask
    /// is the exact test's alone.
    #[inline(never)]
    pub(super) fn shadowed(&self, prim: usize, pt: [i32; 3], nt: [i32; 3]) -> u8 {
        let mut occ = self.occluders.for_surface(prim);
        let pt17 = pt.map(|c| c >> 1);
        let mut left = 0;
        for (o, t) in occ.iter_mut().zip(&self.towards).take(self.lights.len()) {
            if *o == 0 {
                continue;
            }
            if let Some(d) = t.as_ref().and_then(|t| t.from(pt17)) {
                let mut bits = *o;
                while bits != 0 {
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    if let Some(Some(b)) = self.balls.get(i) {
                        if b.missed_by(pt17, d) {
                            *o &= !(1 << i);
                        }
                    }
                }
            }
            left |= *o;
        }
        if left == 0 {
            return 0;
        }
        let point = Self::point_q(pt, self.e, self.z0);
        let normal: V3 = nt.map(|n| Q::from_bits(i64::from(n) << 2));
        crate::render::shadows::shadowed::<Q>(&self.prims, &self.lights, &occ, point, normal)
    }

    /// A hit point (S18 U, about `z0`) in I32F32 metres, the exact test's:
    /// S18 U = 2^(e − 18) m, the bits shifted by 14 + e, saturated.
    #[inline(always)]
    fn point_q(pt: [i32; 3], e: i32, z0: Q) -> V3 {
        let sh = 14 + e;
        let len = |v: i32| {
            let v = i128::from(v);
            let b = if sh >= 0 { v << sh } else { v >> -sh };
            Q::from_bits(b.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64)
        };
        let mut point: V3 = pt.map(len);
        point[2] = point[2].saturating_add(z0);
        point
    }
}

impl Mix32 {
    /// Whether any surface of the frame takes a shadow test.
    #[inline(always)]
    pub(super) fn any_shadow_test(&self) -> bool {
        #[cfg(feature = "shadows")]
        return self.shadow.is_some();
        #[cfg(not(feature = "shadows"))]
        false
    }

    /// The tests primitive `i` takes (0: none, or no shadows).
    #[inline(always)]
    pub(super) fn shadow_tests(&self, i: usize) -> u32 {
        #[cfg(feature = "shadows")]
        return self.shadow.as_ref().map_or(0, |s| s.occluders.tests_of(i));
        #[cfg(not(feature = "shadows"))]
        {
            let _ = i;
            0
        }
    }
}

impl Mix32 {
    /// The lights shadowed where ray `r` (in the field, its nearest hit
    /// known) meets its surface: the adaptive rule's share of a [`Key`]
    /// (0 without shadows or hit).
    ///
    /// [`Key`]: super::rays::Key
    #[cfg(feature = "shadows")]
    #[inline(never)]
    pub(super) fn shade_key<const PERSP: bool>(&self, r: &Ray) -> u8 {
        let Some(s) = &self.shadow else {
            return 0;
        };
        if r.t == NO_HIT || r.t == 0 {
            return 0;
        }
        let prim = (r.hit & !AWAY) as usize;
        let Some(p) = self.prims.get(prim) else {
            return 0;
        };
        let pt = r.hit_point::<PERSP, false>([0; 2]);
        let n = match p.shape {
            MixShape::Plane { n, .. } | MixShape::Disc { n, .. } | MixShape::Rect { n, .. } => n,
            MixShape::Sphere { c18, inv_r, .. } => zip3(pt, c18, |p, c| {
                sar64_low_lt32(smul_u(p.wrapping_sub(c), inv_r.0), inv_r.1)
            }),
        };
        let nt = if r.hit & AWAY != 0 {
            n.map(i32::saturating_neg)
        } else {
            n
        };
        s.shadowed(prim, pt, nt)
    }
}

impl Mix32 {
    /// Without the `shadows` feature no light is shadowed.
    #[cfg(not(feature = "shadows"))]
    #[inline(always)]
    pub(super) fn shade_key<const PERSP: bool>(&self, _: &Ray) -> u8 {
        0
    }
}

#[cfg(all(test, feature = "shadows"))]
mod tests {
    use super::{Ball, Shadow, Towards};
    use crate::render::prepare::CamShape;
    use crate::render::shading::{dot, sub3, ShadingLight, V3};
    use crate::render::shadows::occludes;
    use crate::scene::Q;

    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn q3(v: [f64; 3]) -> V3 {
        v.map(Q::from_num)
    }

    /// The pre-test never clears an occluder the exact test finds: lines
    /// aimed within ±1 % of the radius of spheres and rectangles' bounding
    /// balls (grazing, where the rounding matters), from points near and
    /// far, to point and directional lights, at three length units. It
    /// also clears the lines that pass clear by more than its margin (else
    /// it saves nothing).
    #[test]
    fn the_pre_test_clears_only_what_the_exact_test_misses() {
        let mut seed = 0x5eed_5ad0_u64;
        let (mut cleared, mut cleared_clear, mut hits, mut clear_lines) = (0, 0, 0, 0);
        for case in 0..30_000 {
            let e = [-9, -4, 0][case % 3];
            let mut u = || rng(&mut seed) * 2.0 - 1.0;
            let c = [u() * 2.0, u() * 2.0, 3.0 + u() * 2.0];
            let r = 0.01 + (u() + 1.0) * 0.5;
            let sphere = case % 2 == 0;
            let (shape, radius) = if sphere {
                let sh = CamShape::Sphere {
                    c: q3(c),
                    r2: Q::from_num(r * r),
                    inv_r: Q::from_num(1.0 / r),
                };
                (sh, r)
            } else {
                // An axis-aligned rectangle (its ball: the half diagonal).
                let (hu, hv) = (r, r * 0.5);
                let sh = CamShape::Rect {
                    n: q3([0.0, 1.0, 0.0]),
                    dist: Q::from_num(c[1]),
                    c: q3(c),
                    u: q3([1.0, 0.0, 0.0]),
                    v: q3([0.0, 0.0, 1.0]),
                    hu: Q::from_num(hu),
                    hv: Q::from_num(hv),
                };
                (sh, (hu * hu + hv * hv).sqrt())
            };
            let light = if case % 5 == 0 {
                let l = [u(), 1.0 + u().abs(), u()];
                let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
                ShadingLight::Directional {
                    l: q3(l.map(|x| x / n)),
                    e: q3([1.0; 3]),
                }
            } else {
                ShadingLight::Point {
                    p: q3([u() * 5.0, 3.0 + u() * 2.0, u() * 5.0]),
                    i: q3([1.0; 3]),
                }
            };
            // A point whose line to the light passes at `k` radii from the
            // centre (k within 1 % of 1 on most, up to 3 on the rest).
            let k = if case % 4 == 0 {
                1.0 + u() * 2.0
            } else {
                1.0 + u() * 0.01
            };
            // (The line passes `k r` from the centre only for a directional
            // light; a point light's is nearer, measured below.)
            // (Perpendicular to the line: through `c + k r ŵ`, it passes
            // `k r` from the centre.)
            let along = match light {
                ShadingLight::Point { p, .. } => {
                    let p = p.map(|v| v.to_num::<f64>());
                    [0, 1, 2].map(|i| c[i] - p[i])
                }
                ShadingLight::Directional { l, .. } => l.map(|v| -v.to_num::<f64>()),
            };
            let unit = |w: [f64; 3]| {
                let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt().max(1e-12);
                w.map(|x| x / n)
            };
            let a = unit(along);
            let w = {
                let w = [u(), u(), u()];
                let wa = w[0] * a[0] + w[1] * a[1] + w[2] * a[2];
                unit([0, 1, 2].map(|i| w[i] - wa * a[i]))
            };
            let t = [0, 1, 2].map(|i| c[i] + k * radius * w[i]);
            let towards = match light {
                ShadingLight::Point { p, .. } => {
                    let p = p.map(|v| v.to_num::<f64>());
                    [0, 1, 2].map(|i| t[i] - p[i])
                }
                ShadingLight::Directional { l, .. } => l.map(|v| -v.to_num::<f64>()),
            };
            let s = 0.05 + (u() + 1.0) * 1.5;
            let pf = [0, 1, 2].map(|i| t[i] + s * towards[i]);
            // (Hit points are within the fast formats' range.)
            let scaled = pf.map(|v| (v * (2f64).powi(18 - e)).round());
            if scaled.iter().any(|v| v.abs() >= 2f64.powi(31)) {
                continue;
            }
            let pt = scaled.map(|v| v as i32);
            let point = Shadow::point_q(pt, e, Q::ZERO);
            let (d, segment) = match light {
                ShadingLight::Point { p, .. } => (sub3(p, point), true),
                ShadingLight::Directional { l, .. } => (l, false),
            };
            let exact = occludes(&shape, point, d, dot(d, d), segment);
            let ball: Option<Ball> = Shadow::ball(&shape, e, Q::ZERO);
            let toward: Option<Towards> = Shadow::towards(&light, e, Q::ZERO);
            let pt17 = pt.map(|c| c >> 1);
            let missed = match (ball, toward.and_then(|t| t.from(pt17))) {
                (Some(b), Some(d)) => b.missed_by(pt17, d),
                _ => false,
            };
            assert!(
                !(missed && exact),
                "case {case}: e {e}, k {k}, {shape:?}, {light:?}, pt {pt:?}: cleared a hit"
            );
            // Clear by more than the margin: 2 mm, |oc|/256 and r/512 (the
            // line's distance from the centre, in f64).
            let ocv = [0, 1, 2].map(|i| c[i] - pf[i]);
            let oc = (ocv[0] * ocv[0] + ocv[1] * ocv[1] + ocv[2] * ocv[2]).sqrt();
            let dir = unit(towards);
            let along = ocv[0] * dir[0] + ocv[1] * dir[1] + ocv[2] * dir[2];
            let dist = (oc * oc - along * along).max(0.0).sqrt();
            let clear = dist - radius > 2e-3 + oc / 256.0 + radius / 512.0;
            cleared += usize::from(missed);
            hits += usize::from(exact);
            clear_lines += usize::from(clear);
            cleared_clear += usize::from(clear && missed);
        }
        assert!(hits > 1_000, "{hits} hits");
        assert!(
            cleared_clear == clear_lines && clear_lines > 2_000,
            "{cleared_clear} cleared of {clear_lines} clear lines ({cleared} in all)"
        );
    }
}
