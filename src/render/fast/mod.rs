//! The fast arithmetic: the renderer's pixel path in 32-bit fixed point with
//! one format per quantity (`mix32`), the default wherever the planner can
//! bound its error ([`crate::planner`]).
//!
//! The generic path ([`crate::render`] over a [`crate::num::scalar::Scalar`])
//! runs every quantity in one type; 32 bits of one format cannot hold both a
//! ray slope to 10⁻⁸ and a far hit point, and 64 bits cost a library call a
//! product on Cortex-M3. Here every quantity has the format its range needs,
//! products are one `SMULL`/`SMLAL` into 64 bits with constant shifts, and
//! what has no bounded range (irradiance, `1/r³`) is a normalized mantissa
//! with an exponent ([`Pf`]). There is no division: `1/x` ([`recip`]) and
//! `1/√x` (in [`cos_over_r2`]) are a table seed and one Newton step,
//! products only. The formulas are the generic path's (camera-model.md §3,
//! §5, §6): `cos⁴α = (1/a)²` with `a = d·d`, `E = I (n̂·l)(1/r)³`.
//!
//! A line is rendered in chunks of 32 pixels, each in passes: the rays
//! (undistorted slopes, `a`, `1/a`), then one pass a primitive keeping each
//! ray's nearest hit (in scene order, so ties go to the first primitive, as
//! on the generic path), then shading. A frame's plane without a checker or
//! a lobe (a floor, a wall) has no pass of its own in the one-sample loop:
//! it is tested only on the rays another primitive hits, and the rays no
//! other primitive hits are shaded from the plane in closed form
//! (`Closed`: its ambient and directional terms once a frame, each point
//! light's `kd I h (|n·d| / |w P_L − dist d|)³` from the ray's slopes — no
//! `t`, no hit point). A pass holds one primitive's
//! constants in registers: on the Cortex-M3 that saves more than the chunk
//! buffer's loads and stores cost. With pixel-area sampling
//! (camera-model.md §7, [`crate::render::sensor::sampling`]) the same passes run over rows
//! of rays: the adaptive rule's corners (what each sees: primitive and
//! texture cell), the centres, then the `n×n` grid of each pixel that needs
//! it, whose mean is exact (a power-of-two count) and rounded once.
//!
//! Lengths are in a unit `U = 2^e` m chosen per frame: the smallest power of
//! two with the frame's content (primitives, point lights, in the camera
//! frame) within 8 U. Formats (`Sn`: `n` fractional bits):
//!
//! | quantity | format | range |
//! |---|---|---|
//! | `x̂_d`, `ŷ_d`, `x̂`, `ŷ` (slopes) | i32 S26 | ±32; `|x̂|, |ŷ| ≤ 16` checked per frame |
//! | `u = r_d²`, `a = 1 + x̂² + ŷ²` | i32 S20 | ≤ 2 048 |
//! | `k1`, `k2`, `g` | i32 S28 | `|g| < 8` checked per frame |
//! | unit vectors (normals, light directions, checker axes) | i32 S30 | ±2 |
//! | prepared lengths (centres, plane distances) | i32 S24 (U) | ±128 U; content ≤ 8 U |
//! | `t`, hit points, vectors to lights | i32 S18 (U) | ±8 192 U, saturating |
//! | a hit's coordinate along a rectangle's or checker's axis, `t (d·a)` (`Ray::along`) | i64 S42 (U; S48 for parallel rays) | exact product of `t` and `d·a` (S24) |
//! | sphere `b = d·c`, `d × c` / discriminant `a r² − |d × c|²` | i32 S22 / i64 S44 | ≤ 189 U / 3.6·10⁴ U² |
//! | `r²` to a point light | u64 S36 (U²) | exact |
//! | closed form: `w = n·d`; `q = w P_L − dist d`, then `|q|²` | i32 S24; i64 S50 (exact), i32 S22 U; u64 S44 U² | `|w| < 23`; `|q| ≤ 363 U` |
//! | `cos⁴α` | u32 S31 | (0, 1] |
//! | albedos × gain, irradiance, `1/r³` | [`Pf`] | any |
//! | pixel sum before `cos⁴α` | u64 S15 DN | capped at 2³² DN ([`SUM_CAP`]) |
//!
//! The terms of a pixel's sum are positive, and the cap times the smallest
//! `cos⁴α` (2⁻¹⁸) still saturates the pixel, so capping never changes a
//! pixel. `t` beyond 8 192 U (1 024 times the content) saturates: the hit
//! point then lies short of the surface along the ray. `1/r` is good to
//! 2⁻¹⁹, so `E` to 3·2⁻¹⁹ (6·10⁻⁶) of `I/r²`, plus 2⁻²⁹ of it from
//! truncating `n·l`: 0.4 DN at the top of a 16-bit scale.
//!
//! Rays are perspective (from the origin along `(x̂, ŷ, 1)`) or parallel
//! (weak perspective, orthographic: from `(o_x, o_y, 0)` along `(0, 0, 1)`,
//! origins within 64 U). Parallel rays in a scene without a plane start on
//! the plane `z = z₀` just in front of its content (`parallel_start`):
//! what they see is the same, and `U` follows the content's depth, not its
//! distance (a target 20 m away is resolved as finely as one at 1 m). The
//! normalized Phong lobe `max(0, r̂·v̂)^s` is a [`Pf`] power by squaring,
//! with `l̂` and `v̂` normalized to 2⁻²⁹
//! (`rsqrt_fine`); its error grows with `s` times the hit point's
//! 2⁻¹⁸ U rounding (the planner's error model accounts for it).
//!
//! Defocus (camera-model.md §8) traces each pixel centre's aperture rays
//! through the same passes (`aperture`). A distortion table, aperture rays
//! with pixel-area sampling, and scenes outside the formats are refused when
//! the frame is prepared ([`crate::render::RenderError::OutsideFormat`]);
//! the wide arithmetic renders them. Accuracy and cost: `host-sim tradeoff`
//! (`mix32-poly`).
//!
//! Modules by stage: `rays` (slopes, undistortion, `cos⁴α`), `intersect`
//! (a primitive's pass), `closed` (the plane in closed form), `shade`,
//! `expose` (DN, noise, the pixel's bytes), `sampled` (pixel-area
//! sampling), `aperture` (defocus); `arith` holds the formats' products,
//! reciprocals and square roots. This file holds the frame's state
//! ([`Mix32`], prepared once by `fill`) and the one-sample line loop.

use crate::num::from_acc;
use crate::num::scalar::shr_sat;
use crate::num::{clz64, div_q, mul_sat, umul16_words, FixedF64, ARMV6M};
use crate::render::sensor::sampling::Corners;
use crate::render::shading::{Brdf, ShadingLight, V3};
use crate::render::{Carry, ClosedMean, LineLoop, Lines, RenderError, FLAG_OUTSIDE_FIELD};
use crate::scene::{PixelFormat, Q};
use core::num::{NonZeroU32, NonZeroU64};

mod aperture;
mod arith;
mod closed;
mod expose;
mod intersect;
mod rays;
mod sampled;
mod shade;
#[cfg(test)]
mod tests;

pub use aperture::ApertureClasses;
use aperture::*;
use arith::*;
pub use arith::{cos_over_r2, recip, Pf};
use expose::*;
pub use expose::{mul_nonneg, SUM_CAP};
use intersect::*;
pub use rays::ChunkBufs;
use rays::*;
use shade::*;

/// Whether `L`'s fast loops for `C` channels render the specular lobe
/// ([`Lines::FAST_GRAY_SPECULAR`], [`Lines::FAST_RGB_SPECULAR`]); in a
/// `compact` build, whose loop for three channels serves one-channel
/// frames too ([`chans`]), if either does (a frame whose lobe `L` leaves
/// out is refused before it reaches a loop: `Frame::line_built`).
const fn lobe_built<L: Lines, const C: usize>() -> bool {
    if cfg!(feature = "compact") {
        L::FAST_RGB_SPECULAR || L::FAST_GRAY_SPECULAR
    } else if C == 3 {
        L::FAST_RGB_SPECULAR
    } else {
        L::FAST_GRAY_SPECULAR
    }
}

