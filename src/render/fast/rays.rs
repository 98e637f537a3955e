//! The fast arithmetic's rays: a chunk's [`Ray`]s from their distorted
//! slopes (`undistort_k`, `fill_rays`), what one sees ([`Key`]), its
//! `cos⁴α` (`cos4`), and the chunk's buffers ([`ChunkBufs`]).

#[cfg(target_arch = "x86_64")]
use super::arith::RECIP_SEED;
use super::arith::{mul32, mul_shr_t, recip, sat32, umul, wmul, wmul_axis, wmul_px, wsq, T_MAX};
use crate::target::M0;
use core::num::NonZeroU32;

/// Whether the sampled and aperture loops' shaded rays keep their `cos⁴α`
/// ([`Ray::c4`]; the one-sample loop's always do): on the M0 only (on the
/// M3 the keep cost calibration-board 10 a pixel). The rays are filled
/// ([`Mix32::rays`]) and read ([`Mix32::c4`]) alike.
pub(super) const KEEP_C4_SAMPLED: bool = M0;

/// Pixels a pass handles at once (at most 32: [`Mix32::line_f`] keeps a
/// bit a ray).
pub(super) const CHUNK: usize = 32;
const _: () = assert!(CHUNK <= 32);

/// `Ray::t` of a ray that has hit nothing yet.
pub(super) const NO_HIT: i32 = i32::MAX;

/// A perspective ray's `oy` before [`closed_term`] keeps its mirror's
/// `|q|²` there (whose high word is below 2³⁰).
pub(super) const NO_Q2: i32 = -1;

/// Whether a ray of the one-sample loop keeps, for its mirror, the mirror's
/// `|q|²` to a point light on the closed plane ([`closed_term`]; the two
/// share `w`, `q_y`, `q_z` and the products of `q_x`): on the M0, where a
/// product is four 16-bit ones, and on the x86-64 host, where keeping it
/// measured faster than keeping `q_y² + q_z²` alone. Not on the M3/M4F,
/// where the products are one `SMULL` each and the registers the keeping
/// takes cost more.
pub(super) const KEEP_Q2: bool = M0 || cfg!(target_arch = "x86_64");

/// `Ray::hit`'s flag: the surface hit faces away from the viewer.
pub(super) const AWAY: u8 = 0x80;

/// What a ray sees, for the adaptive rule ([`crate::render::sensor::sampling`]): the
/// primitive (or [`Key::NOTHING`]), on a textured one the texture cell
/// (its indices within ±2²³: lengths within 8 192 U, cells at least
/// 2⁻¹⁰ U), and the lights shadowed there; or [`Key::OUTSIDE`]. Packed in
/// one word, which only equality reads: the primitive in the top byte,
/// the shadowed lights' bits below it, the indices' low 24 bits below
/// (one-to-one for indices within ±2²³).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Key(pub(super) u64);

impl Key {
    /// A ray that hits nothing.
    pub(super) const NOTHING: Key = Key::new(0, 0, u8::MAX, 0);
    /// A ray outside the lens field (or, for a pixel's corners, corners
    /// that disagree): never the same as what a pixel's centre sees.
    pub(super) const OUTSIDE: Key = Key::new(0, 0, u8::MAX - 1, 0);

    /// The key of primitive `prim`'s cell `(u, v)` with the lights
    /// `shade` shadowed.
    #[inline(always)]
    pub(super) const fn new(u: i32, v: i32, prim: u8, shade: u8) -> Key {
        const LOW24: u64 = (1 << 24) - 1;
        Key((u as u32 as u64 & LOW24)
            | ((v as u32 as u64 & LOW24) << 24)
            | ((shade as u64) << 48)
            | ((prim as u64) << 56))
    }

    /// This key with the lights `shade` shadowed (its own bits clear).
    #[inline(always)]
    pub(super) const fn shaded(self, shade: u8) -> Key {
        Key(self.0 | ((shade as u64) << 48))
    }

    /// The lights shadowed where it was found.
    #[cfg(feature = "shadows")]
    #[inline(always)]
    pub(super) const fn shade(self) -> u8 {
        (self.0 >> 48) as u8
    }

