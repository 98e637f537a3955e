//! The fast arithmetic's primitives ([`MixShape`], [`MixPrim`]) and
//! their passes over a chunk of rays: the nearest hit of each ray
//! (`MixShape::nearest`), a sphere's normal at its hit (`fine_normal`),
//! and the region where a rectangle's test cannot fail ([`Inner`]).

use super::arith::{
    map3, mul_shr_right, recip, sar64_low_lt32, smul_u, sqrt_fine, sqrt_s44_to_s22, wmul, wmul_axis, wsq,
    zip3, T_MAX,
};
use super::rays::Ray;
use super::{Mix32, ALONG_S42};
use crate::num::scalar::shr_sat;
use crate::target::{M0, M0_COMPACT};
use core::num::NonZeroU32;

/// The outward unit normal (S30) of a sphere (centre `c`, radius `r24`,
/// S24 U; `inv_r` maps S18 U to S30) where the ray `r` meets it, entering
/// or (`inside`) leaving: from the ray and the sphere, not the rounded hit
/// point (S18 U, whose rounding over a small radius the lobe's exponent
/// would multiply). With `d̂` the ray's unit direction, `c⊥ = c − (d̂·c) d̂`
/// and `s = √(r² − |c⊥|²)`, the hit is `p − c = −c⊥ ∓ s d̂`. Errors: `d̂`
/// within 2⁻²⁸, `c⊥` a unit of S24 (plus `2 |c|` times the ray's own
/// direction error), `s` within 2⁻²⁸ relative plus `|c⊥| δc⊥ / s` —
/// ill-conditioned only next to the silhouette, where the planner bounds
/// the lobe by geometry instead. Out of line on the Cortex-M; inlined on
/// the x86-64 host, where, out of line, it returned the normal through
/// the memory [`Mix32::hit_from`]'s other normals were stored to, whose
/// three 4-byte stores an 8-byte load of them then stalled on.
#[cfg_attr(hilcam_loops_out_of_line, inline(never))]
#[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
#[cold]
pub(super) fn fine_normal<const PERSP: bool, const MOVED: bool>(
    r: &Ray,
    c: [i32; 3],
    r24: i32,
    inv_r: (u32, u32),
    inside: bool,
) -> ([i32; 3], [i32; 3]) {
    // d̂ (S30) and the centre from the ray's origin (S24 U; parallel
    // origins are within 64 U, S18).
    let view = Mix32::view::<PERSP>(r);
    let (dh, cr) = if PERSP {
        (map3(view, i32::saturating_neg), c)
    } else {
        (
            [0, 0, 1 << 30],
            [
                c[0].saturating_sub(r.ox.saturating_mul(64)),
                c[1].saturating_sub(r.oy.saturating_mul(64)),
                c[2],
            ],
        )
    };
    // d̂·c, S54 → S24 (|c| ≤ 72 U).
    let k = ((wmul(dh[0], cr[0]) + wmul(dh[1], cr[1]) + wmul(dh[2], cr[2])) >> 30) as i32;
    // (Perspective rays from the centre of the lens: the centre lies
    // within the content's 8 U, below 2²⁷ in S24, so `c⊥` and `p − c`
    // below 2²⁸ and no sum saturates — wrapping is the same value, without
    // the saturation's tests. Parallel rays' centres lie within 72 U of
    // their origin, and the aperture loop's are moved by its points.)
    let wrap = PERSP && !MOVED;
    let sub = |a: i32, b: i32| {
        if wrap {
            a.wrapping_sub(b)
        } else {
            a.saturating_sub(b)
        }
    };
    let cp = zip3(cr, dh, |ci, di| sub(ci, (wmul(k, di) >> 30) as i32));
    // s² = r² − |c⊥|², S48 (|c⊥| ≤ r ≤ 8 U at a hit).
    let s2 = wmul(r24, r24) - (wsq(cp[0]) + wsq(cp[1]) + wsq(cp[2])) as i64;
    let s = sqrt_fine(s2.max(0) as u64);
    let rel = zip3(cp, dh, |a, d| {
        let sd = (wmul(s, d) >> 30) as i32;
        match (inside, wrap) {
            (true, _) => sub(sd, a),
            (false, true) => a.wrapping_add(sd).wrapping_neg(),
            (false, false) => a.saturating_add(sd).saturating_neg(),
        }
    });
    // S24 → S30 by 1/r: six more bits of shift than from S18. |p − c| is
    // r (or |c⊥|, within the hit test's error of r, where s² < 0): each
    // component fits i32 in S30, the low word of the shift
    // (`tests::a_sphere_hits_normal_fits_without_saturation`). The shift
    // is below 32, in words ([`sar64_low_lt32`]): the radius lies within
    // the content's 8 U (S24, below 2²⁷), so [`recip_len`] normalizes
    // 2⁵⁴/s of 28 bits or more and its shift is at most 22.
    let sh = inv_r.1 + 6;
    (map3(rel, |v| sar64_low_lt32(smul_u(v, inv_r.0), sh)), view)
}