/// The channels a loop for `C` channels (1 or 3) computes for a frame of
/// `n`: `C` — but in a `compact` build (the driven camera's, bound by
/// flash) `n`, since there the loop for three serves one-channel frames
/// too (`Mix32::line_any`): a copy of each loop fewer, about 30 KB of the
/// M0 camera's flash.
#[inline(always)]
const fn chans<const C: usize>(n: usize) -> usize {
    if cfg!(feature = "compact") {
        if n < C {
            n
        } else {
            C
        }
    } else {
        C
    }
}

/// The M0's driven camera (a `compact` build for ARMv6-M, at opt-level
/// "z"): where its flash, not speed, decides a form (the rays' y-range,
/// the inner region's pass, `copy3!`, the exposure's channels).
const M0_COMPACT: bool = ARMV6M && cfg!(feature = "compact");

/// `f(c)` for each of the [`chans`] channels, written out: a loop over them
/// is not unrolled at opt-level "s" (the firmware's), which cost the RGB565
/// scene 28 M3 instructions a pixel. (A form taking the sums by reference
/// cost the M0's standard scene 21 more a pixel.) In a `compact` build too,
/// the count tested at run time: a loop over it cost the compact M3
/// build's checkerboard-barrel 327.1 against 312.9 instructions a pixel
/// (`host-sim profile`, a firmware holding that scene), and the M0
/// camera's flash was 1.3 KB smaller with the loop (measured together
/// with [`Mix32::dn_word`]'s per-channel form: 230 684 against 231 984 B).
#[inline(always)]
fn each<const C: usize>(n: usize, mut f: impl FnMut(usize)) {
    f(0);
    if chans::<C>(n) == 3 {
        f(1);
        f(2);
    }
}

/// The right shift from a perspective ray's S48 U coordinate along an axis
/// to [`Ray::along`]'s S42 (parallel rays keep S48).
const ALONG_S42: u32 = 6;

/// A ray's nearest hit, as shading takes it: material, point (S18 U), unit
/// normal (S30), whether it faces away from the viewer (surfaces are
/// two-sided: shading turns it), and its primitive's [`MixPrim::nl`].
struct Hit<'a> {
    m: usize,
    /// `[0; 3]` on a perspective ray's [`MixPrim::flat`] primitive, whose
    /// shading (directional lights alone) reads no point.
    pt: [i32; 3],
    n: [i32; 3],
    away: bool,
    nl: &'a [i64; crate::scene::MAX_LIGHTS],
    /// [`MixPrim::flat`].
    flat: bool,
    /// [`Mix32::view`] of the ray, where the normal took it already
    /// ([`fine_normal`]: a sphere under a lobe), for the lobe.
    view: Option<[i32; 3]>,
}

#[derive(Clone, Copy, Debug)]
enum MixLight {
    /// Position S18 U; intensity per channel / U² (so that `I/r²` takes `r`
    /// in U).
    Point { p: [i32; 3], i: [Pf; 3] },
    /// Unit direction S30; irradiance per channel.
    Directional { l: [i32; 3], e: [Pf; 3] },
}

/// The frame's plane shaded in closed form ([`Mix32::closed_run`]): a
/// plane without a checker or a lobe, perspective rays, every point light
/// off it by 2⁻¹⁰ U or more. Along the ray `t d` (`d = (x̂, ŷ, 1)`) it is
/// met where `w = n·d` has the sign of `dist` (at `t = dist/w`), and a
/// point light at `P_L` lies at `r = |q| / |w|` with `q = w P_L − dist d`,
/// linear in `d`: its term `kd I h / r³` (`h = n·P_L − dist`, the light's
/// height, constant) is `kd I h (|w| / |q|)³`, with no `t`, no hit point
/// and no vector to the light.
#[derive(Clone, Debug)]
struct Closed {
    /// The plane's index among the primitives (its pass is not run:
    /// [`Mix32::passes`]).
    index: u8,
    /// [`crate::render::Options::closed_mean`] ([`Mix32::closed_run`]).
    mean: ClosedMean,
    /// Unit normal, S30; `dist`, S24 U; `−dist`, S24 U and S50 U.
    n: [i32; 3],
    dist: i32,
    ndist: i32,
    ndist50: i64,
    /// [`Ray::beyond_limit`] of `dist` ([`Mix32::closed_keep`]).
    beyond: u64,
    /// The ambient and directional terms (S15 DN, capped) on the side the
    /// rays see: the same at every point. (A ray meets the plane where `w`
    /// has the sign of `dist`, so every hit faces away if `dist > 0`, and
    /// none does otherwise.)
    flat: [u64; 3],
    /// The point lights on that side.
    lights: heapless::Vec<ClosedLight, { crate::scene::MAX_LIGHTS }>,
}

impl Closed {
    /// Whether a ray with `w = n·d` (S24, [`closed_w`]) meets the plane
    /// ahead: where `w` has the sign of `dist` (`t = dist/w > 0`; `dist ≠
    /// 0`), i.e. `w` times that sign is positive — one comparison (`w ≠ 0
    /// && (w ^ dist) ≥ 0`, two, measured 278.3 against 274.3 M3
    /// instructions a pixel on the standard scene).
    #[inline(always)]
    fn ahead(&self, w: i32) -> bool {
        // (w ^ s) − s is w or −w (|w| < 2^29: no overflow).
        let s = self.dist >> 31;
        (w ^ s).wrapping_sub(s) > 0
    }
}

/// A point light of [`Closed`] on the side of the plane the rays see:
/// position (S26 U: within 8 U) and `kd I |h|` per channel (`I` per U²,
/// `h` in U).
#[derive(Clone, Copy, Debug)]
struct ClosedLight {
    p26: [i32; 3],
    k: [Pf; 3],
}

/// Defocus (camera-model.md §8): the aperture pattern pixel centres are lit
/// through. Point `k` is [`crate::render::sensor::defocus::SPIRAL`]`[k] << up` (units of
/// 2⁻¹⁵ of the radius).
#[derive(Clone, Copy, Debug)]
struct Aperture {
    /// Points (16, 64 or 256).
    m: u16,
    up: u32,
    /// The radius `d/2`, S24 U, and `U/Z̃` times 2⁴⁰: point `u` (unit disc)
    /// is `A = u d/2` on the lens (rounded to S24 U; to S18 U where planes,
    /// discs, rectangles and hit points are moved), and its ray through
    /// the chief ray's point at the focused depth has the chief slopes
    /// minus `A/Z̃` (of the rounded `A`: the ray still meets the chief ray
    /// there, so the rounding moves a hit only by its distance from the
    /// focused depth).
    r24: i32,
    inv_z40: i64,
    /// `Z̃`, S18 U.
    z18: i32,
}

impl Aperture {
    /// The lens's aperture radius `d/2` and focused depth `Z̃` (metres) if
    /// the frame is defocused, else `(0, 1)`. Out of line, as
    /// [`Aperture::new`]: [`Mix32::fill`]'s stack frame lies on the
    /// deepest path.
    #[inline(never)]
    fn lens(f: &Input) -> (Q, Q) {
        if f.aperture == 0 {
            return (Q::ZERO, Q::ONE);
        }
        let lens = &f.scene.camera.lens;
        (
            Q::saturating_from_num(lens.diameter()) >> 1,
            Q::saturating_from_num(lens.focus_distance()),
        )
    }