    /// Whether its cell's `u + v` is odd (the checker's second material).
    #[inline(always)]
    pub(super) const fn odd(self) -> bool {
        (self.0 ^ (self.0 >> 24)) & 1 != 0
    }
}

/// One pixel's ray and its nearest hit so far: from the origin along
/// `(x̂, ŷ, 1)` (perspective), or from `(o_x, o_y, 0)` along `(0, 0, 1)`
/// (parallel rays).
#[derive(Clone, Copy, Debug)]
pub(super) struct Ray {
    /// `x̂`, `ŷ`, S26.
    pub(super) x: i32,
    pub(super) y: i32,
    /// Parallel rays' origin, S18 U. A perspective ray has none: where
    /// [`KEEP_Q2`], [`closed_term`] keeps there, as the low and high words,
    /// its mirror's `|q|²` (`oy` is [`NO_Q2`] until then).
    pub(super) ox: i32,
    pub(super) oy: i32,
    /// `a = d·d`, S20, and `1/a = r 2^(z − 62)` as `(r, z)`.
    pub(super) a: i32,
    pub(super) ra: (u32, u32),
    /// The nearest hit's `t` (S18 U), [`NO_HIT`], or 0 outside the lens
    /// field (no hit can be nearer).
    pub(super) t: i32,
    /// The nearest hit's primitive, with [`AWAY`].
    pub(super) hit: u8,
    /// Where kept (the one-sample loop's rays on every target, the others'
    /// where [`KEEP_C4_SAMPLED`]; [`Mix32::c4`]), `cos⁴α` (S31) for the
    /// pixel it is shaded for: [`cos4`] if the frame vignettes, else 1
    /// ([`fill_rays`]); once for a ray and its mirror. (With the closed
    /// plane's run, keeping it measured fewer instructions on the M3 and
    /// more frames a second on the x86-64 host than recomputing it.)
    pub(super) c4: u32,
}

impl Ray {
    pub(super) const OUTSIDE: Ray = Ray {
        x: 0,
        y: 0,
        ox: 0,
        oy: 0,
        a: 1 << 20,
        ra: (1 << 31, 11),
        t: 0,
        hit: 0,
        c4: 1 << 31,
    };

    /// The ray of the undistorted point `(x̂, ŷ)`; `k` is the parallel
    /// rays' origin scale (`Z̄` or `f/m`, S24 U), unused for perspective.
    #[inline(always)]
    pub(super) fn new<const PERSP: bool>(x: i32, y: i32, k: i32) -> Ray {
        // a = 1 + x² + y², S20 (≤ 513: the slopes are below 16): d·d for
        // perspective rays, and cos⁴α = 1/a² for both.
        let a = (1 << 20) + ((wsq(x) + wsq(y)) >> 32) as i32;
        let ra = NonZeroU32::new(a as u32).map_or((0, 0), recip);
        let (ox, oy) = if PERSP {
            (0, if KEEP_Q2 { NO_Q2 } else { 0 })
        } else {
            // S26 · S24 → S18; |o| ≤ 64 U, checked per frame.
            (((wmul(x, k)) >> 32) as i32, ((wmul(y, k)) >> 32) as i32)
        };
        Ray {
            x,
            y,
            ox,
            oy,
            a,
            ra,
            t: NO_HIT,
            hit: 0,
            c4: 1 << 31,
        }
    }

    /// [`Ray::new`] of a perspective ray without its `1/a` (0), which only
    /// a sphere's pass and [`Ray::c4`] take: the aperture loop's rays,
    /// whose `1/a` a sphere's pass takes itself where the ray meets it
    /// ([`MixShape::nearest`]'s `EXACT`).
    #[inline(always)]
    pub(super) fn flat(x: i32, y: i32) -> Ray {
        Ray {
            x,
            y,
            ox: 0,
            oy: if KEEP_Q2 { NO_Q2 } else { 0 },
            // `a` as [`Ray::new`] takes it.
            a: (1 << 20) + ((wsq(x) + wsq(y)) >> 32) as i32,
            ra: (0, 0),
            t: NO_HIT,
            hit: 0,
            c4: 1 << 31,
        }
    }