#[derive(Clone, Copy, Debug)]
pub(super) enum MixShape {
    /// `n·p = dist`; `rz` is `1/n_z` for parallel rays ([`Ray::plane_t`]).
    Plane { n: [i32; 3], dist: i32, rz: (u32, u32) },
    Sphere {
        /// Centre, S24 (for `b`) and S18 (for the normal and parallel
        /// rays); `c_z` in S50.
        c: [i32; 3],
        cz50: i64,
        c18: [i32; 3],
        /// r², S24 U² (perspective rays) and S36 U² (parallel rays); r,
        /// S24 U.
        r2_24: i32,
        r2: u64,
        r24: i32,
        /// Its normal from the ray and the sphere ([`fine_normal`]): a
        /// material of it has a specular lobe.
        fine: bool,
        inv_r: (u32, u32),
    },
    /// `|p − c|² ≤ r²` with the hit point and the centre in S24 U
    /// ([`Ray::point24`]): no coordinate rounded to S18, so the boundary
    /// moves by the hit's error along the ray times the ray's in-plane
    /// part, plus units of S24 (`planner::fast_boundary_m`).
    Disc {
        n: [i32; 3],
        dist: i32,
        rz: (u32, u32),
        c24: [i32; 3],
        /// r², S48 U² (`r` in S24).
        r2: u64,
    },
    Rect {
        n: [i32; 3],
        dist: i32,
        rz: (u32, u32),
        u: [i32; 3],
        v: [i32; 3],
        /// `c·u`, `c·v` of its centre (rounded down) and its half sizes, in
        /// [`Ray::along`]'s format: S42 U for perspective rays, S48 U for
        /// parallel ones.
        cu: i64,
        cv: i64,
        hu: i64,
        hv: i64,
    },
}

#[derive(Clone, Copy, Debug)]
pub(super) struct MixChecker {
    pub(super) u: [i32; 3],
    pub(super) v: [i32; 3],
    /// `origin·u`, `origin·v` (rounded down) in [`Ray::along`]'s format:
    /// S42 U for perspective rays, S48 U for parallel ones.
    pub(super) ou: i64,
    pub(super) ov: i64,
    /// `1/cell` as a mantissa and the right shift of the product's high
    /// word that floors `w (S18) · mantissa` to a cell index (the whole
    /// shift, 39 to 56 for cells of 2⁻¹⁰ to 64 U, is at least 32).
    pub(super) inv_cell: (u32, u32),
    pub(super) material: u8,
}

impl MixChecker {
    /// The texture cell `(⌊u/c⌋, ⌊v/c⌋)` of a point (S18 U) on it (a
    /// parallel ray's, or the aperture loop's, whose rays start off the
    /// axis).
    #[inline(always)]
    pub(super) fn cells<const PERSP: bool>(&self, pt: [i32; 3], bounded: bool) -> (i32, i32) {
        let shift = if PERSP { ALONG_S42 } else { 0 };
        // (On the Cortex-M0 an axis with a_z = 0 — a plane facing the
        // camera — has that product left out, [`wmul_axis`]: shallow-dof
        // 1 089 instructions a pixel fewer there; on the M3 the test cost
        // 568 more.)
        let along = |a: [i32; 3]| (wmul(pt[0], a[0]) + wmul(pt[1], a[1]) + wmul_axis(pt[2], a[2])) >> shift;
        (
            self.cell::<PERSP>(along(self.u) - self.ou, bounded),
            self.cell::<PERSP>(along(self.v) - self.ov, bounded),
        )
    }

