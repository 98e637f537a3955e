//! The fast arithmetic's defocus (camera-model.md §8): the aperture loop
//! (`line_d`), a pixel's rays through the [`Aperture`]'s points
//! (`aperture_sum`, `traced_at`), the pixels whose rays give one sum
//! (`uniform`), and the bounds a primitive's aperture rays keep
//! (`aperture_terms`).

use super::arith::{copy3, sat32, umul, wmul};
use super::expose::{chunks, put};
use super::intersect::{meets, passes_beyond, MixPrim, MixShape};
use super::rays::{ChunkBufs, Ray, Rays, AWAY, CHUNK, KEEP_C4_SAMPLED, NO_HIT};
use super::shade::KCache;
use super::{each, Aperture, Facing, Hit, Mix32};
use crate::num::FixedF64;
use crate::render::{Lines, FLAG_OUTSIDE_FIELD};
use crate::scene::Q;

/// What the aperture loop does with a pixel ([`Mix32::uniform`]).
#[derive(Clone, Copy)]
enum Through {
    /// Traces its aperture rays through every primitive.
    Traced,
    /// Its rays' sums are all the background's.
    Background,
    /// Its rays' sums are all this ray's (its chief ray with its hit).
    One(Ray),
    /// Every ray meets this rectangle and nothing nearer, in more than one
    /// texture cell: each is tested against it alone, without its edges.
    Only(u8),
}

/// Pixels of a defocused frame by how the fast aperture loop takes them
/// (`Mix32::aperture_classes`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ApertureClasses {
    /// Pixels looked at.
    pub pixels: u32,
    /// Of those, in the lens field (the others are flagged).
    pub field: u32,
    /// Of those, traced through every primitive at every aperture point.
    pub traced: u32,
    /// Of those, tested against one rectangle alone at every aperture
    /// point (its cells found along a run: `Through::Only`). The rest of
    /// the field take their chief ray's sum, or the background's.
    pub only: u32,
}