    /// The ray with its [`Ray::c4`] from its `1/a` ([`cos4`]) if
    /// `vignette` (a loop that keeps it, in a frame that vignettes).
    #[inline(always)]
    pub(super) fn with_c4(mut self, vignette: bool) -> Ray {
        if vignette {
            self.c4 = cos4(self.ra);
        }
        self
    }

    /// The ray with its [`Ray::c4`] times `j` (S31): the distortion's area
    /// factor over the frame's `2^e` ([`undistort_kj`]), if `area`.
    #[inline(always)]
    pub(super) fn with_area(mut self, area: bool, j: u32) -> Ray {
        if area {
            self.c4 = times_s31(self.c4, j);
        }
        self
    }

    /// The ray of the column mirrored about the principal point (`x̂`,
    /// `o_x` negated — perspective rays' is 0; `a` and `1/a` are even in
    /// `x̂`), its hit forgotten. A ray outside the field (`t = 0`) stays
    /// outside.
    #[inline(always)]
    pub(super) fn mirror<const PERSP: bool>(&mut self) {
        // |x̂| < 16 (S26: below 2³⁰) and |o_x| ≤ 64 U (S18): no negation
        // overflows.
        self.x = self.x.wrapping_neg();
        if !PERSP {
            self.ox = self.ox.wrapping_neg();
        }
        if self.t != 0 {
            self.t = NO_HIT;
            self.hit = 0;
        }
    }

    /// [`Ray::mirror`] on each ray. Out of line in a `compact` build: one
    /// copy for every build of [`Mix32::line_f`] (flash).
    #[cfg_attr(feature = "compact", inline(never))]
    #[cfg_attr(not(feature = "compact"), inline(always))]
    pub(super) fn mirror_all<const PERSP: bool>(rays: &mut [Ray]) {
        if M0 {
            // By index: over the slice's iterator the M0's unrolled loop
            // (opt-level 3) divided the slice's length in bytes by a ray's
            // 40 to count them, a library call a chunk (`flat_pass` by
            // index measured worse, so it keeps its loop).
            for q in 0..rays.len() {
                if let Some(r) = rays.get_mut(q) {
                    r.mirror::<PERSP>();
                }
            }
        } else {
            rays.iter_mut().for_each(Ray::mirror::<PERSP>);
        }
    }

    /// The point at `t` (S18 U) along the ray, S18 U.
    #[inline(always)]
    pub(super) fn point<const PERSP: bool>(&self, t: i32) -> [i32; 3] {
        if PERSP {
            [mul32::<26>(t, self.x), mul32::<26>(t, self.y), t]
        } else {
            [self.ox, self.oy, t]
        }
    }

    /// The point at `t` (S18 U) along the ray, S24 U, each coordinate
    /// rounded down from the exact product (a perspective ray's `t x̂`,
    /// `t ŷ`) and saturated: a disc's test ([`MixShape::disc_pass`]).
    #[inline(always)]
    pub(super) fn point24<const PERSP: bool>(&self, t: i32) -> [i32; 3] {
        let z = sat32((t as i64) << 6);
        if PERSP {
            [mul32::<20>(t, self.x), mul32::<20>(t, self.y), z]
        } else {
            [sat32((self.ox as i64) << 6), sat32((self.oy as i64) << 6), z]
        }
    }

    /// The point of its nearest hit (S18 U), moved by `(a_x, a_y, 0)`
    /// (the aperture loop's rays start there) if `MOVED`.
    #[inline(always)]
    pub(super) fn hit_point<const PERSP: bool, const MOVED: bool>(&self, a: [i32; 2]) -> [i32; 3] {
        let pt = self.point::<PERSP>(self.t);
        if MOVED {
            [pt[0].saturating_add(a[0]), pt[1].saturating_add(a[1]), pt[2]]
        } else {
            pt
        }
    }