    /// The aperture of `m` points for a frame of unit `U = 2^e`.
    #[inline(never)]
    fn new(f: &Input, m: u16, e: i32) -> Result<Aperture, RenderError> {
        let (r, z) = Aperture::lens(f);
        let z = NonZeroU64::new(z.to_bits().max(0) as u64).ok_or(RenderError::Degenerate)?;
        if !crate::render::sensor::defocus::is_size(m) {
            return Err(RenderError::Degenerate);
        }
        // 2^40 U / Z̃ = 2^(72 + e) / (Z̃ 2^32), e in [−20, 20]: with Z̃ 2^32
        // = zn 2^k, zn in [2^31, 2^32), it is (2^63 / zn) 2^(9 + e − k)
        // (a 64-bit quotient of 32 bits or more).
        let k = 32 - clz64(z.get()) as i32;
        let zn = z.get() >> k.max(0) << (-k).max(0);
        let q = (1u64 << 63) / zn.max(1);
        let sh = 9 + e - k;
        let inv = if sh >= 0 {
            if q.leading_zeros() as i32 > sh {
                (q << sh) as u128
            } else {
                u128::MAX
            }
        } else {
            (q >> (-sh).min(63)) as u128
        };
        Ok(Aperture {
            m,
            up: crate::render::sensor::defocus::shift(m) - 17,
            r24: len_s(r, e, 24),
            inv_z40: inv.min(i64::MAX as u128) as i64,
            z18: len_s(Q::from_bits(z.get() as i64), e, 18),
        })
    }

    /// `A/Z̃` (S26) of an aperture coordinate `a` (S24 U): `a 2⁴⁰/Z̃`
    /// shifted by 38, rounded, saturated — in 64-bit products (`inv_z40 =
    /// h 2³² + l`; `a l = m 2³² + k` with `0 ≤ k < 2³²`, so `⌊(a inv +
    /// 2³⁷) / 2³⁸⌋ = ⌊(a h + m + ⌊(k + 2³⁷) / 2³²⌋) / 2⁶⌋`), not a
    /// 128-bit one, which the M3 builds of more (per chunk and point:
    /// shallow-dof 8 998 → 8 955 M3 instructions a pixel). The same value
    /// (`tests`).
    #[inline(always)]
    fn slope_off(&self, a: i32) -> i32 {
        let (h, l) = (self.inv_z40 >> 32, self.inv_z40 & 0xFFFF_FFFF);
        // |a h| < 2⁶², |a l| ≤ 2⁶³ − 2³¹: both within i64.
        let al = i64::from(a) * l;
        let m = i64::from(a) * h + (al >> 32) + (((al & 0xFFFF_FFFF) + (1 << 37)) >> 32);
        (m >> 6).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }
}

/// A rectangle's [`Ray::plane_t`] for every ray of an aperture point, if
/// it faces the camera (`n_x = n_y = 0`: `n·d` is `n_z` whatever the ray);
/// `None` if it does not.
type Facing = Option<Option<(i32, bool)>>;

/// The per-frame state of the `mix32` path.
#[derive(Clone, Debug)]
pub struct Mix32 {
    width: u16,
    format: PixelFormat,
    /// `x̂_d` of column 0 and its step, S58.
    x0: i64,
    dx: i64,
    /// `ŷ_d` of line 0 and its step, I64F64 raw (as the generic path).
    y0: i128,
    dy: i128,
    /// `k1`, `k2` (S28) if distortion is modelled; `u` limit (S20).
    k: Option<[i32; 2]>,
    limit: i32,
    /// How far (S26) a chunk's `x̂` may lie beyond the row's ends
    /// ([`Mix32::passes`]): twice `undistort`'s rounding.
    box_margin: i32,
    vignetting: bool,
    /// Parallel rays' origin scale (`Z̄` or `f/m`), S24 U; `None`:
    /// perspective rays.
    parallel: Option<i32>,
    prims: heapless::Vec<MixPrim, { crate::scene::MAX_PRIMITIVES }>,
    lights: heapless::Vec<MixLight, { crate::scene::MAX_LIGHTS }>,
    /// Per material and channel, times the gain: diffuse (DN per W/m²) and
    /// ambient (S15 DN, capped at [`SUM_CAP`]).
    kd: [[Pf; 3]; crate::scene::MAX_MATERIALS],
    ka: [[u64; 3]; crate::scene::MAX_MATERIALS],
    /// Specular constant per material and channel, times the gain, and the
    /// exponent if the material's lobe is rendered.
    ks: [[Pf; 3]; crate::scene::MAX_MATERIALS],
    lobe: [Option<u16>; crate::scene::MAX_MATERIALS],
    /// Per material, [`lobe_below`] of its exponent: `r̂·v̂` (S30) below it
    /// gives a lobe of at most 2⁻⁶⁴.
    lobe_below: [i32; crate::scene::MAX_MATERIALS],
    /// Background, S15 DN (capped).
    bg: [u64; 3],
    /// The scene's sensor noise, and its stage for the current frame id
    /// (camera-model.md §9; `None` without the `sensor` feature).
    noise_spec: Option<crate::scene::Noise>,
    noise: Option<crate::render::sensor::noise::Stage<Q>>,
    /// The side `n` of a pixel's sample grid (1: its centre alone) and
    /// whether the adaptive rule picks the pixels that take it
    /// ([`crate::render::sensor::sampling`]).
    samples: u8,
    adaptive: bool,
    /// Defocus: the aperture pixel centres are lit through.
    aperture: Option<Aperture>,
    /// The plane shaded in closed form, if the frame has one.
    closed: Option<Closed>,
    /// The first rectangle's inner region (perspective rays).
    inner: Option<Inner>,
    /// The right half's rays are the left half's mirrored ([`Ray::mirror`]):
    /// the principal point is centred and the frame's loop is
    /// [`Mix32::line_f`].
    mirror: bool,
    /// Defocus: a pixel whose aperture rays' sums are known to be one
    /// takes it from its chief ray ([`Mix32::uniform`]), unless every ray
    /// is to be traced ([`Mix32::trace_every_aperture_ray`]).
    uniform_on: bool,
}

/// What [`Mix32::fill`] takes from the frame the generic path prepared (all
/// in I32F32, camera frame).
pub(crate) struct Input<'a> {
    pub width: u16,
    pub height: u16,
    pub format: PixelFormat,
    pub x0: i128,
    pub dx: i128,
    pub y0: i128,
    pub dy: i128,
    /// `k1`, `k2` and the `u` limit, if distortion is modelled (polynomial).
    pub distortion: Option<([Q; 2], Q)>,
    pub vignetting: bool,
    /// Parallel rays' origin scale (`Z̄` or `f/m`, metres), or `None` for
    /// perspective rays.
    pub origin_scale: Option<Q>,
    /// Render the specular lobe of every material (even one whose `ks` is
    /// 0: every stage kept).
    pub specular_all: bool,
    /// The scene: its primitives, lights and materials are moved into the
    /// camera frame and folded one at a time (no copy of them all).
    pub scene: &'a crate::scene::Scene,
    pub background: V3,
    pub gain: V3,
    /// The sample grid's side (1, 2, 4, 8 or 16) and the adaptive rule.
    pub samples: u8,
    pub adaptive: bool,
    /// Defocus: the aperture pattern's points (16, 64 or 256; the lens
    /// gives its radius and focused depth), or 0: the chief ray alone.
    pub aperture: u16,
    /// The principal point is the sensor's centre (`o_x = (W − 1)/2`).
    pub centred: bool,
    /// [`crate::render::Options::closed_mean`].
    pub closed_mean: ClosedMean,
}

impl Input<'_> {
    /// The scene's primitives in the camera frame (culled unless every
    /// stage is kept).
    fn prims(&self) -> impl Iterator<Item = crate::render::prepare::CamPrimQ> + '_ {
        let cull = !self.specular_all;
        // With defocus the slope bounds widen by the blur.
        let blur = (self.aperture > 0).then(|| crate::render::prepare::lens_blur(self.scene));
        (self.scene.primitives.iter())
            .map(move |p| crate::render::prepare::cam_prim(self.scene, p, self.origin_scale, cull, blur))
    }

    /// [`Input::prims`] without their slope bounds (for the extents).
    fn shapes(&self) -> impl Iterator<Item = crate::render::prepare::CamPrimQ> + '_ {
        (self.scene.primitives.iter())
            .map(move |p| crate::render::prepare::cam_prim(self.scene, p, self.origin_scale, false, None))
    }

    /// The scene's lights in the camera frame.
    fn lights(&self) -> impl Iterator<Item = ShadingLight> + '_ {
        (self.scene.lights.iter()).map(|l| crate::render::prepare::shading_light(self.scene, l))
    }

    /// The scene's materials, folded with its ambient light.
    fn materials(&self) -> impl Iterator<Item = Brdf> + '_ {
        (self.scene.materials.iter()).map(|m| Brdf::new(m, self.scene.ambient))
    }
}