/// [`MixPrim::spread`] and [`MixPrim::depth`] of primitive `p` through an
/// aperture of radius `r` focused at `Z̃` (metres), for a frame of unit `U
/// = 2^e`. The aperture ray from `A` (`|A| ≤ r`, `A_z = 0`) through the
/// focused point `F = Z̃ (s, 1)` of a chief ray that meets the plane `n·X =
/// h` at `X₀` (depth `z₀`) meets it at `X_A`, `X_A − X₀ = (1 − z₀/Z̃) (A −
/// (n·A) F/(n·F)) / (1 − n·A/(n·F))`: so `|X_A − X₀| ≤ |z₀ − Z̃| (r/Z̃) (1 +
/// ν/cos θ)/(1 − ν r/|n·F|)`, `ν = |n_xy|`, `θ` the chief ray's angle to
/// `n`, over the chief slopes within the rectangle's bounds (no sign change
/// of `n·(s, 1)` there, and `ν r` below half of `|n·F|` and of `|h|`: every
/// aperture ray meets the plane ahead, on the chief ray's side). `r` is
/// taken 2⁻⁸ larger (`A`'s rounding, this f64's), and the depths over the
/// bounding sphere widened by 2⁻¹⁰ of them and 2⁻¹² U (a ray's `t` is
/// within 2⁻²⁰ of it). Once a frame.
#[inline(never)]
pub(super) fn aperture_terms(
    p: &crate::render::prepare::CamPrimQ,
    (r, z): (Q, Q),
    e: i32,
) -> (u32, [i32; 2]) {
    use crate::render::prepare::CamShapeQ as S;
    let f = |q: Q| q.f64();
    let (c, reach) = match &p.shape {
        S::Plane { .. } => return (0, [i32::MIN, i32::MAX]),
        S::Sphere { c, r2, .. } | S::Disc { c, r2, .. } => (c, libm::sqrt(f(*r2))),
        S::Rect { c, hu, hv, .. } => (c, libm::sqrt(f(*hu) * f(*hu) + f(*hv) * f(*hv))),
    };
    let (z0, z1) = (f(c[2]) - reach, f(c[2]) + reach);
    // Metres → S18 U, outwards.
    let s18 = |m: f64, out: f64| {
        let v = libm::ldexp(m * (1.0 + out * libm::ldexp(1.0, -10)), 18 - e) + out * libm::ldexp(1.0, 6);
        let v = if out < 0.0 { libm::floor(v) } else { libm::ceil(v) };
        if v.is_nan() {
            i32::MIN
        } else {
            v.clamp(i32::MIN as f64, i32::MAX as f64) as i32
        }
    };
    let depth = [s18(z0, -1.0), s18(z1, 1.0)];
    if let S::Sphere { .. } = p.shape {
        return (sphere_reach(f(c[2]), reach, (f(r), f(z)), e), depth);
    }
    let (S::Rect { n, dist, .. }, Some(b)) = (&p.shape, p.bounds) else {
        return (0, depth);
    };
    let n = n.map(f);
    let len = libm::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    let (r, z, h) = (f(r) * (1.0 + libm::ldexp(1.0, -8)), f(z), f(*dist) / len);
    if !(len > 0.5 && z > 0.0 && z0 > 0.0) {
        return (0, depth);
    }
    let n = n.map(|v| v / len);
    let nu = libm::sqrt(n[0] * n[0] + n[1] * n[1]);
    // n·(s, 1) is linear in the slopes: its extremes over the bounds are at
    // their corners, as is |(s, 1)|'s largest.
    let [x0, x1, y0, y1] = b.map(f);
    let (mut lo, mut hi, mut smax) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
    for (x, y) in [(x0, y0), (x0, y1), (x1, y0), (x1, y1)] {
        let g = n[0] * x + n[1] * y + n[2];
        (lo, hi) = (lo.min(g), hi.max(g));
        smax = smax.max(libm::sqrt(x * x + y * y + 1.0));
    }
    let gmin = if lo > 0.0 { lo } else { -hi };
    let nf = z * gmin;
    if !(gmin > 0.0 && smax.is_finite() && 2.0 * nu * r < nf && 2.0 * nu * r < libm::fabs(h)) {
        return (0, depth);
    }
    let k = libm::ldexp(r / z * (1.0 + nu * smax / gmin) / (1.0 - nu * r / nf), 24);
    if k < libm::ldexp(1.0, 32) {
        (libm::ceil(k) as u32, depth)
    } else {
        (0, depth)
    }
}

/// [`MixPrim::spread`] of a sphere (centre depth `cz`, radius `rho`,
/// metres) through an aperture of radius `r` focused at `Z̃ = z`: how far
/// from its centre (S24 U, rounded up) a pixel's chief ray must pass for
/// any of its aperture rays to meet it; 0 (no bound) unless it lies wholly
/// ahead of the lens. The aperture ray from `A` meets depth `ζ` at its
/// chief ray's point there plus `A (1 − ζ/Z̃)`, and a hit lies within the
/// sphere's depths `cz ± ρ`: so its chief ray passes within `ρ + |A|
/// max|1 − ζ/Z̃|` of the centre. `r` is taken 2⁻⁸ larger and the depths
/// 2⁻¹⁰ wider (as for a rectangle), plus `ζ 2⁻²⁰` (the slope offset
/// `A/Z̃`'s rounding, 2⁻²⁷) and 2⁻¹² U (the points' rounding and the
/// sphere pass's truncations, below 2⁻²⁰ U). Once a frame.
pub(super) fn sphere_reach(cz: f64, rho: f64, (r, z): (f64, f64), e: i32) -> u32 {
    let (z0, z1) = (
        (cz - rho) * (1.0 - libm::ldexp(1.0, -10)),
        (cz + rho) * (1.0 + libm::ldexp(1.0, -10)),
    );
    if !(z0 > 0.0 && z > 0.0 && r >= 0.0) {
        return 0;
    }
    let off = libm::fabs(1.0 - z0 / z).max(libm::fabs(1.0 - z1 / z));
    let reach = rho + r * (1.0 + libm::ldexp(1.0, -8)) * off + z1 * libm::ldexp(1.0, -20);
    let v = libm::ceil(libm::ldexp(reach, 24 - e) + libm::ldexp(1.0, 12));
    if v < libm::ldexp(1.0, 31) {
        v as u32
    } else {
        0
    }
}