    /// `p·a` of the point `p` at `t` (S18 U) along the ray, for a unit
    /// axis `a` (S30): a perspective ray's `t (d·a)` in S42 U, `d·a`
    /// truncated to S24 (`|d·a| ≤ |d| < 32`), without the point (two
    /// products fewer than [`Ray::point`]'s, and finer: no coordinate
    /// rounded to S18); a parallel ray's from its point, S48 U, exact.
    ///
    /// On the Cortex-M0 a parallel ray's product by a zero component of
    /// the axis (a rectangle or checker square to the camera) is left out
    /// ([`wmul_axis`]): the same sum. (For perspective rays too it helped
    /// some scenes and slowed calibration-board, whose second axis has no
    /// zero component.)
    #[inline(always)]
    pub(super) fn along<const PERSP: bool>(&self, t: i32, a: [i32; 3]) -> i64 {
        if PERSP {
            let da = ((wmul_px(self.x, a[0]) + wmul_px(self.y, a[1]) + ((a[2] as i64) << 26)) >> 32) as i32;
            wmul_px(t, da)
        } else {
            wmul_axis(self.ox, a[0]) + wmul_axis(self.oy, a[1]) + wmul_axis(t, a[2])
        }
    }

    /// Keeps a hit at `t` if it is nearer than the nearest so far.
    #[inline(always)]
    pub(super) fn keep(&mut self, t: i32, prim: u8, away: bool) {
        if t < self.t {
            self.t = t;
            self.hit = prim | if away { AWAY } else { 0 };
        }
    }

    /// The plane `n·p = dist`'s `t` along the ray (S18 U, saturated to
    /// `T_MAX`) and whether the plane faces away (`n·d > 0`), if it is
    /// ahead. For parallel rays `rz` is `1/n_z` (from [`recip`] of `n_z`
    /// in S30), a per-frame constant.
    #[inline(always)]
    pub(super) fn plane_t<const PERSP: bool>(
        &self,
        n: [i32; 3],
        dist: i32,
        rz: (u32, u32),
    ) -> Option<(i32, bool)> {
        if PERSP {
            // t = dist / (n·d) in S18.
            let den = self.n_dot_d(n);
            // t = dist 2^18 / den: dist · (1/den) with 1/den = r 2^(z − 62).
            let (r, z) = recip(NonZeroU32::new(den.unsigned_abs())?);
            // Negated where n·d < 0 (`s` = −1): exact, and within T_MAX
            // ([`mul_shr_t`]); the same `t` as negating it with saturation
            // then taking the least of it and T_MAX (a third of the
            // instructions).
            let s = den >> 31;
            let t = (mul_shr_t(dist, r, 44 - z) ^ s).wrapping_sub(s);
            (t > 0).then_some((t, den > 0))
        } else {
            // t = (dist − n·o) / n_z: n·o S48 → S24 (|o| ≤ 64 U, so the
            // numerator stays within ±128 U); 1/n_z = r 2^(z − 32).
            if n[2] == 0 {
                return None;
            }
            let no = ((wmul(n[0], self.ox) + wmul(n[1], self.oy)) >> 24) as i32;
            // Negated where n_z < 0, as above.
            let s = n[2] >> 31;
            let t = (mul_shr_t(dist.saturating_sub(no), rz.0, 38 - rz.1) ^ s).wrapping_sub(s);
            (t > 0).then_some((t, n[2] > 0))
        }
    }

    /// A perspective ray's `n·d` (S24, from `n` in S30): [`Ray::plane_t`]'s
    /// denominator.
    #[inline(always)]
    pub(super) fn n_dot_d(&self, n: [i32; 3]) -> i32 {
        // n·d S56 → S24.
        ((wmul_px(n[0], self.x) + wmul_px(n[1], self.y) + ((n[2] as i64) << 26)) >> 32) as i32
    }