    /// [`MixChecker::cells`] of ray `r`'s hit ([`Ray::along`]: no point).
    /// Out of line in a `compact` build (flash). (Its pair written out as
    /// in `cells`: one body for both, through a closure argument, measured
    /// slower on the M0.)
    #[cfg_attr(feature = "compact", inline(never))]
    #[cfg_attr(not(feature = "compact"), inline(always))]
    pub(super) fn cells_of<const PERSP: bool>(&self, r: &Ray, bounded: bool) -> (i32, i32) {
        let along = |a: [i32; 3]| r.along::<PERSP>(r.t, a);
        (
            self.cell::<PERSP>(along(self.u) - self.ou, bounded),
            self.cell::<PERSP>(along(self.v) - self.ov, bounded),
        )
    }

    /// The cell index of a coordinate `w` along an axis ([`Ray::along`]'s
    /// format: S42 U, S48 U for parallel rays). `bounded`: `w` is a point
    /// of a primitive other than a plane, so within twice the content's
    /// 8 U of the camera, and so is the origin — `|w|` below 2⁹ U of
    /// the S18 i32's 2¹³ U — and needs no saturation.
    #[inline(always)]
    pub(super) fn cell<const PERSP: bool>(&self, w: i64, bounded: bool) -> i32 {
        // → S18 (saturating), times 1/cell → floor: the product (below
        // 2⁶³) shifted by at least 32, so from its high word (a 32-bit
        // shift; the index is below 2²⁴).
        let w18 = match (bounded, PERSP) {
            (true, true) => (w >> 24) as i32,
            (true, false) => (w >> 30) as i32,
            (false, true) => shr_sat::<24>(w),
            (false, false) => shr_sat::<30>(w),
        };
        ((smul_u(w18, self.inv_cell.0) >> 32) as i32) >> self.inv_cell.1
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct MixPrim {
    pub(super) shape: MixShape,
    pub(super) material: u8,
    pub(super) checker: Option<MixChecker>,
    /// Undistorted slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` (S26) outside which no
    /// ray meets it: a chunk whose rays all lie outside skips its pass.
    pub(super) bounds: Option<[i32; 4]>,
    /// A planar primitive's `n·l` towards each point light, S48 U²: the
    /// same at each of its points, `n·P_L − dist` (the light's height
    /// above the plane), a per-frame constant instead of a product of the
    /// hit point's rounding. 0 where it is taken per pixel: a sphere, a
    /// directional light, a light within 2⁻¹⁰ U of the plane.
    pub(super) nl: [i64; crate::scene::MAX_LIGHTS],
    /// Flat (a constant normal) in a frame whose lights are all
    /// directional: its terms are the same at every point of it
    /// ([`Mix32::shade_flat`]).
    pub(super) flat: bool,
    /// Through the aperture: for a flat rectangle without a lobe, how far
    /// its aperture rays can meet its plane from its chief ray's hit, per
    /// unit of the hit's depth from the focused one (Q8.24); for a sphere,
    /// how far from its centre a chief ray must pass for an aperture ray
    /// to meet it (S24 U: [`passes_beyond`]); 0 for any other primitive
    /// or where there is no bound. And the depths (S18 U, a perspective
    /// ray's `t`) its hits lie within (a plane's: all):
    /// [`aperture_terms`], for [`Mix32::uniform`].
    pub(super) spread: u32,
    pub(super) depth: [i32; 2],
}

/// Whether the perspective ray of slopes `(x̂, ŷ)` (S26) passes farther
/// than `reach` (S24 U) from the point `c` (S24 U): `|d × c|² > |d|²
/// reach²` for `d = (x̂, ŷ, 1)`, exactly (the sphere pass's exact test,
/// Lagrange's identity, with `reach` for the radius).
#[inline(always)]
pub(super) fn passes_beyond(x: i32, y: i32, c: [i32; 3], reach: u32) -> bool {
    // d × c in S50 (each component below 2⁶⁰: |c| within 8 U, |x̂|, |ŷ|
    // below 2⁵), its squares' sum below 2¹²¹; |d|² (S52, below 2⁶⁴)
    // times reach² (below 2⁶²) below 2¹²⁶.
    let e0 = wmul(y, c[2]) - ((c[1] as i64) << 26);
    let e1 = ((c[0] as i64) << 26) - wmul(x, c[2]);
    let e2 = wmul(x, c[1]) - wmul(y, c[0]);
    let sq = |e: i64| u128::from(e.unsigned_abs()) * u128::from(e.unsigned_abs());
    let a52 = wsq(x) + wsq(y) + (1 << 52);
    u128::from(a52) * u128::from(u64::from(reach) * u64::from(reach)) < sq(e0) + sq(e1) + sq(e2)
}

/// Whether slope bounds `b` (`[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]`, S26) meet the box
/// `[x̂₀, x̂₁, ŷ₀, ŷ₁]` (a point where `x̂₀ = x̂₁`, `ŷ₀ = ŷ₁`).
#[inline(always)]
pub(super) fn meets(b: &[i32; 4], [x0, x1, y0, y1]: [i32; 4]) -> bool {
    !(x1 < b[0] || x0 > b[1] || y1 < b[2] || y0 > b[3])
}

/// A point `c` in the frame moved to `(a_x, a_y, 0)` (both in one format),
/// saturating: what [`MixShape::moved`] does to centres, and what the
/// aperture loop's shading takes of a sphere's ([`Mix32::hit_from`]).
#[inline(always)]
pub(super) fn moved_point(c: [i32; 3], a: [i32; 2]) -> [i32; 3] {
    [c[0].saturating_sub(a[0]), c[1].saturating_sub(a[1]), c[2]]
}

impl MixShape {
    /// Every primitive but a plane: its hits lie within the content's
    /// extent ([`MixChecker::cell`]).
    #[inline(always)]
    pub(super) fn bounded(&self) -> bool {
        !matches!(self, MixShape::Plane { .. })
    }

    /// The shape in the frame moved to `(a_x, a_y, 0)` (`a` S18 U, `a24` the
    /// same point in S24 U; defocus's aperture points): exact for centres
    /// (a sphere's from `a24`), `n·A` truncated to S24 U.
    #[inline(always)]
    pub(super) fn moved(&self, a: [i32; 2], a24: [i32; 2]) -> MixShape {
        let na = |n: &[i32; 3]| ((wmul(n[0], a[0]) + wmul(n[1], a[1])) >> 24) as i32;
        let c18 = |c: &[i32; 3]| moved_point(*c, a);
        match *self {
            MixShape::Plane { n, dist, rz } => MixShape::Plane {
                n,
                dist: dist.saturating_sub(na(&n)),
                rz,
            },
            MixShape::Sphere {
                c,
                cz50,
                c18: k,
                r2_24,
                r2,
                r24,
                fine,
                inv_r,
            } => MixShape::Sphere {
                c: moved_point(c, a24),
                cz50,
                c18: c18(&k),
                r2_24,
                r2,
                r24,
                fine,
                inv_r,
            },
            MixShape::Disc { n, dist, rz, c24, r2 } => MixShape::Disc {
                n,
                dist: dist.saturating_sub(na(&n)),
                rz,
                c24: moved_point(c24, a24),
                r2,
            },
            MixShape::Rect {
                n,
                dist,
                rz,
                u,
                v,
                cu,
                cv,
                hu,
                hv,
            } => {
                // (c − A)·a, S42 U.
                let ca = |c: i64, a3: &[i32; 3]| c - ((wmul(a3[0], a[0]) + wmul(a3[1], a[1])) >> ALONG_S42);
                MixShape::Rect {
                    n,
                    dist: dist.saturating_sub(na(&n)),
                    rz,
                    u,
                    v,
                    cu: ca(cu, &u),
                    cv: ca(cv, &v),
                    hu,
                    hv,
                }
            }
        }
    }

    /// One primitive's pass over a chunk: keeps its hits that are nearer
    /// than each ray's nearest so far (`index` names it in [`Ray::hit`]).
    /// With `EXACT` (the aperture loop's rays, which nothing marks as an
    /// edge), a perspective ray that the S44 discriminant puts within its
    /// truncations (< 2³³) of a sphere's silhouette is decided exactly, in
    /// 128 bits, on the ray's S26 slopes and the sphere's S24 centre and
    /// radius; and a sphere's pass takes a ray's `1/a` itself, where the
    /// ray meets it (those rays are built without: [`Ray::flat`]).
    #[inline(always)]
    pub(super) fn nearest<const PERSP: bool, const EXACT: bool>(
        &self,
        index: u8,
        rays: &mut [Ray],
        (inner, slopes): (Option<&Inner>, [i32; 4]),
    ) {
        match self {
            MixShape::Plane { n, dist, rz } => {
                flat_pass::<PERSP>(*n, *dist, *rz, rays, |r, t, away| r.keep(t, index, away));
            }
            MixShape::Sphere { .. } => self.sphere_pass::<PERSP, EXACT>(index, rays),
            MixShape::Disc { .. } => self.disc_pass::<PERSP>(index, rays),
            MixShape::Rect {
                n,
                dist,
                rz,
                u,
                v,
                cu,
                cv,
                hu,
                hv,
            } => {
                // A chunk whose slope box lies within the frame's [`Inner`]
                // region: every ray's test would pass, and none is made —
                // in a pass of the plane alone (one pass with the flag
                // tested per ray measured slower), but in the M0's
                // `compact` build, where the flash it takes is worth more
                // than the little it saves.
                let within = PERSP && inner.is_some_and(|q| q.index == index && q.covers(slopes));
                if within && !M0_COMPACT {
                    flat_pass::<PERSP>(*n, *dist, *rz, rays, |r, t, away| r.keep(t, index, away));
                    return;
                }
                flat_pass::<PERSP>(*n, *dist, *rz, rays, |r, t, away| {
                    if t >= r.t {
                        return;
                    }
                    // (p − c)·u and (p − c)·v within the half sizes.
                    if within
                        || ((r.along::<PERSP>(t, *u) - cu).abs() <= *hu
                            && (r.along::<PERSP>(t, *v) - cv).abs() <= *hv)
                    {
                        r.keep(t, index, away);
                    }
                });
            }
        }
    }

    /// [`MixShape::nearest`] of a disc. Out of line: the loops' other
    /// passes keep their registers.
    #[inline(never)]
    pub(super) fn disc_pass<const PERSP: bool>(&self, index: u8, rays: &mut [Ray]) {
        let MixShape::Disc { n, dist, rz, c24, r2 } = *self else {
            return;
        };
        flat_pass::<PERSP>(n, dist, rz, rays, |r, t, away| {
            if t >= r.t {
                return;
            }
            // (Each square below 2⁶², the sum below 2⁶⁴; a saturated
            // coordinate is 128 U off, outside.)
            let d2: u64 = zip3(r.point24::<PERSP>(t), c24, |p, c| wsq(p.saturating_sub(c)))
                .iter()
                .sum();
            if d2 <= r2 {
                r.keep(t, index, away);
            }
        });
    }

    /// [`MixShape::nearest`] of a sphere. Out of line: the loops' other
    /// passes keep their registers (inlined, a change to it moved
    /// checkerboard-barrel, which has no sphere, by up to 5.5 M3
    /// instructions a pixel).
    #[inline(never)]
    pub(super) fn sphere_pass<const PERSP: bool, const EXACT: bool>(&self, index: u8, rays: &mut [Ray]) {
        let MixShape::Sphere {
            c,
            cz50,
            r2_24,
            c18,
            r2,
            r24,
            ..
        } = self
        else {
            return;
        };
        for r in rays.iter_mut() {
            let (b, sq) = if PERSP {
                // b = d·c S22; disc = b² − a cc = a r² − |d × c|²
                // (Lagrange's identity: no cancellation of b²
                // against a |c|² next to the silhouette), S44 from
                // the cross product's components in S22.
                let (x, y) = (r.x, r.y);
                let b = || ((wmul(x, c[0]) + wmul(y, c[1]) + *cz50) >> 28) as i32;
                // (The M0 takes `b` after the test, only for the rays that
                // hit: 3 instructions a pixel fewer on its standard scene; on
                // the M3 before it, as its registers would have it: 0.8
                // fewer.)
                let b_first = if M0 { 0 } else { b() };
                let k = |v: i64| (v >> 28) as i32;
                let (c0, c1) = ((c[0] as i64) << 26, (c[1] as i64) << 26);
                let (k0, k1, k2) = (
                    k(wmul(y, c[2]) - c1),
                    k(c0 - wmul(x, c[2])),
                    k(wmul(x, c[1]) - wmul(y, c[0])),
                );
                let disc = wmul(r.a, *r2_24) - (wsq(k0) + wsq(k1) + wsq(k2)) as i64;
                let disc = if EXACT && disc.unsigned_abs() < 1 << 33 {
                    // (r24 ≥ 0: `len_s` of a radius.)
                    if passes_beyond(x, y, *c, *r24 as u32) {
                        -1
                    } else {
                        disc.max(0)
                    }
                } else {
                    disc
                };
                if disc < 0 {
                    continue;
                }
                (if M0 { b() } else { b_first }, sqrt_s44_to_s22(disc as u64))
            } else {
                // b = c_z − o_z = c_z (S18); disc = r² − |(c − o)_xy|²,
                // S36 (|c − o| ≤ 72 U).
                let (dx, dy) = (c18[0] as i64 - r.ox as i64, c18[1] as i64 - r.oy as i64);
                let disc = *r2 as i64 - dx * dx - dy * dy;
                if disc < 0 {
                    continue;
                }
                (c18[2], sqrt_s44_to_s22((disc as u64) << 8) >> 4)
            };
            // t = (b ∓ √disc) / a: perspective S22 2^16 / a (S20) →
            // S18; parallel a = 1, S18 already. (`1/a`'s `z` is at
            // most 11, `a` ≥ 2²⁰: the shift is 35 or more, so
            // [`mul_shr_right`], and `|t|` below `|v|/16`, within T_MAX.)
            // (The aperture loop's rays, `EXACT`, come without their `1/a`
            // ([`Ray::flat`]): taken here, as [`Ray::new`] takes it, for
            // the rays that meet the sphere alone.)
            let ra = if PERSP && EXACT {
                NonZeroU32::new(r.a as u32).map_or((0, 0), recip)
            } else {
                r.ra
            };
            let over_a = |v: i32| {
                if PERSP {
                    mul_shr_right(v, ra.0, 46 - ra.1)
                } else {
                    v
                }
            };
            let mut t = over_a(b.saturating_sub(sq));
            // The far root: the ray starts inside, the outward
            // normal faces away.
            let inside = t <= 0;
            if inside {
                t = over_a(b.saturating_add(sq));
                if t <= 0 {
                    continue;
                }
            }
            r.keep(if PERSP { t } else { t.min(T_MAX) }, index, inside);
        }
    }
}

/// Where a rectangle's per-ray test cannot fail: four half-planes of slope
/// space (`m·(x̂, ŷ, 1) ≥ 0`), the rectangle shrunk by what its test's
/// arithmetic can err. A chunk whose slope box lies within all four takes
/// the rectangle's plane alone ([`Mix32::passes`]): the same hits,
/// without the two [`Ray::along`] tests a ray.
///
/// With `t = dist/(n·d)` (`n·d` of the sign `σ` of `dist` for a hit
/// ahead), `|p·a − c_a| ≤ h` for an axis `a` is `σ((h ± c_a) n ∓ dist
/// a)·d ≥ 0` — linear in `d`. The test computes `p·a` as `t̃ (d·a)~` and
/// errs by at most `E` for a point within the rectangle: `t̃`'s relative
/// error (the reciprocal's 2⁻²¹, `n·d` truncated to S24: `2⁻²⁴ T/|dist|`),
/// its truncations (2⁻¹⁸ U, times `2^l` where a small `n·d` makes
/// [`mul_shr_t`] shift left), `d·a` truncated to S24, with `t ≤ T =
/// |c·u| + |c·v| + |dist| + h_u + h_v` and `|d| < 64`; so `h − E` takes
/// the place of `h` (`E` doubled, `T` and `1/|dist|` taken as powers of
/// two above them), and `h − E ± c_a` is rounded down to S24 (a stricter
/// test). The four `m` (S54, exact in i64) are shifted to i32, rounded
/// down: that moves `m·d 2²⁶` by less than `|x̂| + |ŷ| < 2³²` (S26) units
/// of the shifted scale, the bound [`Inner::covers`] asks.
#[derive(Clone, Copy, Debug)]
pub(super) struct Inner {
    pub(super) index: u8,
    pub(super) m: [[i32; 3]; 4],
}

impl Inner {
    /// The first rectangle's, if its shrunk region is not empty.
    pub(super) fn of(prims: &[MixPrim]) -> Option<Inner> {
        let (index, (n, dist, axes)) = prims.iter().enumerate().find_map(|(i, p)| match p.shape {
            MixShape::Rect {
                n,
                dist,
                u,
                v,
                cu,
                cv,
                hu,
                hv,
                ..
            } => Some((i, (n, dist, [(u, cu, hu), (v, cv, hv)]))),
            _ => None,
        })?;
        let sigma: i64 = if dist > 0 {
            1
        } else if dist < 0 {
            -1
        } else {
            return None;
        };
        // T, S42 U (below 2^50: each term below 2^47), below 2^bt; |dist|
        // (S24) at least 2^(bd − 1).
        let t42 = axes
            .iter()
            .map(|(_, c, h)| c.unsigned_abs() + h.unsigned_abs())
            .sum::<u64>()
            + (u64::from(dist.unsigned_abs()) << 18);
        let bt = 64 - crate::num::clz64(t42);
        let bd = 32 - crate::num::clz32(dist.unsigned_abs());
        // The least |n·d| (S24) at a point within, |dist| / T, is at least
        // 2^(bd + 41 − bt): `mul_shr_t` shifts `t` left by at most l.
        let lz = 31u32.checked_sub((bd + 41).checked_sub(bt)?)?;
        // (l ≤ 18: the shift below stays within 64 bits.)
        let l = lz.saturating_sub(13);
        // E, S42 U: T (2⁻²⁰ + 2⁻²² T/|dist|) 64, 2^(l+2) 2⁻¹⁸ 64, T 2⁻²⁴;
        // doubled (T²/|dist| as the powers of two above).
        let a = (2 * bt).saturating_sub(bd + 33);
        if a > 56 {
            return None;
        }
        let e = 2 * ((t42 >> 14) + (1u64 << a) + (1u64 << (l + 32)) + (t42 >> 24) + 1) as i64;
        let mut m = [[0i64; 3]; 4];
        for (k, (a, c, h)) in axes.iter().enumerate() {
            let h = h - e;
            if h <= 0 {
                return None;
            }
            for (j, sign) in [1i64, -1].into_iter().enumerate() {
                // h − E ± c_a, S42 → S24 rounded down (a stricter test).
                let w = ((h + sign * c) >> 18) as i32;
                let row = m.get_mut(2 * k + j)?;
                for ((o, nj), aj) in row.iter_mut().zip(n).zip(a) {
                    // S24 · S30: S54, each below 2^61.
                    *o = sigma * (wmul(w, nj) - sign * wmul(dist, *aj));
                }
            }
        }
        let top = m.iter().flatten().map(|v| v.unsigned_abs()).max().unwrap_or(0);
        let shift = (64 - crate::num::clz64(top)).saturating_sub(30);
        Some(Inner {
            index: index as u8,
            m: m.map(|row| row.map(|v| (v >> shift) as i32)),
        })
    }

    /// Whether every ray of the slope box `[x̂₀, x̂₁] × [ŷ₀, ŷ₁]` (S26) lies
    /// within: each `m`'s least value over the box at least 2³².
    #[inline(always)]
    pub(super) fn covers(&self, [x0, x1, y0, y1]: [i32; 4]) -> bool {
        self.m.iter().all(|m| {
            let v = ((m[2] as i64) << 26)
                + wmul(m[0], x0).min(wmul(m[0], x1))
                + wmul(m[1], y0).min(wmul(m[1], y1));
            v >= 1 << 32
        })
    }
}

/// A flat primitive's pass: `hit(ray, t, away)` for each ray of the chunk
/// that meets its plane ahead ([`Ray::plane_t`]). A plane facing the
/// camera (`n_x = n_y = 0`) has one `t` for all the rays of a chunk —
/// `plane_t` reads nothing of the ray then (perspective: `n·d` is `n_z`;
/// parallel: `n·o` is 0) — taken once, and the reciprocal of each ray's
/// `n·d` left out: the same `t`. Two loops (a test per ray cost the M3's
/// checkerboard-barrel 15 instructions a pixel).
#[inline(always)]
pub(super) fn flat_pass<const PERSP: bool>(
    n: [i32; 3],
    dist: i32,
    rz: (u32, u32),
    rays: &mut [Ray],
    mut hit: impl FnMut(&mut Ray, i32, bool),
) {
    if n[0] == 0 && n[1] == 0 {
        let Some((t, away)) = rays.first().and_then(|r| r.plane_t::<PERSP>(n, dist, rz)) else {
            return;
        };
        for r in rays.iter_mut() {
            hit(r, t, away);
        }
    } else {
        for r in rays.iter_mut() {
            if let Some((t, away)) = r.plane_t::<PERSP>(n, dist, rz) {
                hit(r, t, away);
            }
        }
    }
}