impl Mix32 {
    /// [`Mix32::line_f`] through the aperture (defocus, camera-model.md §8):
    /// a pixel centre is the mean, over the aperture pattern's points `A`,
    /// of the radiance along the ray from `A` through where its chief ray
    /// meets the focused depth, with the chief ray's `cos⁴α`. Per point the
    /// primitives' passes run in the frame moved to `A` (a pinhole there,
    /// the chief slopes shifted by `A/Z̃`: [`MixShape::moved`]) and each hit
    /// is shaded in the camera frame. A primitive's pass is skipped where
    /// the chunk's chief slopes miss its bounds, widened by the blur. The
    /// mean of the `m` sums is exact (`m` a power of two), rounded once.
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    pub(super) fn line_d<L: Lines, const C: usize>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        buf: &mut ChunkBufs,
    ) {
        let Some(ap) = self.aperture else {
            return;
        };
        let nch = self.nch();
        let w = self.width as usize;
        let b = self.format.bytes_per_pixel();
        let (Some(pixels), Some(flags)) = (pixels.get_mut(..w * b), flags.get_mut(..w)) else {
            return;
        };
        let yd = self.yd(j);
        let yd2 = wmul(yd, yd);
        let mut acc = self.x0;
        let mut k = KCache::EMPTY;
        // A facing rectangle's two materials' sums, each under its key
        // (`Ray::hit`, material): the single loop below.
        let mut two = [((0u8, usize::MAX), [0u64; 3]); 2];
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c) as u64);
        let noise = self.noise.as_ref();
        let ChunkBufs {
            rays: chief, words, ..
        } = buf;
        // Its own rays (the carried ones instead of the chief rays:
        // shallow-dof −307 M3 instructions a pixel but +208 on the M4F).
        let mut rays = Rays::default();
        let mut index = j as u32 * self.width as u32;
        let tz = ap.m.trailing_zeros();
        for (pixels, flags) in chunks(pixels, flags, b) {
            let Some(chief) = chief.first(flags.len()) else {
                return;
            };
            // Sums of S15 DN below 2⁴⁷ each: at most 2⁵⁵. (Cleared as one
            // array: `[[0; 3]; CHUNK]` took a call a pixel.)
            let mut sums = [0u64; 3 * CHUNK];
            let (sums, _) = sums.as_chunks_mut::<3>();
            // The pixels whose aperture rays are traced (the others' `m`
            // sums are one sum, [`Mix32::uniform`], or outside the field),
            // and their chief slopes' box.
            let mut todo = [0u8; CHUNK];
            let mut count = 0;
            // The pixels whose rays one rectangle alone meets, and it.
            let mut single = [(0u8, 0u8); CHUNK];
            let mut singles = 0;
            let (mut x0, mut x1, mut y0, mut y1) = (i32::MAX, i32::MIN, i32::MAX, i32::MIN);
            for ((q, r), s) in chief.iter_mut().enumerate().zip(sums.iter_mut()) {
                let xd = (acc >> 32) as i32;
                acc -= self.dx;
                let Some((x, y, j)) = self.undistort_j(xd, yd, yd2) else {
                    *r = Ray::OUTSIDE;
                    continue;
                };
                *r = Ray::new::<true>(x, y, 0)
                    .with_c4((KEEP_C4_SAMPLED || self.area.is_some()) && self.vignetting)
                    .with_area(self.area.is_some(), j);
                let through = if self.uniform_on {
                    self.uniform(&ap, r)
                } else {
                    Through::Traced
                };
                let one = match through {
                    Through::Background => Some(self.bg),
                    Through::One(r) => (self.hit_from::<L, C, true, false>(&r, [[0; 2]; 2], None))
                        .map(|h| self.shade_flat_ap::<L, C>(&r, &h, &mut k)),
                    Through::Only(i) => {
                        if let Some(o) = single.get_mut(singles) {
                            (*o, singles) = ((q as u8, i), singles + 1);
                        }
                        continue;
                    }
                    Through::Traced => None,
                };
                if let Some(one) = one {
                    // (The format's channels: the others stay 0.)
                    each::<C>(nch, |i| {
                        if let (Some(s), Some(v)) = (s.get_mut(i), one.get(i)) {
                            *s = v << tz;
                        }
                    });
                    continue;
                }
                if let Some(t) = todo.get_mut(count) {
                    (*t, count) = (q as u8, count + 1);
                }
                (x0, x1, y0, y1) = (x0.min(r.x), x1.max(r.x), y0.min(r.y), y1.max(r.y));
            }
            let Some(rays) = rays.first(count) else {
                return;
            };
            let run_end = single_runs(&single, singles, chief);
            for u in crate::render::sensor::defocus::SPIRAL
                .iter()
                .take(if count + singles > 0 { ap.m as usize } else { 0 })
            {
                // A = u (2⁻¹⁵) times r (S24 U), rounded, and in S18 U; A/Z̃
                // (S24 U · S40 / U → S26), rounded.
                let a24 = u.map(|v| sat32(((i64::from(v) << ap.up) * ap.r24 as i64 + (1 << 14)) >> 15));
                let a = a24.map(|v| sat32((v as i64 + 32) >> 6));
                let off = a24.map(|a| ap.slope_off(a));
                // The traced rays (out of line: one body whatever the
                // single pixels' code around it, which moved its code).
                if count > 0 {
                    self.traced_at::<L, C>(
                        (rays, &todo),
                        chief,
                        sums,
                        ([a, a24], off),
                        [x0, x1, y0, y1],
                        &mut k,
                    );
                }
                self.singles_at::<L, C>(
                    (&single, singles, &run_end),
                    chief,
                    sums,
                    ([a, a24], off),
                    &mut two,
                    &mut k,
                );
            }
            self.chunk_words::<C>(
                chief,
                sums,
                (words, flags),
                (tz, nch, dn_max),
                (noise, &mut index),
            );
            put(words, false, b, pixels);
        }
    }

    /// [`Mix32::line_d`]'s pixels that one rectangle alone meets
    /// (`single`, with `run_end` from [`single_runs`]) for the aperture
    /// point `a` (S18 U, S24 U; `off` its slope offset): each ray tested
    /// against that rectangle alone, its shading added to the pixel's sums;
    /// `two` keeps a facing rectangle's two materials' sums.
    #[inline(always)]
    fn singles_at<L: Lines, const C: usize>(
        &self,
        (single, singles, run_end): (&[(u8, u8); CHUNK], usize, &[u8; CHUNK]),
        chief: &[Ray],
        sums: &mut [[u64; 3]],
        ([a, a24], off): ([[i32; 2]; 2], [i32; 2]),
        two: &mut [((u8, usize), [u64; 3]); 2],
        k: &mut KCache,
    ) {
        // The pixels one rectangle alone meets: each ray tested
        // against it alone (the frame moved to `A` once a point),
        // without its edges (every ray meets it within them, and
        // nothing nearer): the hits the passes find.
        // A rectangle facing the camera (`n_x = n_y = 0`) has one
        // `t` for every ray of the point: `plane_t` reads nothing of
        // the ray then (`n·d` is `n_z`), so it is taken once with
        // the moved shape, as `flat_pass` takes it once a chunk —
        // the same `t`. Otherwise `None`, and each ray takes its own.
        let mut moved: Option<(u8, MixShape, Facing)> = None;
        // This point's ray of the pixel `single[h]`.
        let ray_at = |h: usize| {
            let &(q, _) = single.get(h)?;
            let c = chief.get(q as usize)?;
            Some(Ray::flat(c.x.saturating_sub(off[0]), c.y.saturating_sub(off[1])))
        };
        let mut g = 0;
        while let (true, Some(&(_, i)), Some(&end), Some(r0)) =
            (g < singles, single.get(g), run_end.get(g), ray_at(g))
        {
            let Some(p) = self.prims.get(i as usize) else {
                break;
            };
            let (shape, facing) = match moved {
                Some((j, shape, facing)) if j == i => (shape, facing),
                _ => {
                    let shape = p.shape.moved(a, a24);
                    let facing = match shape {
                        MixShape::Rect { n, dist, rz, .. } if n[0] == 0 && n[1] == 0 => {
                            Some(r0.plane_t::<true>(n, dist, rz))
                        }
                        _ => None,
                    };
                    moved = Some((i, shape, facing));
                    (shape, facing)
                }
            };
            // A facing rectangle's hit, the same for every ray of
            // the point; then the run `g..=end` is taken in
            // segments of one texture cell (each found from its
            // ends: `run_end`), each ray of a segment with its
            // material. Otherwise the one ray `g`.
            let hit = match facing {
                Some(Some((t, away))) if t != NO_HIT => Some((t, i | if away { AWAY } else { 0 })),
                _ => None,
            };
            let end = if hit.is_some() { usize::from(end).max(g) } else { g };
            let cells = |h: usize| {
                let ((t, hit), k) = hit.zip(p.checker.as_ref())?;
                let mut r = ray_at(h)?;
                (r.t, r.hit) = (t, hit);
                Some(k.cells::<true>(r.hit_point::<true, true>(a), p.shape.bounded()))
            };
            let mut lo = g;
            let mut first = if end > g { Some(cells(g)) } else { None };
            while lo <= end {
                // The segment's last ray: every ray between two of
                // the same cells has them (`run_end`), so by
                // bisection, with the next segment's first cells.
                let (mut last, c_seg) = (end, first);
                if let Some(c_lo) = first {
                    let c_end = cells(end);
                    if c_end != c_lo {
                        let (mut x, mut y, mut c_y) = (lo, end, c_end);
                        while y - x > 1 {
                            let mid = x + (y - x) / 2;
                            let c_mid = cells(mid);
                            if c_mid == c_lo {
                                x = mid;
                            } else {
                                (y, c_y) = (mid, c_mid);
                            }
                        }
                        (last, first) = (x, Some(c_y));
                    }
                }
                // On a facing rectangle whose sums are its side's
                // and material's alone (`flat_sum`), the sum of
                // each of its two materials kept: a checker's rays
                // alternate between them, which `shade_flat`'s one
                // sum does not keep. The material as `hit_from`
                // takes it, once a segment (its cells are one);
                // every ray of the segment adds the kept sum.
                let kept = hit.and_then(|(t, hit)| {
                    let mut r = ray_at(lo)?;
                    (r.t, r.hit) = (t, hit);
                    // (From the segment's cells where the run found
                    // them: `material_at`'s parity.)
                    let m = match (c_seg, &p.checker) {
                        (Some(Some((cu, cv))), Some(k)) if (cu ^ cv) & 1 != 0 => k.material as usize,
                        (Some(Some(_)), _) => p.material as usize,
                        _ => Self::material_at::<true, true>(p, &r, [0; 3], a, None),
                    };
                    let kept = two.get_mut(usize::from(m != p.material as usize))?;
                    if kept.0 != (hit, m) && self.flat_sum::<L, C>(p.flat, m) {
                        *kept = ((hit, m), self.aperture_sum::<L, C>(&r, [a, a24], k));
                    }
                    (kept.0 == (hit, m)).then_some(kept.1)
                });
                for h in lo..=last {
                    let Some(&(q, _)) = single.get(h) else {
                        continue;
                    };
                    let Some(s) = sums.get_mut(q as usize) else {
                        continue;
                    };
                    if let Some(kept) = kept {
                        for (s, l) in s.iter_mut().zip(kept).take(self.chans::<C>()) {
                            *s += l;
                        }
                        continue;
                    }
                    let Some(mut r) = ray_at(h) else {
                        continue;
                    };
                    if let MixShape::Rect { n, dist, rz, .. } = shape {
                        if let Some((t, away)) = facing.unwrap_or_else(|| r.plane_t::<true>(n, dist, rz)) {
                            (r.t, r.hit) = (t, i | if away { AWAY } else { 0 });
                        }
                    }
                    self.add_aperture_ray::<L, C>(&r, [a, a24], s, k);
                }
                lo = last + 1;
            }
            g = end + 1;
        }
    }

    /// [`Mix32::line_d`]'s chunk of pixel words: each pixel's `m` sums'
    /// mean (`2^tz = m`), its chief ray's `cos⁴α`, noise keyed by `index`.
    #[inline(always)]
    fn chunk_words<const C: usize>(
        &self,
        chief: &[Ray],
        sums: &[[u64; 3]],
        (words, flags): (&mut [u16; CHUNK], &mut [u8]),
        (tz, nch, dn_max): (u32, usize, [u64; 3]),
        (noise, index): (Option<&crate::render::sensor::noise::Stage<Q>>, &mut u32),
    ) {
        for (((c, s), out), flag) in chief
            .iter()
            .zip(sums.iter())
            .zip(words.iter_mut())
            .zip(flags.iter_mut())
        {
            *out = if c.t == 0 {
                *flag = FLAG_OUTSIDE_FIELD;
                0
            } else {
                *flag = 0;
                let mut sum = [0; 3];
                each::<C>(nch, |i| {
                    if let (Some(m), Some(v)) = (sum.get_mut(i), s.get(i)) {
                        *m = v >> tz;
                    }
                });
                Self::dn_word::<C>(nch, sum, self.c4::<KEEP_C4_SAMPLED>(c), dn_max, (noise, *index))
            };
            *index = index.wrapping_add(1);
        }
    }

    /// [`Mix32::line_d`]'s traced rays for the aperture point `a` (S18 U,
    /// S24 U; `off` its slope offset): the rays of the pixels `todo` (their
    /// chief rays in `chief`, the box of their slopes `[x̂_lo, x̂_hi, ŷ_lo,
    /// ŷ_hi]`), every primitive's pass, and each hit's shading added to its
    /// pixel's sum.
    #[cfg_attr(hilcam_loops_out_of_line, inline(never))]
    #[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
    fn traced_at<L: Lines, const C: usize>(
        &self,
        (rays, todo): (&mut [Ray], &[u8; CHUNK]),
        chief: &[Ray],
        sums: &mut [[u64; 3]],
        ([a, a24], off): ([[i32; 2]; 2], [i32; 2]),
        [x0, x1, y0, y1]: [i32; 4],
        k: &mut KCache,
    ) {
        for (r, q) in rays.iter_mut().zip(todo.iter().copied()) {
            if let Some(c) = chief.get(q as usize) {
                // (Without `1/a`: a sphere's pass takes it for the
                // rays that meet the sphere, `MixShape::nearest`.)
                *r = Ray::flat(c.x.saturating_sub(off[0]), c.y.saturating_sub(off[1]));
            }
        }
        for (i, p) in self.prims.iter().enumerate() {
            if p.bounds.is_some_and(|b| !meets(&b, [x0, x1, y0, y1])) {
                continue;
            }
            p.shape
                .moved(a, a24)
                .nearest::<true, true>(i as u8, rays, (None, [0; 4]));
        }
        for (r, q) in rays.iter().zip(todo.iter().copied()) {
            let Some(s) = sums.get_mut(q as usize) else {
                continue;
            };
            self.add_aperture_ray::<L, C>(r, [a, a24], s, k);
        }
    }

    /// Adds to `sum` what aperture ray `r` (its nearest hit found, the frame
    /// moved to `a`, S18 U and S24 U) sees: its hit's shading, or the
    /// background.
    #[inline(always)]
    fn add_aperture_ray<L: Lines, const C: usize>(
        &self,
        r: &Ray,
        a: [[i32; 2]; 2],
        sum: &mut [u64; 3],
        k: &mut KCache,
    ) {
        let l = self.aperture_sum::<L, C>(r, a, k);
        for (s, l) in sum.iter_mut().zip(copy3!(l)).take(self.chans::<C>()) {
            *s += l;
        }
    }

    /// [`Mix32::shade_flat`] of an aperture ray. Out of line in a
    /// `compact` build: one copy for the aperture loop's three call sites
    /// (inlined there, the M3 camera's flash was 258 820 B with its runs
    /// still left out, 248 844 B so with them).
    #[cfg_attr(feature = "compact", inline(never))]
    #[cfg_attr(not(feature = "compact"), inline(always))]
    fn shade_flat_ap<L: Lines, const C: usize>(&self, r: &Ray, h: &Hit, k: &mut KCache) -> [u64; 3] {
        self.shade_flat::<L, C, true>(r, h, k)
    }

    /// What [`Mix32::add_aperture_ray`] adds.
    #[inline(always)]
    fn aperture_sum<L: Lines, const C: usize>(&self, r: &Ray, a: [[i32; 2]; 2], k: &mut KCache) -> [u64; 3] {
        match self.hit_from::<L, C, true, true>(r, a, None) {
            Some(h) => self.shade_flat_ap::<L, C>(r, &h, k),
            None => copy3!(self.bg),
        }
    }

    /// The sum of each of a pixel's aperture rays (its chief ray `c`'s),
    /// when they are known to be one. Of the primitives whose bounds hold
    /// its chief slope, the nearest ([`MixPrim::depth`]) lies nearer than
    /// all the others, and is a flat rectangle without a lobe
    /// ([`MixPrim::spread`]) whose plane its chief ray meets farther than
    /// its aperture rays' hits can lie from that ([`aperture_terms`])
    /// within its edges and one texture cell's: its sum depends on its side
    /// and material alone ([`Mix32::shade_flat`]). Where the hit lies that
    /// far outside an edge, no aperture ray meets it, and the next nearest
    /// is taken, as where the nearest is a sphere its chief ray passes
    /// farther from than an aperture ray can reach ([`sphere_reach`],
    /// [`passes_beyond`]; a nearer one that does not is traced); where
    /// none is left, the background. The same sums as the
    /// rays traced, which then need not be. Where the hit lies within its
    /// edges by that much but not within one cell, every ray meets the
    /// rectangle and nothing nearer: [`Through::Only`].
    #[inline(never)]
    fn uniform(&self, ap: &Aperture, c: &Ray) -> Through {
        // The primitives no aperture ray of the pixel meets, a bit each.
        let mut missed = 0u32;
        let holds = |j: usize, p: &MixPrim, missed: u32| {
            missed >> j & 1 == 0 && p.bounds.is_none_or(|b| meets(&b, [c.x, c.x, c.y, c.y]))
        };
        // A sphere its chief ray passes too far from for an aperture ray
        // to meet it (asked only of a sphere the answer matters for: the
        // nearest, or one not behind the nearest).
        let beyond = |p: &MixPrim| match p.shape {
            MixShape::Sphere { c: centre, .. } => p.spread != 0 && passes_beyond(c.x, c.y, centre, p.spread),
            _ => false,
        };
        loop {
            let mut near: Option<(usize, &MixPrim)> = None;
            for (j, p) in self.prims.iter().enumerate() {
                if holds(j, p, missed) && near.is_none_or(|(_, n)| p.depth[0] < n.depth[0]) {
                    near = Some((j, p));
                }
            }
            let Some((i, p)) = near else {
                return Through::Background;
            };
            if let MixShape::Sphere { .. } = p.shape {
                if beyond(p) {
                    missed |= 1 << i;
                    continue;
                }
                return Through::Traced;
            }
            let behind = |(j, q): (usize, &MixPrim)| {
                j == i || !holds(j, q, missed) || q.depth[0] > p.depth[1] || beyond(q)
            };
            // (A focused depth beyond S18's range: no bound from it.)
            if p.spread == 0 || ap.z18 == i32::MAX || !self.prims.iter().enumerate().all(behind) {
                return Through::Traced;
            }
            let MixShape::Rect {
                n,
                dist,
                rz,
                u,
                v,
                cu,
                cv,
                hu,
                hv,
            } = p.shape
            else {
                return Through::Traced;
            };
            let Some((t, away)) = c.plane_t::<true>(n, dist, rz) else {
                return Through::Traced;
            };
            // S18 U · Q8.24 → S42 U, and 2⁻¹¹ U: twice a ray's `along`
            // error (below 2⁻¹⁶ U: `t` and `d·a` within 2⁻²⁰ of them,
            // bounded content within 8 U).
            let m = umul(t.abs_diff(ap.z18), p.spread).min(1 << 62) as i64 + (1 << 31);
            let (du, dv) = (
                (c.along::<true>(t, u) - cu).abs(),
                (c.along::<true>(t, v) - cv).abs(),
            );
            if du.saturating_sub(m) > hu || dv.saturating_sub(m) > hv {
                missed |= 1 << i;
                continue;
            }
            if du.saturating_add(m) > hu || dv.saturating_add(m) > hv {
                return Through::Traced;
            }
            if let Some(kc) = &p.checker {
                let one = |a: [i32; 3], o: i64| {
                    let w = c.along::<true>(t, a) - o;
                    kc.cell::<true>(w - m, true) == kc.cell::<true>(w + m, true)
                };
                if !(one(kc.u, kc.ou) && one(kc.v, kc.ov)) {
                    return Through::Only(i as u8);
                }
            }
            return Through::One(Ray {
                t,
                hit: i as u8 | if away { AWAY } else { 0 },
                ..*c
            });
        }
    }

    /// How `Mix32::line_d` takes the pixels of every `stride`-th row and
    /// column (1: every pixel): [`ApertureClasses`]; `None` without
    /// defocus. (Every one traced where the rule is off:
    /// [`Mix32::trace_every_aperture_ray`].)
    pub fn aperture_classes(&self, height: u16, stride: u16) -> Option<ApertureClasses> {
        let ap = self.aperture.as_ref()?;
        let stride = stride.max(1);
        let mut n = ApertureClasses::default();
        for j in (0..height).step_by(stride as usize) {
            let (yd, mut acc) = (self.yd(j), self.x0);
            for i in 0..self.width {
                let xd = (acc >> 32) as i32;
                acc -= self.dx;
                if i % stride != 0 {
                    continue;
                }
                n.pixels += 1;
                if let Some((x, y)) = self.undistort(xd, yd, wmul(yd, yd)) {
                    n.field += 1;
                    match self
                        .uniform_on
                        .then(|| self.uniform(ap, &Ray::new::<true>(x, y, 0)))
                    {
                        Some(Through::Background | Through::One(_)) => {}
                        Some(Through::Only(_)) => n.only += 1,
                        Some(Through::Traced) | None => n.traced += 1,
                    }
                }
            }
        }
        Some(n)
    }
}