    /// Whether [`Ray::plane_t`] of a perspective ray whose `n·d` is `den`
    /// (S24, `|den| < 2³¹`; the plane `n·p = dist`) is `None` or a `t`
    /// above `t` (`0 ≤ t`, S18 U), decided without its reciprocal where it
    /// can be: `false` only where it may not be. `limit` is
    /// [`Ray::beyond_limit`]`(dist)`, a constant of the plane. The plane is
    /// behind (or never met) where `den` is 0 or its sign is not `dist`'s.
    /// Otherwise, with `T = |dist| 2¹⁸ / |den|` exact, `plane_t`'s `t` is
    /// at least `min(T_MAX, T (1 − 2⁻²¹) − 2^l − 2)`: [`recip`] is within
    /// 2⁻²¹ of `1/|den|` (relative), [`mul_shr_t`]'s floors lose under one
    /// unit before its left shift by `l = z − 13` (`z` the leading zeros of
    /// `|den|`) and one after a right shift, and `2^l |den| < 2¹⁹`. So `t <
    /// T_MAX` and `(t + 2) |den| + 2¹⁹ + D 2⁻²⁰ < D`, `D = |dist| 2¹⁸`,
    /// put the plane beyond `t`. (`tests::plane_beyond_is_plane_t_s`.)
    #[inline(always)]
    pub(super) fn plane_beyond(den: i32, dist: i32, t: i32, limit: u64) -> bool {
        // |den| where it has dist's sign, else 0 or below (and with
        // dist = 0 the limit is 0: the test below fails, and `plane_t`
        // has no t either).
        let s = dist >> 31;
        let w = (den ^ s).wrapping_sub(s);
        w <= 0 || (t < T_MAX && umul(t as u32 + 2, w as u32) < limit)
    }

    /// [`Ray::plane_beyond`]'s `limit` for a plane at `dist` (S24 U): `D −
    /// 2¹⁹ − ⌊D 2⁻²⁰⌋` with `D = |dist| 2¹⁸` (0 where that is negative).
    pub(super) fn beyond_limit(dist: i32) -> u64 {
        let d = u64::from(dist.unsigned_abs()) << 18;
        d.saturating_sub((1 << 19) + (d >> 20))
    }
}

/// The chunk buffer of rays.
pub(super) struct Rays(pub(super) [Ray; CHUNK]);

/// A chunk's rays and pixel words (and flags), kept from line to line
/// ([`Carry`]) by the one-sample loops (`Mix32::line_f`; the aperture
/// loop's chief rays): zeroed once a frame, not once a line — 1.4 KB a
/// line, 3.6 M3 instructions a pixel of the standard scene. Every entry a
/// chunk reads it writes first.
pub struct ChunkBufs {
    pub(super) rays: Rays,
    pub(super) words: [u16; CHUNK],
    pub(super) fl: [u8; CHUNK],
    /// The closed plane's even sums of a chunk (`Mix32::closed_lit`), three
    /// channels' or one's in the first 17 words: here, not zeroed a chunk
    /// (408 B; every slot a chunk reads it writes first): in the run's own
    /// frame, zeroed, it measured more instructions on the M3.
    pub(super) even3: [[u64; 3]; CHUNK / 2 + 1],
}

impl ChunkBufs {
    /// All zero, as one constant: zeroed where it lies. Built field by
    /// field (`#[derive(Default)]`), the rays, then the buffers, then the
    /// carry each took a temporary of their own and were copied on: in the
    /// M0 camera's build (`compact`, opt-level "z") `render_carried`'s
    /// frame was 4 996 B for these 1.8 KB (now 1 976 B).
    pub const EMPTY: ChunkBufs = ChunkBufs {
        rays: Rays::EMPTY,
        words: [0; CHUNK],
        fl: [0; CHUNK],
        even3: [[0; 3]; CHUNK / 2 + 1],
    };
}

impl Default for ChunkBufs {
    fn default() -> ChunkBufs {
        ChunkBufs::EMPTY
    }
}

impl core::fmt::Debug for ChunkBufs {
    /// Scratch: nothing to show.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("ChunkBufs")
    }
}

impl Default for Rays {
    /// All zero (every ray is filled before it is read): a zeroed buffer
    /// rather than [`Ray::OUTSIDE`] built and copied in, per line (cheaper
    /// on the M3).
    fn default() -> Rays {
        Rays::EMPTY
    }
}

impl Rays {
    /// Every ray zero.
    const EMPTY: Rays = {
        const ZERO: Ray = Ray {
            x: 0,
            y: 0,
            ox: 0,
            oy: 0,
            a: 0,
            ra: (0, 0),
            t: 0,
            hit: 0,
            c4: 0,
        };
        Rays([ZERO; CHUNK])
    };

