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
//! with pixel-area sampling, and scenes outside the formats are refused by
//! one rule (`prepare::layout` and `prims_fit`, reasons [`crate::render::Unfit`]), which
//! the planner asks of each fast candidate and the preparation follows
//! ([`crate::render::RenderError::OutsideFormat`]); the wide arithmetic
//! renders them. Accuracy and cost: `host-sim tradeoff`
//! (`mix32-poly`).
//!
//! Modules by stage: `rays` (slopes, undistortion, `cos⁴α`), `intersect`
//! (a primitive's pass), `closed` (the plane in closed form), `shade`,
//! `expose` (DN, noise, the pixel's bytes), `sampled` (pixel-area
//! sampling), `aperture` (defocus); `arith` holds the formats' products,
//! reciprocals and square roots; `prepare` fills the frame's state
//! ([`Mix32`], declared here) once a frame, and `line` holds the
//! one-sample line loop and the per-pixel steps the other loops share.

use crate::num::clz64;
use crate::render::sensor::sampling::Corners;
use crate::render::shading::V3;
use crate::render::{ClosedMean, Lines, RenderError};
use crate::scene::{PixelFormat, Q};
use core::num::NonZeroU64;

mod aperture;
mod arith;
mod closed;
mod expose;
mod intersect;
mod line;
mod prepare;
mod rays;
mod sampled;
mod shade;
mod shadow;
#[cfg(test)]
mod tests;

pub use aperture::ApertureClasses;
pub(crate) use arith::Pf;
use arith::*;
use intersect::*;
pub(crate) use prepare::fits;
pub use rays::ChunkBufs;

/// What a frame's lines, rendered in order, pass from one to the next
/// ([`crate::render::Frame::render`] holds one a frame): the sampled loop's corner keys and, with the fast arithmetic,
/// its chunk buffers ([`ChunkBufs`]).
#[derive(Debug)]
pub(crate) struct Carry<'a> {
    pub(crate) corners: Corners<'a>,
    pub(crate) chunk: ChunkBufs,
}

impl<'a> Carry<'a> {
    /// A carry for a new frame, with `keys` for the corner keys
    /// ([`Corners::new`]).
    pub(crate) fn new(keys: &'a mut [u64]) -> Carry<'a> {
        Carry {
            corners: Corners::new(keys),
            chunk: ChunkBufs::EMPTY,
        }
    }
}

/// Whether `L`'s fast loops for `C` channels render the specular lobe
/// ([`Lines::FAST_GRAY_SPECULAR`], [`Lines::FAST_RGB_SPECULAR`]); in a
/// `compact` build, whose loop for three channels serves one-channel
/// frames too ([`chans`]), if either does (a frame whose lobe `L` leaves
/// out is refused before it reaches a loop: `Frame::line_built`).
const fn lobe_built<L: Lines, const C: usize>() -> bool {
    if crate::target::COMPACT {
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
    if crate::target::COMPACT {
        if n < C {
            n
        } else {
            C
        }
    } else {
        C
    }
}

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
    /// The lights shadowed here where the caller's [`Key`](rays::Key)
    /// found them already (the adaptive rule's centre sample).
    #[cfg(feature = "shadows")]
    shade: Option<u8>,
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
    /// 128-bit one, which the M3 builds of more (per chunk and point). The
    /// same value (`tests`).
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
    /// With distortion, the `e` of `2^e`, a bound of its area factor `J`
    /// over the field (camera-model.md §5): the gain carries `2^e` and a
    /// shaded ray's [`Ray::c4`] `J/2^e` ([`undistort_kj`]), so that
    /// `cos⁴α J/2^e` keeps `cos⁴α`'s S31.
    area: Option<u32>,
    /// A loop that does not keep [`Ray::c4`] computes `cos⁴α` from the
    /// ray's `1/a` ([`Mix32::c4`]): the frame vignettes and is not
    /// distorted (a distorted frame's shaded rays keep it, with `J`).
    cos4_of_ra: bool,
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
    /// Cast shadows, if some surface takes a test.
    #[cfg(feature = "shadows")]
    shadow: Option<shadow::Shadow>,
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
    /// The options ask for a distortion table ([`Unfit::Table`]).
    pub table: bool,
    pub vignetting: bool,
    /// The distortion's area factor ([`Mix32::area`]).
    pub relative_illumination: bool,
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
    /// The shadow tests each surface takes under each light.
    pub occluders: crate::render::shadows::Occluders,
}