/// Runs of `single` (in its order, so of `x̂` not increasing) on one
/// rectangle and one chief `ŷ`: `run_end[g]`, the run's last. Along a
/// run, an aperture point's hit on a facing rectangle (one `t`) is
/// monotone in `x̂`, and so is each of its texture cells (every step from
/// the slope to the cell rounds down or saturates): two rays of the run in
/// the same cells have every ray between in them. (Without distortion a
/// row's `ŷ` is one; with it, rays of one `ŷ` are rare: no run.)
#[cfg_attr(hilcam_loops_out_of_line, inline(never))]
#[cfg_attr(not(hilcam_loops_out_of_line), inline(always))]
fn single_runs(single: &[(u8, u8); CHUNK], singles: usize, chief: &[Ray]) -> [u8; CHUNK] {
    let mut run_end = [0u8; CHUNK];
    let mut g = singles;
    while g > 0 {
        g -= 1;
        let joined = match (single.get(g), single.get(g + 1).filter(|_| g + 1 < singles)) {
            (Some(&(qa, ia)), Some(&(qb, ib))) => {
                ia == ib
                    && chief
                        .get(qa as usize)
                        .zip(chief.get(qb as usize))
                        .is_some_and(|(ca, cb)| ca.y == cb.y && cb.x <= ca.x)
            }
            _ => false,
        };
        let e = if joined {
            run_end.get(g + 1).copied().unwrap_or(g as u8)
        } else {
            g as u8
        };
        if let Some(r) = run_end.get_mut(g) {
            *r = e;
        }
    }
    run_end
}