    /// The first `n` rays.
    pub(super) fn first(&mut self, n: usize) -> Option<&mut [Ray]> {
        self.0.get_mut(..n)
    }
}

/// Whether every ray's `t` is [`NO_HIT`]: four rays a step, one branch
/// for the four (`all`, a branch a ray, took the M3 8 instructions a ray;
/// the M0's opt-level 3 unrolled it already).
#[inline(always)]
pub(super) fn unhit(rays: &[Ray]) -> bool {
    let mut fours = rays.chunks_exact(4);
    for f in fours.by_ref() {
        if let [a, b, c, d] = f {
            if (a.t ^ NO_HIT) | (b.t ^ NO_HIT) | (c.t ^ NO_HIT) | (d.t ^ NO_HIT) != 0 {
                return false;
            }
        }
    }
    fours.remainder().iter().all(|r| r.t == NO_HIT)
}

/// [`Mix32::undistort`] by `k1`, `k2` (S28) within the field's `u` limit
/// (S20).
#[inline(always)]
pub(super) fn undistort_k(k: [i32; 2], limit: i32, xd: i32, yd: i32, yd2: i64) -> Option<(i32, i32)> {
    undistort_kj(k, limit, (xd, yd, yd2), None).map(|(x, y, _)| (x, y))
}

/// [`undistort_k`] and, with `area = Some(e)`, the distortion's area factor
/// `J = g (g + 2u g')` (camera-model.md §5) over `2^e` in S31 (at most 1:
/// `2^e` bounds `J` over the frame, whose gain carries it,
/// [`Mix32::area`]); without, 1.
#[inline(always)]
pub(super) fn undistort_kj(
    [k1, k2]: [i32; 2],
    limit: i32,
    (xd, yd, yd2): (i32, i32, i64),
    area: Option<u32>,
) -> Option<(i32, i32, u32)> {
    // u S20 = (xd² + yd²) S52 >> 32.
    let u = ((wsq(xd) as i64 + yd2) >> 32) as i32;
    if u > limit {
        return None;
    }
    // g − 1 = u (k1 + k2 u), S28; bounded per frame.
    let k2u = ((wmul_px(k2, u)) >> 20) as i32;
    let s = k1 + k2u;
    let g = (1 << 28) + ((wmul_px(s, u)) >> 20) as i32;
    let j = match area {
        // g' = s + k2 u (S28).
        Some(e) => area_factor(g, s.wrapping_add(k2u), u, e),
        None => 1 << 31,
    };
    Some((
        ((wmul_px(xd, g)) >> 28) as i32,
        ((wmul_px(yd, g)) >> 28) as i32,
        j,
    ))
}

/// `a b` of two S31 values, S31 (truncated). Out of line in a `compact`
/// build (flash).
#[cfg_attr(feature = "compact", inline(never))]
#[cfg_attr(not(feature = "compact"), inline(always))]
fn times_s31(a: u32, b: u32) -> u32 {
    (umul(a, b) >> 31) as u32
}

/// `J / 2^e` (S31) from `g`, `g'` (S28) and `u` (S20): `h = g + 2u g'` over
/// `2^e` (S28; below 8 per frame), `g h` (S56) to S31 — below 1 − 2⁻¹⁴
/// (`2^e` bounds `J` with a margin of 2⁻⁸) and at least 0 (`J` reaches 0
/// at the fold). Out of line in a `compact` build (flash: the driven M0
/// camera's fill loops each held a copy).
#[cfg_attr(feature = "compact", inline(never))]
#[cfg_attr(not(feature = "compact"), inline(always))]
fn area_factor(g: i32, dg: i32, u: i32, e: u32) -> u32 {
    let t = ((wmul_px(dg, u)) >> 20) as i32;
    let h = g.wrapping_add(t).wrapping_add(t) >> e;
    ((wmul_px(g, h) >> 25) as i32).max(0) as u32
}