/// `c` in a frame moved along the axis to `z = z0`, metres.
fn at(c: V3, z0: Q) -> V3 {
    [c[0], c[1], c[2].saturating_sub(z0)]
}

/// A primitive in the camera frame moved along the axis to `z = z0`
/// (planes are never moved: [`parallel_start`]).
fn ahead(mut p: crate::render::prepare::CamPrimQ, z0: Q) -> crate::render::prepare::CamPrimQ {
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
fn centre_and_reach(shape: &crate::render::prepare::CamShapeQ) -> Option<(V3, Q)> {
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
fn content_extent(f: &Input, z0: Q) -> (Q, Q) {
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
fn parallel_start(f: &Input) -> Q {
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
fn v_len(v: V3) -> Q {
    // |v| ≤ 8.4·10⁶ m for scene content: √ of the I32F32 square sum in f64-free
    // integer form (one-off, per frame).
    let s: u128 = v
        .iter()
        .map(|c| (c.to_bits() as i128 * c.to_bits() as i128) as u128)
        .sum();
    // √ of 2^-64 m² → 2^-32 m.
    Q::from_bits(crate::num::isqrt_u128(s).min(i64::MAX as u128) as i64)
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
    };

    /// Converts a prepared frame in place (the path's state is kilobytes:
    /// no copies of it on the stack); refuses what the formats cannot
    /// hold, leaving `self` partly filled — the caller drops it then.
    pub(crate) fn fill(&mut self, f: &Input) -> Result<(), RenderError> {
        use crate::render::prepare::CamShapeQ as S;
        let bad = RenderError::OutsideFormat;
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
            return Err(bad);
        }
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
                        inv_r: recip_len(r, e).ok_or(bad)?,
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
                    let cell = div_q(Q::ONE, k.inv_cell).ok_or(bad)?;
                    let half = 1i64 << (29 - along);
                    Some(MixChecker {
                        u,
                        v,
                        ou: (dot48(o, u) >> (along + 6)) - half,
                        ov: (dot48(o, v) >> (along + 6)) - half,
                        inv_cell: recip_len(cell, e)
                            .and_then(|(m, sh)| Some((m, (sh + 30).checked_sub(32).filter(|k| *k < 32)?)))
                            .ok_or(bad)?,
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
        let gain = f.gain.map(Pf::of_q);
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
        let bg = zip3(f.background, gain, |b, g| (Pf::of_q(b) * g).to_sum(15));
        // Spheres under a lobe take the fine normal.
        let lobe = self.lobe;
        let has_lobe = |m: u8| lobe.get(m as usize).is_some_and(Option::is_some);
        for p in self.prims.iter_mut() {
            let lobed = has_lobe(p.material) || p.checker.as_ref().is_some_and(|k| has_lobe(k.material));
            if let MixShape::Sphere { fine, .. } = &mut p.shape {
                *fine = lobed;
            }
        }

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
            return Err(bad);
        }
        let (k, limit, gmax, margin) = match f.distortion {
            Some(([k1, k2], limit)) => {
                let u_corner = mul_sat(xm, xm).saturating_add(mul_sat(ym, ym));
                let u_max = u_corner.min(limit);
                let s = k1.abs().saturating_add(mul_sat(k2.abs(), u_max));
                let g = Q::ONE.saturating_add(mul_sat(s, u_max));
                if s >= Q::from_num(8) || g >= Q::from_num(8) {
                    return Err(bad);
                }
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
                (Some([s28(k1), s28(k2)]), sat32(limit.to_bits() >> 12), g, margin)
            }
            None => (None, i32::MAX, Q::ONE, 2),
        };
        // (Aperture rays' slopes are the chief ray's shifted by up to d/(2Z̃):
        // d/2 ≤ (16 − slope) Z̃.)
        let slope = mul_sat(xm.max(ym), gmax);
        if slope > Q::from_num(16) || ap_r > mul_sat(Q::from_num(16) - slope, ap_z) {
            return Err(bad);
        }
        // Parallel rays: origins within 64 U (so that n·o and the sphere's
        // offsets keep their formats), the scale in S24.
        let parallel = match f.origin_scale {
            None => None,
            Some(k) => {
                let k24 = len_s(k, e, 24);
                if k <= Q::ZERO || k24 == i32::MAX || mul_sat(slope, k) > shl_q(64, e) {
                    return Err(bad);
                }
                Some(k24)
            }
        };
        self.parallel = parallel;
        self.width = f.width;
        self.format = f.format;
        self.x0 = (f.x0 >> 6) as i64;
        self.dx = (f.dx >> 6) as i64;
        self.y0 = f.y0;
        self.dy = f.dy;
        self.k = k;
        self.limit = limit;
        self.box_margin = margin.max(2);
        self.vignetting = f.vignetting;
        self.bg = bg;
        self.noise_spec = f.scene.noise;
        if !matches!(f.samples, 1 | 2 | 4 | 8 | 16) {
            return Err(RenderError::Degenerate);
        }
        self.samples = f.samples;
        self.adaptive = f.adaptive && f.samples > 1;
        self.aperture = match f.aperture {
            0 => None,
            // Pixel centres through the aperture, perspective rays.
            _ if f.samples > 1 || parallel.is_some() => return Err(RenderError::Degenerate),
            m => Some(Aperture::new(f, m, e)?),
        };
        self.mirror = f.centred && self.samples == 1 && self.aperture.is_none();
        self.closed = self.closed_plane(f.closed_mean);
        self.inner = if parallel.is_none() {
            Inner::of(&self.prims)
        } else {
            None
        };
        let directional = self
            .lights
            .iter()
            .all(|l| matches!(l, MixLight::Directional { .. }));
        for p in self.prims.iter_mut() {
            p.flat = directional && !matches!(p.shape, MixShape::Sphere { .. });
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
    fn yd(&self, j: u16) -> i32 {
        ((self.y0 - self.dy * j as i128) >> 38) as i32
    }

    /// `(x̂, ŷ)` (S26) of a distorted point, or `None` beyond the fold.
    #[inline(always)]
    fn undistort(&self, xd: i32, yd: i32, yd2: i64) -> Option<(i32, i32)> {
        match self.k {
            Some(k) => undistort_k(k, self.limit, xd, yd, yd2),
            None => Some((xd, yd)),
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

    /// Renders line `j`: `pixels` holds `width × bytes_per_pixel` bytes.
    /// Only `L`'s loops are compiled in; a line of another is left as it
    /// is ([`crate::render::Frame::render_with`] refuses such a frame first).
    ///
    /// On x86-64 the loops the Cortex-M builds keep out of line are
    /// inlined here and into [`Mix32::line_v3`] and [`Mix32::line_v4`]:
    /// three copies of them, two built for newer processors.
    #[cfg_attr(target_arch = "x86_64", inline(never))]
    pub fn line<L: Lines>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8], carry: &mut Carry) {
        self.line_any::<L, false>(j, pixels, flags, carry)
    }

    /// [`Mix32::line`] built for x86-64-v3 processors (AVX2, BMI1, BMI2,
    /// FMA, LZCNT, MOVBE, POPCNT): variable shifts and leading-zero counts
    /// are one instruction each there, and perspective rays are made in
    /// vector lanes (`fill_lanes`). The same bytes. (The closed plane's
    /// pixels in lanes too, every ray's terms where the scalar run takes
    /// one in two to eight, measured slower and went: 1080p standard
    /// 55.7–55.8 frames/s against 68.9–69.7 on 2 threads, `host-sim
    /// throughput`.)
    ///
    /// # Safety
    ///
    /// Call only on a processor with those features.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt")]
    pub fn line_v3<L: Lines>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8], carry: &mut Carry) {
        self.line_any::<L, true>(j, pixels, flags, carry)
    }

    /// [`Mix32::line`] built for x86-64-v4 processors (x86-64-v3's features
    /// and AVX-512 F, CD, VL, BW, DQ): the compiler vectorizes more of the
    /// lanes (`fill_lanes`: the count of leading zeros and the seed
    /// table's gather). The same bytes.
    ///
    /// # Safety
    ///
    /// Call only on a processor with those features.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(
        enable = "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt,avx512f,avx512cd,avx512vl,avx512bw,avx512dq"
    )]
    pub fn line_v4<L: Lines>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8], carry: &mut Carry) {
        self.line_any::<L, true>(j, pixels, flags, carry)
    }

    /// [`Mix32::line`]'s dispatch to the frame's loop.
    #[inline(always)]
    fn line_any<L: Lines, const LANES: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        carry: &mut Carry,
    ) {
        // (The sampled loop keeps its own chunk buffers.)
        let (corners, buf) = (&mut carry.corners, &mut carry.chunk);
        // One channel's loops: in a `compact` build, those for three, which
        // compute the frame's one channel ([`chans`]; a copy fewer of each).
        const G: usize = if cfg!(feature = "compact") { 3 } else { 1 };
        match self.line_loop() {
            LineLoop::FastGrayPerspective if L::FAST_GRAY_PERSPECTIVE => {
                self.line_f::<L, LANES, G, true>(j, pixels, flags, buf)
            }
            LineLoop::FastRgbPerspective if L::FAST_RGB_PERSPECTIVE => {
                self.line_f::<L, LANES, 3, true>(j, pixels, flags, buf)
            }
            LineLoop::FastGrayParallel if L::FAST_GRAY_PARALLEL => {
                self.line_f::<L, LANES, G, false>(j, pixels, flags, buf)
            }
            LineLoop::FastRgbParallel if L::FAST_RGB_PARALLEL => {
                self.line_f::<L, LANES, 3, false>(j, pixels, flags, buf)
            }
            LineLoop::FastGrayPerspectiveSampled if L::FAST_GRAY_PERSPECTIVE_SAMPLED => {
                self.sampled::<L, G, true>(j, pixels, flags, corners)
            }
            LineLoop::FastRgbPerspectiveSampled if L::FAST_RGB_PERSPECTIVE_SAMPLED => {
                self.sampled::<L, 3, true>(j, pixels, flags, corners)
            }
            LineLoop::FastGrayParallelSampled if L::FAST_GRAY_PARALLEL_SAMPLED => {
                self.sampled::<L, G, false>(j, pixels, flags, corners)
            }
            LineLoop::FastRgbParallelSampled if L::FAST_RGB_PARALLEL_SAMPLED => {
                self.sampled::<L, 3, false>(j, pixels, flags, corners)
            }
            LineLoop::FastGrayAperture if L::FAST_GRAY_APERTURE => self.line_d::<L, G>(j, pixels, flags, buf),
            LineLoop::FastRgbAperture if L::FAST_RGB_APERTURE => self.line_d::<L, 3>(j, pixels, flags, buf),
            _ => {}
        }
    }

    /// The loop this frame's lines are rendered by.
    pub fn line_loop(&self) -> LineLoop {
        let rgb = self.format == PixelFormat::Rgb565;
        if self.aperture.is_some() {
            return if rgb {
                LineLoop::FastRgbAperture
            } else {
                LineLoop::FastGrayAperture
            };
        }
        match (rgb, self.parallel.is_none(), self.samples > 1) {
            (false, true, false) => LineLoop::FastGrayPerspective,
            (true, true, false) => LineLoop::FastRgbPerspective,
            (false, false, false) => LineLoop::FastGrayParallel,
            (true, false, false) => LineLoop::FastRgbParallel,
            (false, true, true) => LineLoop::FastGrayPerspectiveSampled,
            (true, true, true) => LineLoop::FastRgbPerspectiveSampled,
            (false, false, true) => LineLoop::FastGrayParallelSampled,
            (true, false, true) => LineLoop::FastRgbParallelSampled,
        }
    }

    /// [`Mix32::line`] for `C` channels, perspective or parallel rays: the
    /// line in chunks of [`CHUNK`] pixels, each in passes — the undistorted
    /// rays, then one pass a primitive keeping the nearest hit, then
    /// shading, then the pixel bytes. A pass holds one primitive's
    /// constants in registers. With the principal point centred
    /// ([`Mix32::mirror`]) a chunk of the left half's rays, once shaded, is
    /// mirrored ([`Ray::mirror`]) into the right half's columns and run
    /// through the passes again: the right half's rays are not undistorted
    /// anew (the error of each is the mirror image of its column's).
    #[cfg_attr(not(target_arch = "x86_64"), inline(never))]
    #[cfg_attr(target_arch = "x86_64", inline(always))]
    fn line_f<L: Lines, const LANES: bool, const C: usize, const PERSP: bool>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        buf: &mut ChunkBufs,
    ) {
        let w = self.width as usize;
        let b = self.format.bytes_per_pixel();
        let (Some(pixels), Some(flags)) = (pixels.get_mut(..w * b), flags.get_mut(..w)) else {
            return;
        };
        let yd = self.yd(j);
        let yd2 = wmul(yd, yd);
        let mut acc = self.x0;
        // kd · E per light for the material of the last shaded pixel.
        let mut k = KCache::EMPTY;
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c) as u64);
        let noise = self.noise.as_ref();
        let ChunkBufs {
            rays,
            words,
            fl,
            even3,
        } = buf;
        // The index of the line's first pixel in the frame (the noise's key).
        let line = j as u32 * self.width as u32;
        // Columns `w − half ..` take the rays of columns `.. half` mirrored.
        let half = if self.mirror { w / 2 } else { 0 };
        let direct = w - half;
        // One body for both kinds of chunk (a copy of the passes and the
        // shading each would cost flash): columns `s + q` from their
        // slopes, then, if any, the mirrored columns `w − 1 − s − q` of the
        // first `m` of those rays `q`.
        let (mut s, mut n, mut mirrored) = (0, 0, false);
        let (mut ys, mut outside) = ([0i32; 2], false);
        while s < direct {
            // (Computed twice, here and below, not kept from the chunk's
            // start: kept, it cost the M3's standard scene 6 instructions a
            // pixel, 412 against 406.)
            let m = n.min(half.saturating_sub(s));
            let (cnt, first, step) = if mirrored {
                (m, w - s - m, u32::MAX)
            } else {
                n = CHUNK.min(direct - s);
                (n, s, 1)
            };
            let (Some(rays), Some(out), Some(flags), Some(words), Some(fl)) = (
                rays.first(cnt),
                pixels.get_mut(first * b..(first + cnt) * b),
                flags.get_mut(first..first + cnt),
                words.get_mut(..cnt),
                fl.get_mut(..cnt),
            ) else {
                return;
            };
            if mirrored {
                Ray::mirror_all::<PERSP>(rays);
            } else {
                // Inlined here (not `trace_row`): the loop without sampling
                // stays as fast as it was (an out-of-line pass cost the
                // standard scene 9 M3 instructions a pixel).
                (ys, outside) = match () {
                    // Perspective rays in vector lanes in the x86-64-v3 and
                    // v4 builds.
                    #[cfg(target_arch = "x86_64")]
                    () if LANES && PERSP => {
                        let u = (self.k, self.limit);
                        fill_lanes(rays, &mut acc, self.dx, (yd, yd2), u, self.vignetting)
                    }
                    () => self.rays::<PERSP>(
                        rays,
                        || {
                            let xd = (acc >> 32) as i32;
                            acc -= self.dx;
                            xd
                        },
                        (yd, yd2),
                        (true, true),
                    ),
                };
            }
            // The closed plane, if any: tested only where another primitive
            // was hit; the rays no other primitive hit (and those outside
            // the field) see it or nothing, shaded in closed form.
            let closed = if PERSP { self.closed.as_ref() } else { None };
            let met = self.passes::<PERSP, true>(rays, ys, outside, closed.map(|c| c.index as usize));
            // Each pixel's noise key is its index in the frame: the mirrored
            // rays' columns run right to left (`step` is −1 modulo 2³²).
            let index = line.wrapping_add(if mirrored { w - 1 - s } else { s } as u32);
            // The rays left to shade here, a bit each: those the run left
            // (another primitive's hits), else all.
            let mut left = match closed {
                Some(c) => self.closed_run::<C>(
                    c,
                    (rays, ys, met || outside),
                    (words, &mut *even3),
                    fl,
                    dn_max,
                    (noise, index, step),
                ),
                // (1 to 32 rays: a shift of 0 to 31. None gives a mask
                // whose rays `get` does not find.)
                None => u32::MAX.wrapping_shr(CHUNK.saturating_sub(rays.len()) as u32),
            };
            while left != 0 {
                let q = left.trailing_zeros();
                left &= left - 1;
                let key = index.wrapping_add(q.wrapping_mul(step));
                let q = q as usize;
                if let (Some(r), Some(word), Some(flag)) = (rays.get(q), words.get_mut(q), fl.get_mut(q)) {
                    *word = self.pixel::<L, C, PERSP>(r, copy3!(dn_max), flag, &mut k, (noise, key));
                }
            }
            store(words, fl, mirrored, b, out, flags);
            if !mirrored && n.min(half.saturating_sub(s)) > 0 {
                mirrored = true;
            } else {
                (s, mirrored) = (s + n, false);
            }
        }
    }

    /// [`fill_rays`] of a row of slopes (`ŷ_d` fixed) with this frame's
    /// undistortion (a frame without distortion has a loop without its
    /// test). With `keep_c4`, each ray's `cos⁴α` ([`Ray::c4`], for
    /// [`Mix32::c4`]); without `ra`, on the M0, perspective rays without
    /// their `1/a` ([`Ray::flat`]: rays that are not shaded, in a frame
    /// without a sphere).
    #[inline(always)]
    fn rays<const PERSP: bool>(
        &self,
        rays: &mut [Ray],
        xd: impl FnMut() -> i32,
        row: (i32, i64),
        (keep_c4, ra): (bool, bool),
    ) -> ([i32; 2], bool) {
        let korigin = self.parallel.unwrap_or(0);
        let vignette = keep_c4 && self.vignetting;
        // (Not in the M0's `compact` build: flash, 1.7 KB of its camera's
        // for standard 885.4 → 877.2; the M3 camera's 226.7 → 221.7 for
        // 1 KB.)
        let mono = !M0_COMPACT;
        match self.k {
            // `ŷ = ŷ_d g(u)` is monotone in `u` (so in `|x̂_d|`) where `g` is,
            // as each of its floors is: `k1`, `k2 ≥ 0` (u ≥ 0).
            Some(k) => fill_rays::<PERSP>(
                rays,
                korigin,
                xd,
                row,
                |xd, yd, yd2| undistort_k(k, self.limit, xd, yd, yd2),
                (vignette, ra, mono && k[0] >= 0 && k[1] >= 0, || {
                    undistort_k(k, self.limit, 0, row.0, row.1).map(|(_, y)| y)
                }),
            ),
            None => fill_rays::<PERSP>(
                rays,
                korigin,
                xd,
                row,
                |xd, yd, _| Some((xd, yd)),
                (vignette, ra, mono, || Some(row.0)),
            ),
        }
    }

    /// Every primitive's pass over `rays`, given their `[ŷ_lo, ŷ_hi]`
    /// ([`fill_rays`]; rays outside the field count as 0: a larger box,
    /// never a skipped hit) and whether any is outside the field. Out of line in a `compact` build: one copy
    /// serves the loops for one and three channels (flash).
    /// Primitive `skip` (the frame's [`Closed`] plane in the one-sample
    /// loop) has no pass: [`Mix32::closed_keep`] tests it on the rays
    /// another primitive hits, [`Mix32::closed_run`] shades the others.
    /// Whether any pass ran (else every ray's `t` is as it was).
    #[cfg_attr(feature = "compact", inline(never))]
    #[cfg_attr(not(feature = "compact"), inline(always))]
    fn passes<const PERSP: bool, const TRIM: bool>(
        &self,
        rays: &mut [Ray],
        [y0, y1]: [i32; 2],
        outside: bool,
        skip: Option<usize>,
    ) -> bool {
        // Along a row (`ŷ_d` fixed) `x̂` is monotone in `x̂_d` within the
        // field: ∂x̂/∂x̂_d = g + 2 x̂_d² g'(u) ≥ g + 2u g'(u) ≥ 0 before the
        // fold (x̂_d² ≤ u). So the ends bound the rest, to twice
        // `undistort`'s rounding (`box_margin`). A chunk with rays outside
        // the field takes them all.
        let m = self.box_margin;
        let (mut x0, mut x1) = match (rays.first(), rays.last()) {
            (Some(a), Some(b)) if !outside => {
                (a.x.min(b.x).saturating_sub(m), a.x.max(b.x).saturating_add(m))
            }
            _ => (i32::MAX, i32::MIN),
        };
        if outside {
            for r in rays.iter() {
                (x0, x1) = (x0.min(r.x), x1.max(r.x));
            }
        }
        let mut met = false;
        for (i, p) in self.prims.iter().enumerate() {
            if skip == Some(i) {
                continue;
            }
            let (mut lo, mut hi) = (0, rays.len());
            if let Some(b) = p.bounds {
                if x1 < b[0] || x0 > b[1] || y1 < b[2] || y0 > b[3] {
                    continue;
                }
                // The chunk's test, ray by ray, from each end: the pass
                // runs over the rays from the first to the last that lie
                // within the bounds.
                let out = |r: &Ray| r.x < b[0] || r.x > b[1] || r.y < b[2] || r.y > b[3];
                while TRIM && rays.get(lo).is_some_and(out) {
                    lo += 1;
                }
                while TRIM && hi > lo && rays.get(hi - 1).is_some_and(out) {
                    hi -= 1;
                }
            }
            let Some(rays) = rays.get_mut(lo..hi) else {
                continue;
            };
            met = true;
            p.shape
                .nearest::<PERSP, false>(i as u8, rays, (self.inner.as_ref(), [x0, x1, y0, y1]));
        }
        met
    }

    /// Shades one pixel of a chunk whose nearest hits are known; returns
    /// its [`word`].
    #[inline(always)]
    fn pixel<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        dn_max: [u64; 3],
        flag: &mut u8,
        k: &mut KCache,
        (noise, index): (Option<&crate::render::sensor::noise::Stage<Q>>, u32),
    ) -> u16 {
        if r.t == 0 {
            *flag = FLAG_OUTSIDE_FIELD;
            return 0;
        }
        *flag = 0;
        let (sum, c4) = self.radiance::<L, C, PERSP, true>(r, k, None);
        Self::dn_word::<C>(self.nch(), sum, c4, dn_max, (noise, index))
    }

    /// A pixel's [`word`] from its sum before vignetting (S15 DN) and
    /// `cos⁴α` (S31): the noise stage's draw, or vignetted and rounded.
    /// Channels past `C` are not packed: the compiler drops them.
    #[inline(always)]
    fn dn_word<const C: usize>(
        n: usize,
        sum: [u64; 3],
        c4: u32,
        dn_max: [u64; 3],
        (noise, index): (Option<&crate::render::sensor::noise::Stage<Q>>, u32),
    ) -> u16 {
        match noise {
            Some(z) => noisy::<C>(n, z, sum, c4, index, dn_max),
            // (A `compact` build's loop for three channels serves one-channel
            // frames too: their channel alone. The others leave the
            // compiler to drop what `word` does not pack.)
            None if cfg!(feature = "compact") && !M0_COMPACT => {
                let mut dn = [0u32; 3];
                each::<C>(n, |c| {
                    if let (Some(d), Some(&s), Some(&max)) = (dn.get_mut(c), sum.get(c), dn_max.get(c)) {
                        *d = vignette_dn(s, c4, max as u32);
                    }
                });
                word::<C>(n, dn)
            }
            // On the M0 each channel a value, not through a closure over
            // the arrays: at its camera's opt-level "z" that closure stayed
            // out of line and both arrays were copied to the stack a pixel,
            // two `memcpy`s of 24 B (wide-vignetting 338.2 against 193.7
            // instructions a pixel, standard 884.8 against 810.3; this form
            // measured the M3 camera's standard 231.8 against 221.1).
            None if M0_COMPACT => {
                let ([s0, s1, s2], [m0, m1, m2]) = (sum, dn_max);
                let v = |s: u64, max: u64| vignette_dn(s, c4, max as u32);
                let d0 = v(s0, m0);
                let dn = if chans::<C>(n) == 3 {
                    [d0, v(s1, m1), v(s2, m2)]
                } else {
                    [d0, 0, 0]
                };
                word::<C>(n, dn)
            }
            // Three sums below 2^32 (no channel saturated), tested once:
            // spheres-specular 4.4 M3 instructions a pixel fewer (on the
            // M0 1.7 more: not there).
            None if C == 3 && !ARMV6M && (sum[0] | sum[1] | sum[2]) >> 32 == 0 => word::<C>(
                n,
                zip3(sum, dn_max, |s, max| vignette_dn_lo(s as u32, c4, max as u32)),
            ),
            None => word::<C>(n, zip3(sum, dn_max, |s, max| vignette_dn(s, c4, max as u32))),
        }
    }

    /// A ray's (in the field) sum before vignetting (S15 DN, capped) and
    /// its `cos⁴α` (S31; [`Mix32::c4`]).
    #[inline(always)]
    fn radiance<L: Lines, const C: usize, const PERSP: bool, const KEPT: bool>(
        &self,
        r: &Ray,
        k: &mut KCache,
        key: Option<Key>,
    ) -> ([u64; 3], u32) {
        let c4 = self.c4::<KEPT>(r);
        let sum = match self.hit_from::<L, C, PERSP, false>(r, [[0; 2]; 2], key) {
            Some(h) => self.shade_flat::<L, C, PERSP>(r, &h, k),
            None => copy3!(self.bg),
        };
        (sum, c4)
    }

    /// The channels a loop for `C` computes for this frame ([`chans`]).
    #[inline(always)]
    fn chans<const C: usize>(&self) -> usize {
        chans::<C>(self.nch())
    }

    /// The frame's channels where a loop takes them at run time (a
    /// `compact` build's: [`chans`]); elsewhere 0, which no loop reads (its
    /// `C` says): no code.
    #[inline(always)]
    fn nch(&self) -> usize {
        if cfg!(feature = "compact") {
            self.format.channels()
        } else {
            0
        }
    }

    /// A shaded ray's `cos⁴α` (S31): if `KEPT` (always in the one-sample
    /// loop, [`KEEP_C4_SAMPLED`] in the others), as [`fill_rays`] set it.
    #[inline(always)]
    fn c4<const KEPT: bool>(&self, r: &Ray) -> u32 {
        if KEPT {
            r.c4
        } else if self.vignetting {
            cos4(r.ra)
        } else {
            1 << 31
        }
    }

    /// The material ray `r` sees at its hit on `p` (its point `pt`, `[0;
    /// 3]` where [`Mix32::hit_from`] takes none; the frame moved to `a` if
    /// `MOVED`): `p`'s, or its checker's on the odd cells (from `key`
    /// where the caller knows the cell).
    #[inline(always)]
    fn material_at<const PERSP: bool, const MOVED: bool>(
        p: &MixPrim,
        r: &Ray,
        pt: [i32; 3],
        a: [i32; 2],
        key: Option<Key>,
    ) -> usize {
        let mut m = p.material as usize;
        if let Some(k) = &p.checker {
            let odd = match key {
                Some(key) => key.odd(),
                None => {
                    // (The aperture loop's rays start off the axis.)
                    let bounded = p.shape.bounded();
                    let (cu, cv) = match (PERSP, MOVED) {
                        (true, false) => k.cells_of::<PERSP>(r, bounded),
                        (true, true) => k.cells::<PERSP>(r.hit_point::<PERSP, MOVED>(a), bounded),
                        // (A parallel ray's point is its origin and `t`.)
                        (false, _) => k.cells::<PERSP>(pt, bounded),
                    };
                    // The parity of cu + cv.
                    (cu ^ cv) & 1 != 0
                }
            };
            if odd {
                m = k.material as usize;
            }
        }
        m
    }

    /// The nearest hit of a ray after every primitive's pass; if `MOVED`,
    /// for a ray traced in the frame moved to
    /// `(a_x, a_y, 0)` (`a` in S18 U, `a24` in S24 U, as
    /// [`MixShape::moved`] takes them): the hit point moved back, the rest
    /// in the camera frame. (`MOVED` a constant: `hit` as
    /// this with `a = 0` at run time cost the M4F's standard scene 7
    /// instructions a pixel.) With `key`, the ray's [`Key`] as
    /// [`Mix32::key`] found it: a checker's material from its cell's parity.
    #[inline(always)]
    fn hit_from<L: Lines, const C: usize, const PERSP: bool, const MOVED: bool>(
        &self,
        r: &Ray,
        [a, a24]: [[i32; 2]; 2],
        key: Option<Key>,
    ) -> Option<Hit<'_>> {
        if r.t == NO_HIT {
            return None;
        }
        let p = self.prims.get((r.hit & !AWAY) as usize)?;
        let away = r.hit & AWAY != 0;
        // The point, where a sphere's normal or a point light's term takes
        // it: a flat primitive ([`MixPrim::flat`]: directional lights
        // alone) needs none.
        let pt = if PERSP && p.flat {
            [0; 3]
        } else {
            r.hit_point::<PERSP, MOVED>(a)
        };
        let mut view = None;
        let n = match &p.shape {
            MixShape::Plane { n, .. } | MixShape::Disc { n, .. } | MixShape::Rect { n, .. } => *n,
            // Under a specular lobe, whose exponent multiplies the normal's
            // error, from the ray and the sphere (the centre from the
            // ray's origin).
            MixShape::Sphere {
                c,
                r24,
                inv_r,
                fine: true,
                ..
            } if lobe_built::<L, C>() => {
                // The centre the pass took ([`MixShape::moved`]).
                let c = if MOVED { moved_point(*c, a24) } else { *c };
                let (n, v) = fine_normal::<PERSP, MOVED>(r, c, *r24, *inv_r, away);
                // (Not kept in a `compact` build, whose loops measured more
                // with it: shallow-target 270.3 → 286.9 M3 instructions a
                // pixel, shallow-dof 13 653 → 13 914.)
                view = (!cfg!(feature = "compact")).then_some(v);
                n
            }
            // A point of the sphere: `|p − c|` is `r` within the hit's
            // error (`r` ≥ 2⁻¹⁰ U, [`recip_len`]; the point within 2⁻¹⁶ U:
            // below 1.02 r), so each component, S30, is below 2³¹ and the
            // low word of the shifted product (and `p − c`, both within
            // 8 U) needs no saturation. The same values. (`inv_r`'s shift
            // is 9 to 26: [`recip_len`] normalizes 2⁵⁴/s, s in [2¹⁴, 2³¹),
            // to 32 bits from 24 to 41.)
            MixShape::Sphere { c18, inv_r, .. } => zip3(pt, *c18, |p, c| {
                sar64_low_lt32(smul_u(p.wrapping_sub(c), inv_r.0), inv_r.1)
            }),
        };
        let m = Self::material_at::<PERSP, MOVED>(p, r, pt, a, key);
        Some(Hit {
            m,
            pt,
            n,
            away,
            nl: &p.nl,
            flat: p.flat,
            view,
        })
    }

    /// The unit direction from a ray's hit towards the viewer, S30:
    /// `−(x̂, ŷ, 1)/√a` (perspective) or `(0, 0, −1)` (parallel rays).
    #[inline(always)]
    fn view<const PERSP: bool>(r: &Ray) -> [i32; 3] {
        if !PERSP {
            return [0, 0, -(1 << 30)];
        }
        // a S20 = m 2^-z; 1/√a = y 2^((z − 44)/2) in S30 (z ≤ 42: a ≥ 1).
        // (The shift is below 32 — a ≤ 513 in S20, so z ≥ 34 — but its
        // word form here, [`sar64_low_lt32`], measured the M3's
        // spheres-specular 445.9 → 447.1 a pixel, the M4F's 435.3 → 431.3.)
        let (y, z) = rsqrt_fine(r.a as u64);
        let sh = 26 + (44 - z.min(44)) / 2;
        [
            -(sar64(smul_u(r.x, y), sh) as i32),
            -(sar64(smul_u(r.y, y), sh) as i32),
            -((y >> ((44 - z.min(44)) / 2)) as i32),
        ]
    }

    /// Whether a hit's sum depends on its primitive, side and material
    /// alone ([`Mix32::shade_flat`] keeps it): a flat primitive's
    /// ([`MixPrim::flat`]) whose material `m` has no lobe rendered. (In a
    /// `compact` build too, since the aperture loop's copies of `shade`
    /// are one call, [`Mix32::shade_flat_ap`]: before, the copies cost
    /// 21 KB of the M3 camera's flash and were left out, its frames
    /// dearer — shallow-dof 13 448 against 8 303 instructions a pixel.)
    #[inline(always)]
    fn flat_sum<L: Lines, const C: usize>(&self, flat: bool, m: usize) -> bool {
        let lobe = lobe_built::<L, C>() && self.lobe.get(m).is_none_or(Option::is_some);
        flat && !lobe
    }

    /// [`Mix32::shade`], kept for the next hit where it cannot change: on a
    /// [`MixPrim::flat`] primitive (a constant normal, every light
    /// directional), of a material without a rendered lobe, the sum depends
    /// on the primitive, its side and the material alone — [`Ray::hit`]
    /// and [`Hit::m`], the key it is kept under. The same sums.
    #[inline(always)]
    fn shade_flat<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        h: &Hit,
        k: &mut KCache,
    ) -> [u64; 3] {
        if !self.flat_sum::<L, C>(h.flat, h.m) {
            return self.shade::<L, C, PERSP>(r, h, k);
        }
        if k.flat != (r.hit, h.m) {
            k.flat_sum = self.shade::<L, C, PERSP>(r, h, k);
            k.flat = (r.hit, h.m);
        }
        copy3!(k.flat_sum)
    }

    /// The ambient, Lambertian and (for a material with a lobe) specular
    /// terms of every light, before vignetting: S15 DN, capped at
    /// [`SUM_CAP`].
    #[inline(always)]
    fn shade<L: Lines, const C: usize, const PERSP: bool>(
        &self,
        r: &Ray,
        h: &Hit,
        k: &mut KCache,
    ) -> [u64; 3] {
        let Hit {
            m,
            pt,
            n,
            away,
            nl: nls,
            view: kept,
            ..
        } = *h;
        let nch = self.nch();
        let channels = chans::<C>(nch);
        if k.material != m {
            let (Some(kd), Some(&ka), Some(ks), Some(&lobe)) =
                (self.kd.get(m), self.ka.get(m), self.ks.get(m), self.lobe.get(m))
            else {
                return [0; 3];
            };
            k.material = m;
            k.ka = ka;
            k.lobe = lobe;
            k.below = self.lobe_below.get(m).copied().unwrap_or(0);
            for ((kl, (ksl, top)), l) in k.k.iter_mut().zip(k.ks.iter_mut()).zip(&self.lights) {
                let e = match l {
                    MixLight::Point { i, .. } => i,
                    MixLight::Directional { e, .. } => e,
                };
                for (((kc, ksc), (d, s)), e) in kl
                    .iter_mut()
                    .zip(ksl.iter_mut())
                    .zip(kd.iter().zip(ks))
                    .zip(e)
                    .take(channels)
                {
                    *kc = *d * *e;
                    *ksc = *s * *e;
                }
                *top = ksl.iter().take(channels).map(|p| p.e).max().unwrap_or(0);
            }
        }
        // The normal turned towards the viewer, and the view direction, for
        // the lobe.
        let nt = if away { n.map(i32::saturating_neg) } else { n };
        // The lobe, if this build's loop for `C` channels has it (a frame
        // with one is refused by a build without: `Frame::line_built`).
        let lobe = if lobe_built::<L, C>() { k.lobe } else { None };
        let view = lobe.map(|_| kept.unwrap_or_else(|| Self::view::<PERSP>(r)));
        let mut sum = copy3!(k.ka);
        for (((l, kl), (ksl, top)), &nl) in self.lights.iter().zip(&k.k).zip(&k.ks).zip(nls) {
            let (w, ldir) = match l {
                MixLight::Point { p, .. } => {
                    let lv = zip3(*p, pt, i32::saturating_sub);
                    // n·l, S48 U: the plane's constant, or from the hit.
                    let nl = match (nl, away) {
                        (0, _) => wmul_px(nt[0], lv[0]) + wmul_px(nt[1], lv[1]) + wmul_px(nt[2], lv[2]),
                        (c, false) => c,
                        (c, true) => -c,
                    };
                    if nl <= 0 {
                        continue;
                    }
                    // r², S36 U², exact (> 0: n·l is).
                    let r2 = wsq(lv[0]) + wsq(lv[1]) + wsq(lv[2]);
                    let (_, y, z) = rsqrt_norm(r2);
                    // l̂ = l/r in S30 (only for the lobe): 1/r = y 2^((z − 28)/2)
                    // with lv in S18.
                    let ldir = view.map(|_| {
                        let (y, z) = rsqrt_refine(r2, y, z);
                        map3(lv, |c| sar64_low(smul_u(c, y), 32 - z / 2))
                    });
                    (cos_over_r3(nl as u64, y, z), ldir)
                }
                MixLight::Directional { l, .. } => {
                    let Some(w) = directional_w(nt, *l) else {
                        continue;
                    };
                    (w, Some(*l))
                }
            };
            each::<C>(nch, |c| {
                if let (Some(s), Some(k)) = (sum.get_mut(c), kl.get(c)) {
                    *s = (*s + k.mul_to_sum(w, 15)).min(SUM_CAP);
                }
            });
            if let (Some(s), Some(v), Some(ld)) = (lobe, view, ldir) {
                // r̂·v̂ = 2 (n̂·l̂)(n̂·v̂) − l̂·v̂, S30.
                let (nl, nv) = (dot30(nt, ld), dot30(nt, v));
                // (2 nl nv) >> 30 as (nl nv) >> 29: a 32 × 32-bit product
                // (as i64s, a library call on the M0).
                let rv = sat32((wmul_px(nl, nv) >> 29) - dot30(ld, v) as i64);
                // Below `below` the lobe is at most 2⁻⁶⁴ (0 at and below
                // 0), and with `ks E w` under 2⁴⁹ DN (its exponents' sum
                // at most −15: each mantissa is below 2³²) its term is
                // below 2⁻¹⁵ DN, which `mul_to_sum` floors to 0: the same
                // sum without the powers.
                if rv < k.below && *top + w.e <= -15 {
                    continue;
                }
                let f = lobe_pf(rv, s);
                each::<C>(nch, |c| {
                    if let (Some(s), Some(k)) = (sum.get_mut(c), ksl.get(c)) {
                        *s = (*s + (*k * f).mul_to_sum(w, 15)).min(SUM_CAP);
                    }
                });
            }
        }
        copy3!(sum)
    }
}