/// Fills `rays` with the rays of a row's distorted slopes `(x̂_d, ŷ_d)`,
/// `x̂_d = xd()` for each ray in turn and `(ŷ_d, ŷ_d²)` fixed (S26, S26,
/// S52), undistorted by `undistort` (`korigin`: [`Ray::new`]'s `k`; with
/// `vignette`, each ray's [`Ray::c4`], times the area factor `undistort`
/// gives with it if `area` ([`Ray::with_area`]); without `ra`, on the M0,
/// perspective rays without their `1/a`, [`Ray::flat`]): the rays'
/// `[ŷ_lo, ŷ_hi]` (rays
/// outside the field count as 0) and whether any is outside the field.
/// ([`Mix32::passes`] takes `x̂`'s range from the chunk's ends.)
///
/// With `mono` (`ŷ` monotone in `|x̂_d|` along the row: [`Mix32::rays`]),
/// `ŷ`'s range is taken from the chunk's end rays — and, if their `x̂`
/// (which has `x̂_d`'s sign) differ in sign, from `centre`'s, the row's
/// `ŷ` at `x̂_d = 0`, too: a range that holds the rays' — not ray by ray.
/// (`centre` is not `undistort`: called twice here, that was a call a ray
/// on the M0.)
#[inline(always)]
pub(super) fn fill_rays<const PERSP: bool>(
    rays: &mut [Ray],
    korigin: i32,
    mut xd: impl FnMut() -> i32,
    (yd, yd2): (i32, i64),
    undistort: impl Fn(i32, i32, i64) -> Option<(i32, i32, u32)>,
    (vignette, area, ra, mono, centre): (bool, bool, bool, bool, impl FnOnce() -> Option<i32>),
) -> ([i32; 2], bool) {
    let mut outside = false;
    let _ = ra;
    for r in rays.iter_mut() {
        *r = match undistort(xd(), yd, yd2) {
            // (Without `1/a`: rays no sphere's pass and no `cos⁴α` reads.
            // On the M0 alone: elsewhere the arm, though never taken, moved
            // the loops' layout, `Mix32::trace_row`.)
            #[cfg(hilcam_m0)]
            Some((x, y, _)) if PERSP && !ra => Ray::flat(x, y),
            Some((x, y, j)) => Ray::new::<PERSP>(x, y, korigin)
                .with_c4(vignette)
                .with_area(area, j),
            None => {
                outside = true;
                Ray::OUTSIDE
            }
        };
    }
    let (mut y0, mut y1) = (i32::MAX, i32::MIN);
    match (rays.first(), rays.last()) {
        (Some(a), Some(b)) if mono && !outside => {
            (y0, y1) = (a.y.min(b.y), a.y.max(b.y));
            if (a.x ^ b.x) < 0 {
                if let Some(y) = centre() {
                    (y0, y1) = (y0.min(y), y1.max(y));
                }
            }
        }
        _ => rays.iter().for_each(|r| (y0, y1) = (y0.min(r.y), y1.max(r.y))),
    }
    ([y0, y1], outside)
}

/// [`fill_rays`] of perspective rays along a row, on the x86-64-v3 and v4
/// hosts in vector lanes (each step a loop over the chunk's 32 rays that
/// the compiler vectorizes, with the scalar loop's integer operations):
/// ray `q` at `x̂_d = acc − q·dx` (S58;
/// `acc` is moved past the chunk) and `(ŷ_d, ŷ_d²)`, undistorted by `(k,
/// limit)` if `k` ([`undistort_k`]), with [`Ray::new`]'s `a` and `1/a`
/// ([`recip`]) and, if `vignette`, its `cos⁴α` ([`cos4`]), times the area
/// factor over `2^e` if `area = Some(e)` ([`undistort_kj`]); the same bits
/// (the test `ray_lanes_are_fill_rays`). Lanes outside the field or past
/// the chunk compute on what they hold (wrapping) and are not read.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn fill_lanes(
    rays: &mut [Ray],
    acc: &mut i64,
    dx: i64,
    (yd, yd2): (i32, i64),
    (k, limit): (Option<[i32; 2]>, i32),
    (vignette, area): (bool, Option<u32>),
) -> ([i32; 2], bool) {
    let (mut x, mut y, mut inside) = ([0i32; CHUNK], [yd; CHUNK], [true; CHUNK]);
    let mut jn = [1u32 << 31; CHUNK];
    for (q, x) in x.iter_mut().enumerate() {
        // (Wrapping: lanes past the row run on past its ends.)
        *x = (acc.wrapping_sub((q as i64).wrapping_mul(dx)) >> 32) as i32;
    }
    *acc -= rays.len() as i64 * dx;
    if let Some([k1, k2]) = k {
        for q in 0..CHUNK {
            let xd = x[q];
            let u = (((xd as i64 * xd as i64) + yd2) >> 32) as i32;
            inside[q] = u <= limit;
            let k2u = ((k2 as i64 * u as i64) >> 20) as i32;
            let s = k1.wrapping_add(k2u);
            let g = (1i32 << 28).wrapping_add(((s as i64 * u as i64) >> 20) as i32);
            x[q] = ((xd as i64 * g as i64) >> 28) as i32;
            y[q] = ((yd as i64 * g as i64) >> 28) as i32;
            if let Some(e) = area {
                let t = ((s.wrapping_add(k2u) as i64 * u as i64) >> 20) as i32;
                let h = g.wrapping_add(t).wrapping_add(t) >> e;
                jn[q] = (((g as i64 * h as i64) >> 25) as i32).max(0) as u32;
            }
        }
    }
    let (mut a, mut r, mut z, mut c4) = ([0i32; CHUNK], [0u32; CHUNK], [0u32; CHUNK], [1u32 << 31; CHUNK]);
    for q in 0..CHUNK {
        let (xq, yq) = (x[q] as i64, y[q] as i64);
        a[q] = (1i32 << 20).wrapping_add((((xq * xq) as u64 + (yq * yq) as u64) >> 32) as i32);
    }
    // `recip(a)` (a ≥ 2^20 in the field): the count and the seed's lookup,
    // then the Newton step (loops of their own: AVX2 leaves the first
    // scalar and vectorizes the second).
    let (mut dn, mut seed) = ([0u32; CHUNK], [0u32; CHUNK]);
    for q in 0..CHUNK {
        let v = (a[q] as u32).max(1);
        z[q] = v.leading_zeros();
        dn[q] = v << z[q];
        seed[q] = RECIP_SEED[(dn[q] >> 21) as usize & 1023] as u32;
    }
    for q in 0..CHUNK {
        let (dq, sq) = (dn[q] as u64, seed[q] as u64);
        let vr = ((dq * (sq << 16)) >> 32) as u32;
        r[q] = (((1u32 << 31).wrapping_sub(vr) as u64 * sq) >> 14) as u32;
        if vignette {
            c4[q] = cos4((r[q], z[q]));
        }
        if area.is_some() {
            c4[q] = ((c4[q] as u64 * jn[q] as u64) >> 31) as u32;
        }
    }
    let (mut y0, mut y1, mut outside) = (i32::MAX, i32::MIN, false);
    for (q, ray) in rays.iter_mut().enumerate().take(CHUNK) {
        *ray = if inside[q] {
            Ray {
                x: x[q],
                y: y[q],
                ox: 0,
                oy: if KEEP_Q2 { NO_Q2 } else { 0 },
                a: a[q],
                ra: (r[q], z[q]),
                t: NO_HIT,
                hit: 0,
                c4: c4[q],
            }
        } else {
            outside = true;
            Ray::OUTSIDE
        };
        (y0, y1) = (y0.min(ray.y), y1.max(ray.y));
    }
    ([y0, y1], outside)
}

/// `cos⁴α = (1/a)²` (S31) from a ray's `1/a = r 2^(z − 62)` (`a` in S20,
/// so `1/a_real = r 2^(z − 42)`, `z ≤ 11`).
#[inline(always)]
pub(super) fn cos4((r, z): (u32, u32)) -> u32 {
    let inv = r >> (11u32.saturating_sub(z));
    if M0 {
        // (A square: three 16 × 16-bit products, where the form below
        // takes four, 7.5 instructions a pixel more on the standard scene.)
        (umul(inv, inv) >> 31) as u32
    } else {
        // inv < 2^31 (`1/a` below 1 for every `a` of 2^20 and more:
        // `tests`), so inv² / 2^31 is the high word of inv · 2 inv.
        (umul(inv, inv << 1) >> 32) as u32
    }
}
