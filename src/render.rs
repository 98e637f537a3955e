//! The line renderer (camera-model.md §3, §5, §6, §7, §9).
//!
//! One ray per pixel centre — or, where the scene asks for pixel-area
//! integration, the mean of an `n×n` grid over the pixel's square
//! ([`crate::sampling`]) — then, where it asks for sensor noise, the EMVA
//! 1288 stage ([`crate::noise`]); fixed point end to end, one scanline at a time
//! into the place a [`FrameSink`] holds for it (a link encoder's chunk) or
//! else a caller-provided line buffer handed to the sink: RAM is O(width),
//! whatever the height.
//!
//! A [`Frame`] is prepared once per frame: the scene is moved into the camera
//! frame, the distortion table built, constants folded, each bounded
//! primitive's slope-space bounds computed. The per-pixel arithmetic is the
//! planner's choice ([`Options::arithmetic`]): the fast one
//! ([`crate::mix32`], 32-bit with a format per quantity, lines in chunks of
//! 32 rays), or the wide one here, generic over a [`Scalar`] — I32F32
//! ([`Q`]) for the planner's fallback, `f32` for comparison
//! ([`Frame::build`]). The wide one runs one of two pixel loops
//! (perspective or parallel rays), and the stages the scene may not need
//! (distortion, specular, vignetting) are per-frame flags: a branch that
//! goes the same way for the whole frame. Arithmetic saturates: nothing
//! wraps, and a value that saturates ends as a saturated pixel. Scene
//! ranges ([`crate::scene`]) keep valid scenes clear of saturation in
//! I32F32 except where the physics says so (over-exposure); what the fast
//! formats cannot hold the planner does not send them.

use crate::distortion::{Lut, MAX_LUT};
use crate::num::{quotient, FixedF64, Len, Norm, Wide};
use crate::sampling::Corners;
use crate::scalar::Scalar;
use crate::scene::{Light, PixelFormat, Primitive, Scene, Shape, Q};
use crate::shading::{axpy, dot, dot_k, from_q3, scale3, sub3, Brdf, ShadingLight, V3};
use crate::vignetting;
use core::ops::{Add as _, Mul as _};
use fixed::types::I64F64;

/// Flag bit: the pixel lies beyond the fold radius, outside the lens field
/// (its value is 0).
pub const FLAG_OUTSIDE_FIELD: u8 = 1;

/// The largest `|x̂|, |ŷ|` (undistorted) the renderer supports: 16, a
/// half-angle of 86.4°.
pub const MAX_SLOPE: i32 = 16;

/// What a [`FrameSink`] is told when a frame begins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameInfo {
    /// Width, pixels.
    pub width: u16,
    /// Height, pixels (lines).
    pub height: u16,
    /// Pixel format.
    pub format: PixelFormat,
}

/// What a frame's lines, rendered in order, pass from one to the next
/// ([`Frame::render_line_in`]; [`Frame::render_carried`] holds one a
/// frame): the sampled loop's corner keys and, with the fast arithmetic,
/// its chunk buffers ([`crate::mix32::ChunkBufs`]).
#[derive(Debug)]
pub struct Carry<'a> {
    // (Read by the fast arithmetic's sampled loop alone.)
    #[cfg_attr(not(feature = "mix32"), allow(dead_code))]
    pub(crate) corners: Corners<'a>,
    #[cfg(feature = "mix32")]
    pub(crate) chunk: crate::mix32::ChunkBufs,
}

impl<'a> Carry<'a> {
    /// A carry for a new frame, with `keys` for the corner keys
    /// ([`Corners::new`]).
    pub fn new(keys: &'a mut [u64]) -> Carry<'a> {
        Carry {
            corners: Corners::new(keys),
            #[cfg(feature = "mix32")]
            chunk: crate::mix32::ChunkBufs::EMPTY,
        }
    }
}

/// Receives a rendered frame: [`FrameSink::begin`], every line in order,
/// [`FrameSink::end`]. The link's [`crate::link::Stream`], the host's
/// collectors and the timing adapter [`Timed`] are sinks.
pub trait FrameSink {
    /// The sink's error.
    type Error;
    /// The frame begins.
    fn begin(&mut self, _info: &FrameInfo) -> Result<(), Self::Error> {
        Ok(())
    }
    /// Line `y`: `pixels` holds `width × bytes_per_pixel` bytes, `flags` one
    /// byte of `FLAG_*` bits a pixel.
    fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error>;
    /// Where line `y` (`len` bytes) is to be rendered if the sink holds
    /// that place itself (a link encoder's chunk: the line is then not
    /// copied, and [`FrameSink::placed`] follows instead of
    /// [`FrameSink::line`]); `None` (the default): in the caller's buffer.
    fn place(&mut self, _y: u16, _len: usize) -> Result<Option<&mut [u8]>, Self::Error> {
        Ok(None)
    }
    /// Line `y` was rendered where [`FrameSink::place`] said; `flags` as
    /// for [`FrameSink::line`]. A sink that places lines implements this
    /// (the default does nothing with them).
    fn placed(&mut self, _y: u16, _flags: &[u8]) -> Result<(), Self::Error> {
        Ok(())
    }
    /// The frame ends; `cost` is what rendering it cost when an adapter
    /// ([`Timed`]) measured it.
    fn end(&mut self, _cost: Option<u64>) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// A timing adapter: measures the renderer, not the sink. The time spent
/// between the inner sink's calls (plus `already`, e.g. the frame's
/// preparation), converted by `to_cost`, is passed to the inner sink's
/// [`FrameSink::end`] as the frame's cost — so a slow link's back-pressure
/// is not counted. Between [`FrameSink::placed`] and the next call
/// nothing is rendered: that gap is not timed, so a placed line costs two
/// clock reads, as a copied one does.
pub struct Timed<K, C, T> {
    /// The sink timed.
    pub inner: K,
    clock: C,
    to_cost: T,
    spent: u64,
    /// The clock when the inner sink last returned, if the time since is
    /// the renderer's.
    last: Option<u64>,
}

impl<K: FrameSink, C: FnMut() -> u64, T: Fn(u64) -> u64> Timed<K, C, T> {
    /// Starts timing now; `already` clock ticks are counted in.
    pub fn new(inner: K, mut clock: C, to_cost: T, already: u64) -> Self {
        let last = Some(clock());
        Timed {
            inner,
            clock,
            to_cost,
            spent: already,
            last,
        }
    }

    /// The cost so far (`to_cost` of the ticks counted).
    pub fn cost(&self) -> u64 {
        (self.to_cost)(self.spent)
    }

    fn lap(&mut self) {
        if let Some(last) = self.last {
            let now = (self.clock)();
            self.spent = self.spent.wrapping_add(now.wrapping_sub(last));
        }
    }
}

impl<K: FrameSink, C: FnMut() -> u64, T: Fn(u64) -> u64> FrameSink for Timed<K, C, T> {
    type Error = K::Error;
    fn begin(&mut self, info: &FrameInfo) -> Result<(), Self::Error> {
        self.lap();
        let r = self.inner.begin(info);
        self.last = Some((self.clock)());
        r
    }
    fn line(&mut self, y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error> {
        self.lap();
        let r = self.inner.line(y, pixels, flags);
        self.last = Some((self.clock)());
        r
    }
    fn place(&mut self, y: u16, len: usize) -> Result<Option<&mut [u8]>, Self::Error> {
        self.lap();
        let r = self.inner.place(y, len);
        self.last = Some((self.clock)());
        r
    }
    fn placed(&mut self, y: u16, flags: &[u8]) -> Result<(), Self::Error> {
        self.lap();
        // Until the next place (or the end): not the renderer's time.
        self.last = None;
        self.inner.placed(y, flags)
    }
    fn end(&mut self, _cost: Option<u64>) -> Result<(), Self::Error> {
        self.lap();
        let cost = self.cost();
        let r = self.inner.end(Some(cost));
        self.last = Some((self.clock)());
        r
    }
}

/// How the renderer forms rays (chosen by the planner; may approximate the
/// camera's model).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderModel {
    /// Rays from the centre of projection.
    Perspective,
    /// Parallel rays from `(x̂ Z̄, ŷ Z̄, 0)`.
    WeakPerspective {
        /// `Z̄`, metres.
        mean_depth: Len,
    },
    /// Parallel rays from `(x/m, y/m, 0)`.
    Orthographic {
        /// `m`.
        scale: Norm,
    },
}

impl RenderModel {
    /// Stage name.
    pub const fn name(&self) -> &'static str {
        match self {
            RenderModel::Perspective => "rays:perspective",
            RenderModel::WeakPerspective { .. } => "rays:weak-perspective",
            RenderModel::Orthographic { .. } => "rays:orthographic",
        }
    }

    /// Perspective rays in place of weak-perspective ones (a telecentric
    /// camera's stay parallel).
    pub const fn exact(self) -> RenderModel {
        match self {
            RenderModel::WeakPerspective { .. } => RenderModel::Perspective,
            m => m,
        }
    }
}

/// How `g(u)` (distorted → undistorted, camera-model.md §3) is evaluated per
/// pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DistortionEval {
    /// The table entry nearest to `u` (error up to `|g'| h / 2`).
    Nearest,
    /// Linear interpolation between table entries (error up to `|k2| h²/4`).
    Linear,
    /// The polynomial `1 + u (k1 + k2 u)` itself: no table.
    Polynomial,
}

impl DistortionEval {
    /// Stage name.
    pub const fn name(&self) -> &'static str {
        match self {
            DistortionEval::Nearest => "distortion-lut-nearest",
            DistortionEval::Linear => "distortion-lut",
            DistortionEval::Polynomial => "distortion-polynomial",
        }
    }
}

/// The line loops a renderer is compiled with: one per arithmetic, ray
/// model and (fast arithmetic) channel count. A loop whose constant is
/// `false` is left out of the build, and a frame that needs it is refused
/// ([`RenderError::NotBuilt`]). A firmware whose scenes are planned at build
/// time lists the loops their plans use (`firmware/build.rs`); everything
/// else renders with [`AllLines`].
pub trait Lines {
    /// Fast arithmetic, one channel (Gray8, Gray16), perspective rays.
    const FAST_GRAY_PERSPECTIVE: bool = true;
    /// Fast arithmetic, RGB565, perspective rays.
    const FAST_RGB_PERSPECTIVE: bool = true;
    /// Fast arithmetic, one channel, parallel rays (weak perspective,
    /// orthographic).
    const FAST_GRAY_PARALLEL: bool = true;
    /// Fast arithmetic, RGB565, parallel rays.
    const FAST_RGB_PARALLEL: bool = true;
    /// The four fast loops above with pixel-area sampling
    /// ([`crate::sampling`]).
    const FAST_GRAY_PERSPECTIVE_SAMPLED: bool = true;
    /// RGB565, perspective rays, sampled.
    const FAST_RGB_PERSPECTIVE_SAMPLED: bool = true;
    /// One channel, parallel rays, sampled.
    const FAST_GRAY_PARALLEL_SAMPLED: bool = true;
    /// RGB565, parallel rays, sampled.
    const FAST_RGB_PARALLEL_SAMPLED: bool = true;
    /// Fast arithmetic, one channel, through the aperture (defocus; pixel
    /// centres, perspective rays).
    const FAST_GRAY_APERTURE: bool = true;
    /// RGB565 through the aperture.
    const FAST_RGB_APERTURE: bool = true;
    /// Wide arithmetic, perspective rays (defocus's aperture rays too).
    const WIDE_PERSPECTIVE: bool = true;
    /// Wide arithmetic, parallel rays.
    const WIDE_PARALLEL: bool = true;
    /// The fast loops' specular lobe, for one channel and for RGB565: left
    /// out where no frame the build renders needs it (a frame that does is
    /// refused like a left-out loop).
    const FAST_GRAY_SPECULAR: bool = true;
    /// RGB565's lobe.
    const FAST_RGB_SPECULAR: bool = true;
    /// The wide loops' stages, each left out where no frame the build
    /// renders needs it (a frame that does is refused like a left-out
    /// loop): pixel-area sampling ([`crate::sampling`]),
    const WIDE_SAMPLED: bool = true;
    /// the aperture's rays (defocus, [`crate::defocus`]),
    const WIDE_APERTURE: bool = true;
    /// and the specular lobe.
    const WIDE_SPECULAR: bool = true;
    /// The sampled fast loops carry their corner keys from line to line
    /// ([`crate::sampling::Corners`]); without, they trace both rows of
    /// corners a line whatever the caller passes (less code).
    const CARRY_CORNERS: bool = true;
}

/// Every line loop.
pub struct AllLines;

impl Lines for AllLines {}

/// Every line loop the planner picks, the sampled ones without the corner
/// carry (the driven camera's build, which holds no keys: its flash and RAM
/// are spoken for). (Until the fast aperture loops were planned, it left
/// them out: they took the camera's flash from 222 704 to 238 292 B on the
/// M3, 226 116 to 244 920 B on the M0.)
pub struct PlannedLines;

impl Lines for PlannedLines {
    const CARRY_CORNERS: bool = false;
}

/// A line loop: the arithmetic, the rays and, for the fast arithmetic, the
/// channels ([`Lines`] has a constant for each).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LineLoop {
    /// [`Lines::FAST_GRAY_PERSPECTIVE`].
    FastGrayPerspective,
    /// [`Lines::FAST_RGB_PERSPECTIVE`].
    FastRgbPerspective,
    /// [`Lines::FAST_GRAY_PARALLEL`].
    FastGrayParallel,
    /// [`Lines::FAST_RGB_PARALLEL`].
    FastRgbParallel,
    /// [`Lines::FAST_GRAY_PERSPECTIVE_SAMPLED`].
    FastGrayPerspectiveSampled,
    /// [`Lines::FAST_RGB_PERSPECTIVE_SAMPLED`].
    FastRgbPerspectiveSampled,
    /// [`Lines::FAST_GRAY_PARALLEL_SAMPLED`].
    FastGrayParallelSampled,
    /// [`Lines::FAST_RGB_PARALLEL_SAMPLED`].
    FastRgbParallelSampled,
    /// [`Lines::FAST_GRAY_APERTURE`].
    FastGrayAperture,
    /// [`Lines::FAST_RGB_APERTURE`].
    FastRgbAperture,
    /// [`Lines::WIDE_PERSPECTIVE`].
    WidePerspective,
    /// [`Lines::WIDE_PARALLEL`].
    WideParallel,
}

impl LineLoop {
    /// Every loop.
    pub const ALL: [LineLoop; 12] = [
        LineLoop::FastGrayPerspective,
        LineLoop::FastRgbPerspective,
        LineLoop::FastGrayParallel,
        LineLoop::FastRgbParallel,
        LineLoop::FastGrayPerspectiveSampled,
        LineLoop::FastRgbPerspectiveSampled,
        LineLoop::FastGrayParallelSampled,
        LineLoop::FastRgbParallelSampled,
        LineLoop::FastGrayAperture,
        LineLoop::FastRgbAperture,
        LineLoop::WidePerspective,
        LineLoop::WideParallel,
    ];

    /// Whether `L` compiles it in.
    pub const fn built<L: Lines>(self) -> bool {
        match self {
            LineLoop::FastGrayPerspective => L::FAST_GRAY_PERSPECTIVE,
            LineLoop::FastRgbPerspective => L::FAST_RGB_PERSPECTIVE,
            LineLoop::FastGrayParallel => L::FAST_GRAY_PARALLEL,
            LineLoop::FastRgbParallel => L::FAST_RGB_PARALLEL,
            LineLoop::FastGrayPerspectiveSampled => L::FAST_GRAY_PERSPECTIVE_SAMPLED,
            LineLoop::FastRgbPerspectiveSampled => L::FAST_RGB_PERSPECTIVE_SAMPLED,
            LineLoop::FastGrayParallelSampled => L::FAST_GRAY_PARALLEL_SAMPLED,
            LineLoop::FastRgbParallelSampled => L::FAST_RGB_PARALLEL_SAMPLED,
            LineLoop::FastGrayAperture => L::FAST_GRAY_APERTURE,
            LineLoop::FastRgbAperture => L::FAST_RGB_APERTURE,
            LineLoop::WidePerspective => L::WIDE_PERSPECTIVE,
            LineLoop::WideParallel => L::WIDE_PARALLEL,
        }
    }

    /// The name of its [`Lines`] constant (for code that lists a build's
    /// loops, `firmware/build.rs`).
    pub const fn constant(self) -> &'static str {
        match self {
            LineLoop::FastGrayPerspective => "FAST_GRAY_PERSPECTIVE",
            LineLoop::FastRgbPerspective => "FAST_RGB_PERSPECTIVE",
            LineLoop::FastGrayParallel => "FAST_GRAY_PARALLEL",
            LineLoop::FastRgbParallel => "FAST_RGB_PARALLEL",
            LineLoop::FastGrayPerspectiveSampled => "FAST_GRAY_PERSPECTIVE_SAMPLED",
            LineLoop::FastRgbPerspectiveSampled => "FAST_RGB_PERSPECTIVE_SAMPLED",
            LineLoop::FastGrayParallelSampled => "FAST_GRAY_PARALLEL_SAMPLED",
            LineLoop::FastRgbParallelSampled => "FAST_RGB_PARALLEL_SAMPLED",
            LineLoop::FastGrayAperture => "FAST_GRAY_APERTURE",
            LineLoop::FastRgbAperture => "FAST_RGB_APERTURE",
            LineLoop::WidePerspective => "WIDE_PERSPECTIVE",
            LineLoop::WideParallel => "WIDE_PARALLEL",
        }
    }
}

/// What the renderer is told to do (the planner's choice).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// Ray model.
    pub model: RenderModel,
    /// Distortion table entries (2 to [`MAX_LUT`]; ignored without
    /// distortion or with [`DistortionEval::Polynomial`]).
    pub lut_entries: usize,
    /// How `g(u)` is evaluated.
    pub distortion_eval: DistortionEval,
    /// Runs the distortion and specular stages even when the scene makes
    /// them identities (`k1 = k2 = 0`, no specular material): the renderer
    /// without the planner's pruning, for measuring what the pruning saves.
    pub keep_all_stages: bool,
    /// The per-pixel arithmetic.
    pub arithmetic: Arithmetic,
    /// Pixel-area integration: the side `n` of the `n×n` sample grid
    /// ([`crate::sampling`]; 1, 2, 4, 8 or 16; 1 is the centre alone).
    pub samples: u8,
    /// The grid only where a pixel's corners and centre disagree
    /// ([`crate::sampling`]'s adaptive rule).
    pub adaptive: bool,
    /// Defocus: points of the aperture pattern a sample is lit through
    /// ([`crate::defocus`]; 16, 64 or 256, perspective rays only); 0: the
    /// chief ray alone (a pinhole).
    pub aperture: u16,
    /// The fast one-sample loop's plane in closed form: in a chunk of rays
    /// that all see it, under one point light, the rays between those
    /// shaded take interpolated sums ([`ClosedMean`]; the planner's error
    /// bound, `planner::closed_mean_err`, within the budget).
    pub closed_mean: ClosedMean,
}

/// How the closed plane's sums are interpolated along a row
/// ([`Options::closed_mean`]), in a chunk of rays that all see the plane
/// under one point light. Each step is a mean of two sums, rounded down.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClosedMean {
    /// Every ray shaded with its own light term.
    #[default]
    Off,
    /// The even rays shaded, the odd ones their neighbours' mean: a
    /// linear interpolation over 2 rays.
    Pairs,
    /// Every fourth ray shaded (and the last two), the rays `≡ 2 (mod 4)`
    /// the mean of theirs 2 apart, then the odd ones their neighbours':
    /// a linear interpolation over 4 rays, whose error bound is 4 times
    /// the pairs' (`planner::closed_mean_factor`).
    Quads,
    /// Every eighth ray shaded (and the last two, and a ray `≡ 4 (mod 8)`
    /// within 4 of the last even one), the other rays `≡ 4 (mod 8)` the
    /// mean of theirs 4 apart, then as [`ClosedMean::Quads`]: over 8 rays,
    /// 16 times the pairs' bound.
    Octs,
}

impl ClosedMean {
    /// Rays from one shaded ray to the next (1: every ray shaded).
    #[inline(always)]
    pub const fn span(self) -> u32 {
        match self {
            ClosedMean::Off => 1,
            ClosedMean::Pairs => 2,
            ClosedMean::Quads => 4,
            ClosedMean::Octs => 8,
        }
    }

    /// Whether any ray takes an interpolated sum.
    pub const fn on(self) -> bool {
        !matches!(self, ClosedMean::Off)
    }

    /// The ray shaded after ray `q` of a run of `len` rays that all see the
    /// plane: every [`ClosedMean::span`]-th up to the last even ray, then
    /// the last ray (the rays between take interpolated sums). With
    /// [`ClosedMean::Octs`], a ray `≡ 4 (mod 8)` whose ray 4 on lies past
    /// the last even one is shaded too (the rays 2 apart take its sum).
    pub const fn next_shaded(self, q: usize, len: usize) -> usize {
        let last_even = len.saturating_sub(1) & !1;
        let span = self.span() as usize;
        if q < last_even {
            let next = q + span;
            if next < last_even {
                next
            } else if span == 8 && q + 4 < last_even && next > last_even {
                q + 4
            } else {
                last_even
            }
        } else {
            q + 1
        }
    }

    /// The rays of a run of `len` (3 to 32) that [`ClosedMean::next_shaded`]
    /// visits, a bit each (bit `q` for ray `q`): every `span`-th below the
    /// last even ray `e`, `e` and the last ray, and with
    /// [`ClosedMean::Octs`] ray `e − 2` where it is `≡ 4 (mod 8)`.
    #[inline(always)]
    pub const fn shaded_mask(self, len: usize) -> u32 {
        let e = (len.saturating_sub(1) & !1) as u32 & 31;
        let every = match self {
            ClosedMean::Off => u32::MAX,
            ClosedMean::Pairs => 0x5555_5555,
            ClosedMean::Quads => 0x1111_1111,
            ClosedMean::Octs => 0x0101_0101,
        };
        let tail = match self {
            ClosedMean::Octs if e % 8 == 6 => 1 << (e - 2),
            _ => 0,
        };
        let last = if len & 1 == 0 { 3 << e } else { 1 << e };
        (every & ((1 << e) - 1)) | last | tail
    }

    /// How many rays of a run of `len` are shaded ([`ClosedMean::next_shaded`]).
    pub const fn shaded(self, len: usize) -> usize {
        let (mut q, mut n) = (0, 0);
        while q < len {
            n += 1;
            q = self.next_shaded(q, len);
        }
        n
    }
}

/// The per-pixel arithmetic (the planner's choice).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Arithmetic {
    /// 32-bit fixed point with a format per quantity ([`crate::mix32`]):
    /// the fast default, for every scene its formats hold.
    Fast,
    /// Every quantity in the frame's [`Scalar`] (I32F32 for the planner's
    /// fallback; `f32` for comparison).
    Wide,
}

impl Arithmetic {
    /// Name as reports spell it.
    pub const fn name(self) -> &'static str {
        match self {
            Arithmetic::Fast => "fast",
            Arithmetic::Wide => "wide",
        }
    }
}

impl Options {
    /// `model` with a linearly interpolated table of `lut_entries`, stages
    /// pruned to what the scene needs.
    pub const fn new(model: RenderModel, lut_entries: usize) -> Options {
        Options {
            model,
            lut_entries,
            distortion_eval: DistortionEval::Linear,
            keep_all_stages: false,
            arithmetic: Arithmetic::Wide,
            samples: 1,
            adaptive: false,
            aperture: 0,
            closed_mean: ClosedMean::Off,
        }
    }

    /// These options with the sample pattern `scene` asks for
    /// ([`crate::sampling::of_scene`]), as the planner sets it.
    pub fn with_scene_sampling(self, scene: &Scene) -> Options {
        let (samples, adaptive) = crate::sampling::of_scene(scene);
        Options {
            samples,
            adaptive,
            ..self
        }
    }

    /// These options with arithmetic `a`.
    pub const fn with_arithmetic(self, a: Arithmetic) -> Options {
        Options {
            arithmetic: a,
            ..self
        }
    }
}

/// A departure from the plan, for measuring the speed/accuracy trade
/// (`host-sim tradeoff`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Override {
    /// The plan as it is.
    Planned,
    /// A distortion table of `entries` (2 to [`MAX_LUT`]) read by `eval`.
    Table {
        /// Entries.
        entries: usize,
        /// [`DistortionEval::Nearest`] or [`DistortionEval::Linear`].
        eval: DistortionEval,
    },
    /// The distortion polynomial per pixel: no table.
    Polynomial,
    /// Nothing pruned: perspective rays (unless the camera is telecentric),
    /// the distortion stage even without distortion (a [`MAX_LUT`]-entry
    /// table in the wide arithmetic, the polynomial in the fast one), the
    /// specular stage even without a specular material, no slope-space
    /// culling.
    AllStages,
    /// An `n×n` sample grid on every pixel (`adaptive = false`) or where
    /// the adaptive rule asks.
    Samples {
        /// Grid side: 1, 2, 4, 8 or 16.
        n: u8,
        /// The adaptive rule.
        adaptive: bool,
    },
    /// The aperture sampled with `points` (16, 64, 256), or not at all (0).
    Aperture {
        /// Aperture pattern points.
        points: u16,
    },
    /// The closed plane's every ray shaded with its own light terms, not
    /// the odd ones from their neighbours' mean ([`Options::closed_mean`]
    /// off).
    NoMean,
    /// Perspective rays where the plan has weak-perspective ones (a
    /// telecentric camera's stay parallel).
    Perspective,
    /// Weak-perspective rays at mean depth `mean_depth` (metres) where the
    /// plan has perspective ones (the planner's weak-perspective candidate
    /// gives it; a telecentric camera's rays are unchanged).
    Weak {
        /// `Z̄`, metres.
        mean_depth: Len,
    },
}

impl Options {
    /// These options with `o` applied.
    pub fn with(self, o: Override) -> Options {
        match o {
            Override::Planned => self,
            Override::Table { entries, eval } => Options {
                lut_entries: entries,
                distortion_eval: eval,
                ..self
            },
            Override::Polynomial => Options {
                distortion_eval: DistortionEval::Polynomial,
                ..self
            },
            Override::AllStages => Options {
                model: self.model.exact(),
                lut_entries: MAX_LUT,
                // The fast arithmetic evaluates the polynomial (no table).
                distortion_eval: match self.arithmetic {
                    Arithmetic::Fast => DistortionEval::Polynomial,
                    Arithmetic::Wide => DistortionEval::Linear,
                },
                keep_all_stages: true,
                ..self
            },
            Override::Samples { n, adaptive } => Options {
                samples: n,
                adaptive,
                ..self
            },
            Override::Aperture { points } => Options {
                aperture: points,
                ..self
            },
            Override::NoMean => Options {
                closed_mean: ClosedMean::Off,
                ..self
            },
            Override::Perspective => Options {
                model: self.model.exact(),
                ..self
            },
            Override::Weak { mean_depth } => Options {
                model: match self.model {
                    RenderModel::Perspective => RenderModel::WeakPerspective { mean_depth },
                    m => m,
                },
                ..self
            },
        }
    }
}

/// Why a frame cannot be rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RenderError {
    /// The line or flag buffer is shorter than a line.
    BufferTooSmall,
    /// An undistorted sensor corner lies beyond [`MAX_SLOPE`].
    FieldTooWide,
    /// A primitive lies at the centre of projection, a ray model
    /// parameter is degenerate, the sample grid's side is not 1, 2, 4, 8 or
    /// 16, or the aperture pattern's size not 0, 16, 64 or 256 (or not 0
    /// with parallel rays).
    Degenerate,
    /// The distortion factor `g` exceeds ±32 768 over the sensor.
    DistortionOutOfRange,
    /// The [`crate::mix32`] path cannot render the frame: it needs a stage
    /// that path leaves out (a distortion table, defocus) or values beyond
    /// its formats.
    OutsideFormat,
    /// The frame needs pixel-area sampling, defocus or sensor noise, and
    /// the core's `sensor` feature is off; or its line loop is not among
    /// those the renderer was built with ([`Lines`]).
    NotBuilt,
    /// The distortion table asked for has more entries than the frame holds
    /// (its `T`).
    TableTooLarge,
}

/// The error of [`Frame::render`]: the renderer's or the sink's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError<E> {
    /// Rendering failed.
    Render(RenderError),
    /// The sink failed.
    Sink(E),
}

/// Which stages a frame runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stages {
    /// Ray model.
    pub model: RenderModel,
    /// How distortion is undone, if it is modelled.
    pub distortion: Option<DistortionEval>,
    /// Distortion table entries, if a table is used.
    pub distortion_lut: Option<usize>,
    /// cos⁴ fall-off.
    pub vignetting: bool,
    /// Specular lobe.
    pub specular: bool,
    /// Output format.
    pub format: PixelFormat,
    /// The per-pixel arithmetic.
    pub arithmetic: Arithmetic,
    /// Sample grid side (1: the pixel centre alone).
    pub samples: u8,
    /// The adaptive rule decides which pixels get the grid.
    pub adaptive: bool,
    /// Aperture pattern points (0: a pinhole, no defocus).
    pub aperture: u16,
    /// Sensor noise.
    pub noise: bool,
}

impl Stages {
    /// No stages (a frame of no pixels).
    const NONE: Stages = Stages {
        model: RenderModel::Perspective,
        distortion: None,
        distortion_lut: None,
        vignetting: false,
        specular: false,
        format: PixelFormat::Gray8,
        arithmetic: Arithmetic::Wide,
        samples: 1,
        adaptive: false,
        aperture: 0,
        noise: false,
    };

    /// Stage names, in pipeline order.
    pub fn names(&self) -> heapless::Vec<&'static str, 12> {
        let mut v = heapless::Vec::new();
        let _ = v.push(match self.arithmetic {
            Arithmetic::Fast => "arithmetic:fast",
            Arithmetic::Wide => "arithmetic:wide",
        });
        let _ = v.push("pixel-to-normalized");
        if self.samples > 1 {
            let _ = v.push(match (self.samples, self.adaptive) {
                (2, false) => "sample:2x2",
                (4, false) => "sample:4x4",
                (8, false) => "sample:8x8",
                (_, false) => "sample:16x16",
                (2, true) => "sample:2x2-adaptive",
                (4, true) => "sample:4x4-adaptive",
                (8, true) => "sample:8x8-adaptive",
                (_, true) => "sample:16x16-adaptive",
            });
        }
        if let Some(d) = self.distortion {
            let _ = v.push(d.name());
        }
        let _ = v.push(self.model.name());
        match self.aperture {
            0 => {}
            16 => {
                let _ = v.push("defocus:16");
            }
            64 => {
                let _ = v.push("defocus:64");
            }
            _ => {
                let _ = v.push("defocus:256");
            }
        }
        let _ = v.push("intersect");
        let _ = v.push("shade:lambertian");
        if self.specular {
            let _ = v.push("shade:specular");
        }
        if self.vignetting {
            let _ = v.push("vignetting:cos4");
        }
        if self.noise {
            let _ = v.push("noise:emva1288");
        }
        let _ = v.push(match self.format {
            PixelFormat::Gray8 => "quantize:gray8",
            PixelFormat::Gray16 { .. } => "quantize:gray16",
            PixelFormat::Rgb565 => "quantize:rgb565",
        });
        v
    }
}

/// A primitive in the camera frame.
/// A primitive in the camera frame, I32F32 (what [`crate::mix32`] converts).
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
    fn to<S: Scalar>(&self) -> CamPrim<S> {
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

/// A frame prepared for rendering, with per-pixel values in `S`: one of
/// the two arithmetics' per-frame state (never both), the distortion table
/// (if the plan uses one) holding at most `T` entries.
///
/// `T` is the table storage the frame reserves (`4 T` bytes): a device sizes
/// it to the tables its scenes' plans use ([`crate::planner::Budget`]'s
/// `max_table_entries`), 0 if none.
#[derive(Clone, Debug)]
pub struct Frame<S: Scalar = Q, const T: usize = MAX_LUT> {
    width: u16,
    height: u16,
    format: PixelFormat,
    stages: Stages,
    path: Path<S, T>,
}

/// The per-frame state of the arithmetic that renders the frame (no heap to
/// box the larger one in: the enum is what keeps one, not both).
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
enum Path<S: Scalar, const T: usize> {
    /// The wide arithmetic, generic over `S`.
    Wide(WideFrame<S, T>),
    /// The 32-bit arithmetic with a format per quantity.
    #[cfg(feature = "mix32")]
    Fast(crate::mix32::Mix32),
}

/// The wide arithmetic's per-frame state.
#[derive(Clone, Debug)]
struct WideFrame<S: Scalar, const T: usize> {
    width: u16,
    height: u16,
    format: PixelFormat,
    stages: Stages,
    /// `x̂_d` of column 0 and its step per column, I64F64 raw.
    x0: i128,
    dx: i128,
    /// `ŷ_d` of line 0 and its step per line, I64F64 raw.
    y0: i128,
    dy: i128,
    /// `g` at the table's nodes, i32 entries converted per lookup (a shift
    /// in fixed point): one table serves every scalar type.
    lut: Option<Lut<T>>,
    /// [`Lut::scale`] in `S`.
    lut_scale: S,
    /// `k1`, `k2` for [`DistortionEval::Polynomial`].
    poly: [S; 2],
    /// `u = r_d²` beyond which a pixel is outside the lens field.
    limit: S,
    /// Parallel-ray origin scale: `Z̄` or `f/m`.
    k_origin: S,
    prims: heapless::Vec<CamPrim<S>, { crate::scene::MAX_PRIMITIVES }>,
    lights: heapless::Vec<ShadingLight<S>, { crate::scene::MAX_LIGHTS }>,
    materials: [Brdf<S>; crate::scene::MAX_MATERIALS],
    background: V3<S>,
    /// `K π/4 (d/f)²` per channel (with the channel's full-scale factor):
    /// DN per unit radiance on the axis.
    gain: V3<S>,
    /// Sample grid offsets from the pixel centre, `x̂_d` and `ŷ_d` (I64F64
    /// raw), and the half pixel steps (the corners).
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    sub_x: [i128; crate::sampling::MAX_GRID as usize],
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    sub_y: [i128; crate::sampling::MAX_GRID as usize],
    half: (i128, i128),
    /// `1/n²`.
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    inv_n2: S,
    /// Defocus: the aperture radius `d/2` and `d/(2 Z̃)` (a
    /// [`crate::defocus::SPIRAL`] entry shifted left by `ap_shift` is a
    /// point of the `m`-point pattern on the unit disc in I32F32 bits:
    /// times these, an aperture point's `a` and `a/Z̃`), and `1/m`.
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    ap_r: S,
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    ap_rz: S,
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    ap_shift: u32,
    #[cfg_attr(not(feature = "sensor"), allow(dead_code))]
    inv_m: S,
    /// The scene's noise and the stage made of it for [`Frame::set_frame_id`].
    noise_spec: Option<crate::scene::Noise>,
    noise: Option<crate::noise::Stage<S>>,
}

fn q(w: Wide) -> Q {
    w.narrow::<Q>().value
}

fn v3_world_to_cam(scene: &Scene, p: crate::frame::WorldPoint) -> V3 {
    let c = scene.camera.extrinsics.world_to_camera(p).value;
    [Q::from_num(c.x), Q::from_num(c.y), Q::from_num(c.z)]
}

/// Rotates a world direction into the camera frame (`R d`).
fn dir_to_cam(scene: &Scene, d: [Norm; 3]) -> V3 {
    let r = scene.camera.extrinsics.rotation();
    r.map(|row| {
        q(Wide::of(row[0])
            .mul(Wide::of(d[0]))
            .add(Wide::of(row[1]).mul(Wide::of(d[1])))
            .add(Wide::of(row[2]).mul(Wide::of(d[2]))))
    })
}

impl Frame<Q> {
    /// Prepares `scene` for rendering with `opts`, in I32F32: the renderer
    /// the planner's predictions hold for.
    pub fn new(scene: &Scene, opts: &Options) -> Result<Frame, RenderError> {
        Frame::build(scene, opts)
    }
}

/// The fast arithmetic's entry points built for one x86-64 level (its
/// name, features in words, `target_feature` list, then `Mix32`'s line of
/// that level and the three functions' names): [`Frame::render_line`],
/// [`Frame::render_carried`] and the line both call. The same bytes as the
/// baseline build (integer arithmetic; host-sim's tests compare every
/// shipped scene at every level the processor has); the wide arithmetic's
/// loops are the baseline's. The caller checks the processor (host-sim's
/// `harness::x86_level`).
macro_rules! x86_entry_points {
    ($level:literal, $words:literal, $features:literal, $mix:ident, $line:ident, $carried:ident, $line_in:ident) => {
        #[doc = concat!(
                            "[`Frame::render_line`] with the fast arithmetic's loops built for ",
                            $level, " processors.\n\n# Safety\n\nCall only on a processor with ",
                            $level, "'s features (", $words, ")."
                        )]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        pub fn $line(&self, j: u16, pixels: &mut [u8], flags: &mut [u8]) -> Result<(), RenderError> {
            self.$line_in(j, pixels, flags, &mut Carry::new(&mut []))
        }

        #[doc = concat!(
                            "[`Frame::render_carried`] (every loop) with the fast loops built for ",
                            $level, ".\n\n# Safety\n\nCall only on a processor with ", $level, "'s features."
                        )]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        pub fn $carried<K: FrameSink>(
            &self,
            pixels: &mut [u8],
            flags: &mut [u8],
            keys: &mut [u64],
            sink: &mut K,
        ) -> Result<(), FrameError<K::Error>> {
            let mut carry = Carry::new(keys);
            self.render_each(pixels, flags, sink, |j, p, f| {
                self.$line_in(j, p, f, &mut carry)
            })
        }

        /// [`Frame::render_line_in`] (every loop) with the fast loops of
        /// this level.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        fn $line_in(
            &self,
            j: u16,
            pixels: &mut [u8],
            flags: &mut [u8],
            carry: &mut Carry,
        ) -> Result<(), RenderError> {
            #[cfg(feature = "mix32")]
            if let Path::Fast(m) = &self.path {
                self.check_buffers(pixels, flags)?;
                m.$mix::<AllLines>(j, pixels, flags, carry);
                return Ok(());
            }
            self.render_line_in::<AllLines>(j, pixels, flags, carry)
        }
    };
}

impl<S: Scalar, const T: usize> Frame<S, T> {
    /// Prepares `scene` for rendering with `opts`, per-pixel values in `S`.
    pub fn build(scene: &Scene, opts: &Options) -> Result<Frame<S, T>, RenderError> {
        let mut f = Frame::empty();
        f.prepare(scene, opts)?;
        Ok(f)
    }

    /// A frame of no pixels, to be prepared in place by [`Frame::prepare`].
    pub fn empty() -> Frame<S, T> {
        Frame {
            width: 0,
            height: 0,
            format: PixelFormat::Gray8,
            stages: Stages::NONE,
            path: Path::Wide(WideFrame::empty()),
        }
    }

    /// [`Frame::build`] in place: on a small stack (firmware) this keeps one
    /// frame where building one and returning it would hold two or three.
    /// On error the frame is left with no pixels.
    pub fn prepare(&mut self, scene: &Scene, opts: &Options) -> Result<(), RenderError> {
        let r = self.prepare_inner(scene, opts);
        if r.is_err() {
            self.width = 0;
            self.height = 0;
        }
        r
    }

    #[inline(never)]
    fn prepare_inner(&mut self, scene: &Scene, opts: &Options) -> Result<(), RenderError> {
        // The wide state holds what both arithmetics start from.
        if !matches!(self.path, Path::Wide(_)) {
            self.path = Path::Wide(WideFrame::empty());
        }
        // (Irrefutable without the fast path.)
        #[allow(irrefutable_let_patterns)]
        let Path::Wide(w) = &mut self.path
        else {
            return Err(RenderError::Degenerate);
        };
        let fast = w.prepare(scene, opts)?;
        (self.width, self.height, self.format, self.stages) = (w.width, w.height, w.format, w.stages);
        match fast {
            None => Ok(()),
            Some(fast) => self.prepare_mix32(scene, &fast),
        }
    }

    /// Prepares the [`crate::mix32`] path from the scene's I32F32 values
    /// (the wide state it replaces gave the frame's geometry).
    #[cfg(feature = "mix32")]
    #[inline(never)]
    fn prepare_mix32(&mut self, scene: &Scene, fast: &FastInput) -> Result<(), RenderError> {
        let input = crate::mix32::Input {
            width: self.width,
            height: self.height,
            format: scene.format,
            x0: fast.x0,
            dx: fast.dx,
            y0: fast.y0,
            dy: fast.dy,
            distortion: fast.distortion,
            vignetting: self.stages.vignetting,
            origin_scale: fast.origin_scale,
            specular_all: fast.specular_all,
            scene,
            background: scene.background,
            gain: fast.gain,
            samples: fast.samples,
            adaptive: fast.adaptive,
            aperture: fast.aperture,
            closed_mean: fast.closed_mean,
            centred: fast.centred,
        };
        self.path = Path::Fast(crate::mix32::Mix32::EMPTY);
        let Path::Fast(m) = &mut self.path else {
            return Err(RenderError::OutsideFormat);
        };
        m.fill(&input)
    }

    /// Without the `mix32` feature the path is not built in.
    #[cfg(not(feature = "mix32"))]
    fn prepare_mix32(&mut self, _: &Scene, _: &FastInput) -> Result<(), RenderError> {
        Err(RenderError::OutsideFormat)
    }

    /// Sets the frame id the noise is keyed by (0 after preparation).
    pub fn set_frame_id(&mut self, id: u32) {
        match &mut self.path {
            Path::Wide(w) => w.set_frame_id(id),
            #[cfg(feature = "mix32")]
            Path::Fast(m) => m.set_frame_id(id),
        }
    }

    /// The primitive (its index in the scene) whose pixels are shaded in
    /// closed form, if any: the fast arithmetic's plane without a checker
    /// or a lobe, seen by perspective rays, with its point lights off it
    /// (`mix32`'s `Closed`).
    pub fn closed_plane(&self) -> Option<usize> {
        match &self.path {
            Path::Wide(_) => None,
            #[cfg(feature = "mix32")]
            Path::Fast(m) => m.closed_plane_index(),
        }
    }

    /// Defocus in the fast arithmetic: every pixel's aperture rays traced,
    /// also those of a pixel whose sums are known to be one (`mix32`'s
    /// `uniform`): the check that the rule changes no byte, and the cost it
    /// saves. Nothing otherwise.
    pub fn trace_every_aperture_ray(&mut self) {
        #[cfg(feature = "mix32")]
        if let Path::Fast(m) = &mut self.path {
            m.trace_every_aperture_ray();
        }
    }

    /// Defocus in the fast arithmetic: how its loop takes the pixels of
    /// every `stride`-th row and column (traced, tested against one
    /// rectangle, or one sum); `None` otherwise.
    #[cfg(feature = "mix32")]
    pub fn aperture_classes(&self, stride: u16) -> Option<crate::mix32::ApertureClasses> {
        match &self.path {
            Path::Wide(_) => None,
            Path::Fast(m) => m.aperture_classes(self.height, stride),
        }
    }

    /// The stages this frame runs.
    pub fn stages(&self) -> Stages {
        self.stages
    }

    /// Sensor size.
    pub fn size(&self) -> (u16, u16) {
        (self.width, self.height)
    }

    /// Bytes a line occupies.
    pub fn line_bytes(&self) -> usize {
        self.width as usize * self.format.bytes_per_pixel()
    }

    /// Fractional bits of the distortion table's i32 entries, if any.
    pub fn table_frac_bits(&self) -> Option<u32> {
        match &self.path {
            Path::Wide(w) => w.lut.as_ref().map(Lut::entry_frac_bits),
            #[cfg(feature = "mix32")]
            Path::Fast(_) => None,
        }
    }

    /// Distortion table bytes (0 without a table).
    pub fn table_bytes(&self) -> usize {
        match &self.path {
            Path::Wide(w) => w.lut.as_ref().map_or(0, Lut::bytes),
            #[cfg(feature = "mix32")]
            Path::Fast(_) => 0,
        }
    }

    /// The undistorted normalized point `(x̂, ŷ)` the renderer uses for
    /// pixel `(i, j)`, or `None` outside the lens field or the sensor — the
    /// same code path as the pixel loop.
    pub fn undistorted(&self, i: u16, j: u16) -> Option<(S, S)> {
        if i >= self.width || j >= self.height {
            return None;
        }
        match &self.path {
            Path::Wide(w) => w.undistorted(i, j),
            #[cfg(feature = "mix32")]
            Path::Fast(m) => m.undistorted(i, j).map(|(x, y)| (S::from_q(x), S::from_q(y))),
        }
    }

    /// Renders line `j` into `pixels` (at least [`Frame::line_bytes`]) and
    /// `flags` (at least the width).
    pub fn render_line(&self, j: u16, pixels: &mut [u8], flags: &mut [u8]) -> Result<(), RenderError> {
        self.render_line_with::<AllLines>(j, pixels, flags)
    }

    /// The loop this frame's lines are rendered by.
    pub fn line_loop(&self) -> LineLoop {
        match &self.path {
            #[cfg(feature = "mix32")]
            Path::Fast(m) => m.line_loop(),
            Path::Wide(_) if matches!(self.stages.model, RenderModel::Perspective) => {
                LineLoop::WidePerspective
            }
            Path::Wide(_) => LineLoop::WideParallel,
        }
    }

    /// Whether this frame's line loop is one of `L`'s.
    pub fn line_built<L: Lines>(&self) -> bool {
        let st = &self.stages;
        let wide_stages = match &self.path {
            Path::Wide(_) => {
                (L::WIDE_SAMPLED || st.samples <= 1)
                    && (L::WIDE_APERTURE || st.aperture == 0)
                    && (L::WIDE_SPECULAR || !st.specular)
            }
            #[cfg(feature = "mix32")]
            Path::Fast(_) => {
                let lobe = match st.format.channels() {
                    3 => L::FAST_RGB_SPECULAR,
                    _ => L::FAST_GRAY_SPECULAR,
                };
                lobe || !st.specular
            }
        };
        self.line_loop().built::<L>() && wide_stages
    }

    /// [`Frame::render_line`] with only `L`'s line loops compiled in:
    /// [`RenderError::NotBuilt`] for a frame whose loop is not one of them.
    pub fn render_line_with<L: Lines>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
    ) -> Result<(), RenderError> {
        self.render_line_in::<L>(j, pixels, flags, &mut Carry::new(&mut []))
    }

    /// [`Frame::render_line_with`] with what the line before (the same
    /// frame's line `j − 1`, rendered with `carry`) left in `carry`: the
    /// same bytes, with one row of the sampled loop's corners traced
    /// instead of two.
    pub fn render_line_in<L: Lines>(
        &self,
        j: u16,
        pixels: &mut [u8],
        flags: &mut [u8],
        carry: &mut Carry,
    ) -> Result<(), RenderError> {
        // Only the fast arithmetic's loops use it.
        #[cfg(not(feature = "mix32"))]
        let _ = carry;
        self.check_buffers(pixels, flags)?;
        if !self.line_built::<L>() {
            return Err(RenderError::NotBuilt);
        }
        // Per-frame dispatch to one of the loops; those `L` leaves out are
        // not compiled in.
        match (&self.path, self.line_loop()) {
            #[cfg(feature = "mix32")]
            (Path::Fast(m), _) => m.line::<L>(j, pixels, flags, carry),
            // Through the aperture, a sample's chief ray is a pinhole ray:
            // one loop for both (a third copy would cost flash).
            (Path::Wide(w), LineLoop::WidePerspective) if L::WIDE_PERSPECTIVE => {
                w.line::<L, PINHOLE>(j, pixels, flags)
            }
            (Path::Wide(w), LineLoop::WideParallel) if L::WIDE_PARALLEL => {
                w.line::<L, PARALLEL>(j, pixels, flags)
            }
            _ => {}
        }
        Ok(())
    }

    /// [`RenderError::BufferTooSmall`] unless `pixels` holds a line
    /// ([`Frame::line_bytes`]) and `flags` the width.
    fn check_buffers(&self, pixels: &[u8], flags: &[u8]) -> Result<(), RenderError> {
        if pixels.len() < self.line_bytes() || flags.len() < self.width as usize {
            return Err(RenderError::BufferTooSmall);
        }
        Ok(())
    }

    /// Renders every line through `sink`, each where the sink places it
    /// ([`FrameSink::place`]) or in `pixels`; `flags` holds a line's flags.
    pub fn render<K: FrameSink>(
        &self,
        pixels: &mut [u8],
        flags: &mut [u8],
        sink: &mut K,
    ) -> Result<(), FrameError<K::Error>> {
        self.render_with::<AllLines, K>(pixels, flags, sink)
    }

    /// [`Frame::render`] with only `L`'s line loops compiled in: a frame
    /// whose loop is not one of them is refused
    /// ([`RenderError::NotBuilt`]) before the sink sees it.
    pub fn render_with<L: Lines, K: FrameSink>(
        &self,
        pixels: &mut [u8],
        flags: &mut [u8],
        sink: &mut K,
    ) -> Result<(), FrameError<K::Error>> {
        self.render_carried::<L, K>(pixels, flags, &mut [], sink)
    }

    /// [`Frame::render_with`] carrying the sampled loop's corner keys from
    /// line to line in `keys` ([`Corners`]: `width + 1` words; shorter,
    /// unused): the same frame, one row of corners traced a line instead
    /// of two. Out of line: its [`Carry`] (1.4 KB) is on the stack only
    /// while the frame renders, not while its caller prepares the next.
    #[inline(never)]
    pub fn render_carried<L: Lines, K: FrameSink>(
        &self,
        pixels: &mut [u8],
        flags: &mut [u8],
        keys: &mut [u64],
        sink: &mut K,
    ) -> Result<(), FrameError<K::Error>> {
        let mut carry = Carry::new(keys);
        if !self.line_built::<L>() {
            return Err(FrameError::Render(RenderError::NotBuilt));
        }
        self.render_each(pixels, flags, sink, |j, p, f| {
            self.render_line_in::<L>(j, p, f, &mut carry)
        })
    }

    /// Every line through `sink`, each rendered by `line` where the sink
    /// places it ([`FrameSink::place`]) or else in `pixels` (then
    /// [`RenderError::BufferTooSmall`] if it or `flags` is shorter than a
    /// line).
    fn render_each<K: FrameSink>(
        &self,
        pixels: &mut [u8],
        flags: &mut [u8],
        sink: &mut K,
        mut line: impl FnMut(u16, &mut [u8], &mut [u8]) -> Result<(), RenderError>,
    ) -> Result<(), FrameError<K::Error>> {
        let info = FrameInfo {
            width: self.width,
            height: self.height,
            format: self.format,
        };
        let n = self.line_bytes();
        let Some(flags) = flags.get_mut(..self.width as usize) else {
            return Err(FrameError::Render(RenderError::BufferTooSmall));
        };
        let short = || FrameError::Render(RenderError::BufferTooSmall);
        sink.begin(&info).map_err(FrameError::Sink)?;
        for j in 0..self.height {
            // One call of `line` (inlined once, not twice).
            let slot = sink.place(j, n).map_err(FrameError::Sink)?;
            let placed = slot.is_some();
            let p = slot.unwrap_or(&mut *pixels).get_mut(..n).ok_or_else(short)?;
            line(j, p, flags).map_err(FrameError::Render)?;
            if placed {
                sink.placed(j, flags).map_err(FrameError::Sink)?;
            } else {
                sink.line(j, pixels.get(..n).ok_or_else(short)?, flags)
                    .map_err(FrameError::Sink)?;
            }
        }
        sink.end(None).map_err(FrameError::Sink)
    }

    x86_entry_points!(
        "x86-64-v3",
        "AVX2, BMI1, BMI2, FMA, LZCNT, MOVBE, POPCNT",
        "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt",
        line_v3,
        render_line_v3,
        render_carried_v3,
        render_line_v3_in
    );
    x86_entry_points!(
        "x86-64-v4",
        "x86-64-v3's and AVX-512 F, CD, VL, BW, DQ",
        "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt,avx512f,avx512cd,avx512vl,avx512bw,avx512dq",
        line_v4,
        render_line_v4,
        render_carried_v4,
        render_line_v4_in
    );
}

/// What the fast path is prepared from, beyond the scene: the wide
/// preparation's geometry and constants (I32F32, camera frame).
#[cfg_attr(not(feature = "mix32"), allow(dead_code))]
struct FastInput {
    x0: i128,
    dx: i128,
    y0: i128,
    dy: i128,
    /// `k1`, `k2` and the `u` limit, if distortion is modelled (polynomial).
    distortion: Option<([Q; 2], Q)>,
    origin_scale: Option<Q>,
    specular_all: bool,
    gain: V3,
    samples: u8,
    adaptive: bool,
    /// Defocus: the aperture pattern's points (0: none).
    aperture: u16,
    /// [`Options::closed_mean`].
    closed_mean: ClosedMean,
    /// The principal point is the sensor's centre, `o_x = (W − 1)/2`
    /// exactly: column `W − 1 − i` sees the mirror image of column `i`'s
    /// slopes.
    centred: bool,
}

impl<S: Scalar, const T: usize> WideFrame<S, T> {
    /// A frame of no pixels. A function, not a constant: a constant this
    /// size is copied from flash (7 KB of it), a function's value is built
    /// by stores.
    #[inline(always)]
    fn empty() -> WideFrame<S, T> {
        WideFrame {
            width: 0,
            height: 0,
            format: PixelFormat::Gray8,
            stages: Stages::NONE,
            x0: 0,
            dx: 0,
            y0: 0,
            dy: 0,
            lut: None,
            lut_scale: S::ZERO,
            poly: [S::ZERO; 2],
            limit: S::MAX,
            k_origin: S::ZERO,
            prims: heapless::Vec::new(),
            lights: heapless::Vec::new(),
            materials: [Brdf::ZERO; crate::scene::MAX_MATERIALS],
            background: [S::ZERO; 3],
            gain: [S::ZERO; 3],
            sub_x: [0; crate::sampling::MAX_GRID as usize],
            sub_y: [0; crate::sampling::MAX_GRID as usize],
            half: (0, 0),
            inv_n2: S::ONE,
            ap_r: S::ZERO,
            ap_rz: S::ZERO,
            ap_shift: 0,
            inv_m: S::ONE,
            noise_spec: None,
            noise: None,
        }
    }

    /// Prepares the frame's geometry and, for the wide arithmetic, its
    /// primitives, lights and materials; for the fast arithmetic it returns
    /// what that path is prepared from instead.
    #[inline(always)]
    fn prepare(&mut self, scene: &Scene, opts: &Options) -> Result<Option<FastInput>, RenderError> {
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
        self.width = w;
        self.height = h;
        self.format = scene.format;
        self.stages = Stages {
            model: opts.model,
            distortion: None,
            distortion_lut: None,
            vignetting: !matches!(opts.model, RenderModel::Orthographic { .. }),
            specular: scene.has_specular() || opts.keep_all_stages,
            format: scene.format,
            arithmetic: opts.arithmetic,
            samples: opts.samples.clamp(1, crate::sampling::MAX_GRID),
            adaptive: opts.adaptive && opts.samples > 1,
            aperture: opts.aperture,
            noise: scene.noise.is_some(),
        };
        if !matches!(self.stages.samples, 1 | 2 | 4 | 8 | 16) {
            return Err(RenderError::Degenerate);
        }
        let aperture = opts.aperture > 0;
        if aperture
            && (!crate::defocus::is_size(opts.aperture) || !matches!(opts.model, RenderModel::Perspective))
        {
            return Err(RenderError::Degenerate);
        }
        if cfg!(not(feature = "sensor")) && (self.stages.samples > 1 || self.stages.noise || aperture) {
            return Err(RenderError::NotBuilt);
        }
        (self.x0, self.dx, self.y0, self.dy) = (x0, dx, y0, dy);
        #[cfg(feature = "sensor")]
        {
            let n = self.stages.samples;
            self.sub_x = crate::sampling::scaled_offsets(dx, n);
            self.sub_y = crate::sampling::scaled_offsets(dy, n);
            // Half a pixel step (the corners), rounded toward −∞.
            self.half = (dx >> 1, dy >> 1);
            self.inv_n2 = S::from_q(Q::from_bits(1i64 << (32 - 2 * crate::sampling::log2(n))));
            // Defocus: the aperture radius, and it over Z̃.
            let m = opts.aperture.max(1);
            let lens = &scene.camera.lens;
            let r = Wide::of(lens.diameter()).mul(Wide::of(Q::from_bits(1 << 31)));
            let rz = r
                .checked_div(Wide::of(lens.focus_distance()))
                .ok_or(RenderError::Degenerate)?;
            self.ap_r = S::from_q(q(r));
            self.ap_rz = S::from_q(q(rz));
            self.ap_shift = crate::defocus::shift(m);
            self.inv_m = S::from_q(Q::from_bits(1i64 << (32 - m.trailing_zeros())));
        }
        self.noise_spec = scene.noise;
        self.noise = crate::noise::Stage::for_frame(scene.noise, scene.format, 0);
        self.background = from_q3(scene.background);
        // What only some frames set, reset from the previous frame; every
        // other field is set below for every frame.
        self.lut = None;
        self.lut_scale = S::ZERO;
        self.poly = [S::ZERO; 2];
        self.limit = S::MAX;
        self.prims.clear();
        self.lights.clear();
        self.materials = [Brdf::ZERO; crate::scene::MAX_MATERIALS];
        let mut poly_q = None;
        // Distortion over [0, u_max], u_max = min(fold, corner maximum). With
        // every stage kept, a lens without distortion runs the identity
        // (`k1 = k2 = 0`, g = 1).
        if !scene.distortion.is_none() || opts.keep_all_stages {
            let dist = scene.distortion;
            let mut u_corner = Q::ZERO;
            for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
                let (xd, yd) = (self.xd_q(i), self.yd_q(j));
                u_corner = u_corner.max(Scalar::add(Scalar::mul(xd, xd), Scalar::mul(yd, yd)));
            }
            let fold = dist.fold_u().map(Q::saturating_from_num);
            let (u_max, limit) = match fold {
                Some(f) if f < u_corner => (f, f),
                _ => (u_corner, Q::MAX),
            };
            self.limit = S::from_q(limit);
            self.stages.distortion = Some(opts.distortion_eval);
            if opts.distortion_eval == DistortionEval::Polynomial {
                let (k1, k2) = dist.coefficients();
                let k = [k1, k2].map(Q::saturating_from_num);
                poly_q = Some((k, limit));
                self.poly = k.map(S::from_q);
            } else {
                if opts.lut_entries.clamp(2, MAX_LUT) > T {
                    return Err(RenderError::TableTooLarge);
                }
                // Filled where it is used: no copy of the table on the stack.
                let lut = self.lut.get_or_insert_with(Lut::empty);
                if dist.fill_lut(u_max, opts.lut_entries, lut) {
                    self.lut = None;
                    return Err(RenderError::DistortionOutOfRange);
                }
                self.lut_scale = S::from_q(lut.scale());
                self.stages.distortion_lut = Some(lut.len());
            }
        }
        // The widest undistorted corner must stay within MAX_SLOPE.
        for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
            if let Some((x, y)) = self.undistorted(i, j) {
                let lim = S::from_int(MAX_SLOPE);
                if x.abs() > lim || y.abs() > lim {
                    return Err(RenderError::FieldTooWide);
                }
            }
        }
        self.k_origin = match opts.model {
            RenderModel::Perspective => S::ZERO,
            RenderModel::WeakPerspective { mean_depth } => S::from_q(Q::saturating_from_num(mean_depth)),
            RenderModel::Orthographic { scale } => S::from_q(q(Wide::of(intr.focal_length())
                .checked_div(Wide::of(scale))
                .ok_or(RenderError::Degenerate)?)),
        };
        // Constants: gain = K π/4 (d/f)².
        let lens = &scene.camera.lens;
        let dof = Wide::of(lens.diameter())
            .checked_div(Wide::of(lens.focal_length()))
            .ok_or(RenderError::Degenerate)?;
        let gain = [0, 1, 2].map(|c| vignetting::gain(scene.exposure, dof, scene.format.channel_scale(c)));
        self.gain = from_q3(gain);
        // Parallel rays' origin scale; slope-space culling unless every
        // stage is kept.
        let origin_scale = match opts.model {
            RenderModel::Perspective => None,
            _ => Some(self.k_origin.to_q()),
        };
        if opts.arithmetic == Arithmetic::Fast {
            let table =
                self.stages.distortion.is_some() && opts.distortion_eval != DistortionEval::Polynomial;
            // Defocus runs in the fast arithmetic for pixel centres only.
            let sampled = self.stages.samples > 1;
            if table || (aperture && sampled) || (sampled && cfg!(not(feature = "sensor"))) {
                return Err(RenderError::OutsideFormat);
            }
            // The fast path prepares its own primitives, lights and
            // materials: the wide ones are not built.
            return Ok(Some(FastInput {
                x0: self.x0,
                dx: self.dx,
                y0: self.y0,
                dy: self.dy,
                distortion: poly_q,
                origin_scale,
                specular_all: opts.keep_all_stages,
                gain,
                samples: self.stages.samples,
                adaptive: self.stages.adaptive,
                aperture: opts.aperture,
                closed_mean: opts.closed_mean,
                centred: scene.camera.intrinsics.is_centred_x(),
            }));
        }
        for (m, dst) in scene.materials.iter().zip(self.materials.iter_mut()) {
            *dst = Brdf::new(m, scene.ambient).to();
        }
        let cull = !opts.keep_all_stages;
        let blur = aperture.then(|| lens_blur(scene));
        for p in &scene.primitives {
            let _ = self.prims.push(cam_prim(scene, p, origin_scale, cull, blur).to());
        }
        for l in &scene.lights {
            let _ = self.lights.push(shading_light(scene, l).to());
        }
        Ok(None)
    }

    #[inline(always)]
    fn xd_q(&self, i: u16) -> Q {
        from_acc(self.x0 - self.dx * i as i128)
    }

    #[inline(always)]
    fn yd_q(&self, j: u16) -> Q {
        from_acc(self.y0 - self.dy * j as i128)
    }

    /// The undistorted normalized point `(x̂, ŷ)` the renderer uses for
    /// pixel `(i, j)`, or `None` outside the lens field — the same code path
    /// as the pixel loop.
    fn undistorted(&self, i: u16, j: u16) -> Option<(S, S)> {
        let (xd, yd) = (S::from_q(self.xd_q(i)), S::from_q(self.yd_q(j)));
        match self.stages.distortion {
            Some(_) => self.undistort(xd, yd),
            None => Some((xd, yd)),
        }
    }

    /// `(x̂_d, ŷ_d) g(u)`, or `None` beyond the fold.
    #[inline(always)]
    fn undistort(&self, xd: S, yd: S) -> Option<(S, S)> {
        let u = xd.mul(xd).add(yd.mul(yd));
        if u > self.limit {
            return None;
        }
        let g = match self.stages.distortion {
            Some(DistortionEval::Polynomial) => S::ONE.add(u.mul(self.poly[0].add(u.mul(self.poly[1])))),
            Some(DistortionEval::Nearest) => {
                self.lut.as_ref().map_or(S::ONE, |l| l.nearest(u, self.lut_scale))
            }
            _ => self.lut.as_ref().map_or(S::ONE, |l| l.linear(u, self.lut_scale)),
        };
        Some((xd.mul(g), yd.mul(g)))
    }

    /// Sets the frame id the noise is keyed by.
    fn set_frame_id(&mut self, id: u32) {
        self.noise = crate::noise::Stage::for_frame(self.noise_spec, self.format, id);
    }

    #[inline(never)]
    #[cfg_attr(not(feature = "sensor"), allow(unused_variables, unused_mut))]
    fn line<L: Lines, const R: u8>(&self, j: u16, pixels: &mut [u8], flags: &mut [u8]) {
        let bpp = self.format.bytes_per_pixel();
        let channels = self.format.channels();
        let dn_max = [0, 1, 2].map(|c| self.format.dn_max(c));
        let yc = self.y0 - self.dy * j as i128;
        let n = self.stages.samples;
        let corners = L::WIDE_SAMPLED && n > 1 && self.stages.adaptive;
        let (hx, hy) = self.half;
        let (top, bottom) = (yc + hy, yc - hy);
        // The keys of the current pixel's left corners (adaptive rule).
        #[cfg(feature = "sensor")]
        let mut left = if corners {
            [
                self.key::<R>(self.x0 + hx, top),
                self.key::<R>(self.x0 + hx, bottom),
            ]
        } else {
            [None, None]
        };
        let mut acc = self.x0;
        let row = u32::from(j) * u32::from(self.width);
        // (Not `chunks_exact_mut(bpp)`: where the compiler keeps its
        // iterator out of line, it divides by `bpp` there, a panic path.)
        for (i, flag) in flags.iter_mut().take(self.width as usize).enumerate() {
            let Some(out) = pixels.get_mut(i * bpp..(i + 1) * bpp) else {
                break;
            };
            let xc = acc;
            acc -= self.dx;
            #[cfg(feature = "sensor")]
            let value = if !L::WIDE_SAMPLED || n <= 1 {
                self.sample_inline::<L, R>(xc, yc).map(|(v, _)| v)
            } else {
                self.area_value::<L, R>(xc, yc, (top, bottom), &mut left)
            };
            #[cfg(not(feature = "sensor"))]
            let value = self.sample_inline::<L, R>(xc, yc).map(|(v, _)| v);
            let Some(value) = value else {
                *flag = FLAG_OUTSIDE_FIELD;
                out.iter_mut().for_each(|b| *b = 0);
                continue;
            };
            *flag = 0;
            let mut dn = [0u32; 3];
            #[cfg(feature = "sensor")]
            if let Some(z) = &self.noise {
                let p = row + i as u32;
                for (c, ((dst, v), max)) in dn.iter_mut().zip(value).zip(dn_max).take(channels).enumerate() {
                    *dst = z.apply(v, p, c, max);
                }
                self.format.pack(dn, out);
                continue;
            }
            for ((dst, v), max) in dn.iter_mut().zip(value).zip(dn_max).take(channels) {
                *dst = vignetting::round_dn(v, max);
            }
            self.format.pack(dn, out);
        }
    }

    /// The value of the pixel centred at `(xc, yc)` (I64F64 raw) under the
    /// sample pattern: with the adaptive rule, its centre sample if its
    /// corners (`left` from the previous pixel, the right ones looked at
    /// here on the lines `top`, `bottom`) and centre see the same; else the
    /// grid's mean. Out of line: the one-sample loop stays lean.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn area_value<L: Lines, const R: u8>(
        &self,
        xc: i128,
        yc: i128,
        (top, bottom): (i128, i128),
        left: &mut [Option<Key>; 2],
    ) -> Option<V3<S>> {
        if !self.stages.adaptive {
            return self.grid::<L, R>(xc, yc);
        }
        let hx = self.half.0;
        let right = [self.key::<R>(xc - hx, top), self.key::<R>(xc - hx, bottom)];
        let centre = self.sample::<L, R>(xc, yc);
        let uniform = match centre {
            Some((_, k)) => left.iter().chain(right.iter()).all(|c| *c == Some(k)),
            None => false,
        };
        *left = right;
        match centre {
            Some((v, _)) if uniform => Some(v),
            _ => self.grid::<L, R>(xc, yc),
        }
    }

    /// The ray of the distorted slopes `(x̂_d, ŷ_d)` (I64F64 raw): origin,
    /// direction, `d·d`, and the undistorted slopes; `None` beyond the fold.
    #[inline(always)]
    fn ray<const R: u8>(&self, xacc: i128, yacc: i128) -> Option<PixelRay<S>> {
        let (xd, yd) = (S::from_q(from_acc(xacc)), S::from_q(from_acc(yacc)));
        let (x, y) = if self.stages.distortion.is_some() {
            self.undistort(xd, yd)?
        } else {
            (xd, yd)
        };
        // Pinhole rays are also the chief rays of aperture samples.
        let (o, d) = if R != PARALLEL {
            ([S::ZERO; 3], [x, y, S::ONE])
        } else {
            (
                [x.mul(self.k_origin), y.mul(self.k_origin), S::ZERO],
                [S::ZERO, S::ZERO, S::ONE],
            )
        };
        // d·d (1 for parallel rays); for perspective rays also the
        // 1 + x̂² + ŷ² of cos⁴α (equal in fixed point, where sums are exact).
        let a = if R != PARALLEL { dot(d, d) } else { S::ONE };
        Some(PixelRay { o, d, a, xy: (x, y) })
    }

    /// One sample at the distorted slopes `(x̂_d, ŷ_d)` (I64F64 raw): `K E`
    /// per channel in DN before rounding, and what the ray sees; `None`
    /// beyond the fold. Out of line, for the grid and the adaptive rule (one
    /// copy in flash); the one-sample loop inlines [`WideFrame::sample_inline`].
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn sample<L: Lines, const R: u8>(&self, xacc: i128, yacc: i128) -> Option<(V3<S>, Key)> {
        self.sample_inline::<L, R>(xacc, yacc)
    }

    /// [`WideFrame::sample`], inlined.
    #[inline(always)]
    fn sample_inline<L: Lines, const R: u8>(&self, xacc: i128, yacc: i128) -> Option<(V3<S>, Key)> {
        let PixelRay { o, d, a, xy: (x, y) } = self.ray::<R>(xacc, yacc)?;
        #[cfg(feature = "sensor")]
        let (radiance, key) = if L::WIDE_APERTURE && R == PINHOLE && self.stages.aperture > 0 {
            self.through_aperture::<L>((x, y), a)
        } else if L::WIDE_SPECULAR && self.stages.specular {
            self.trace::<true, R>(o, d, a, (x, y))
        } else {
            self.trace::<false, R>(o, d, a, (x, y))
        };
        #[cfg(not(feature = "sensor"))]
        let (radiance, key) = if L::WIDE_SPECULAR && self.stages.specular {
            self.trace::<true, R>(o, d, a, (x, y))
        } else {
            self.trace::<false, R>(o, d, a, (x, y))
        };
        let cos4 = match (self.stages.vignetting, R != PARALLEL) {
            (false, _) => S::ONE,
            (true, true) => vignetting::cos4_of(a),
            (true, false) => vignetting::cos4(x, y),
        };
        let mut e = [S::ZERO; 3];
        for ((dst, l), g) in e
            .iter_mut()
            .zip(radiance)
            .zip(self.gain)
            .take(self.format.channels())
        {
            *dst = vignetting::exposure(g, l, cos4);
        }
        Some((e, key))
    }

    /// The radiance of the chief ray of undistorted slopes `(x̂, ŷ)` (`a =
    /// 1 + x̂² + ŷ²`) through the aperture (camera-model.md §8): the mean
    /// over the pattern's points `A` of the radiance along the ray from `A`
    /// through `Z̃ (x̂, ŷ, 1)`; and, for the adaptive rule, what the chief
    /// ray sees.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn through_aperture<L: Lines>(&self, (x, y): (S, S), a: S) -> (V3<S>, Key) {
        let mut sum = [S::ZERO; 3];
        let channels = self.format.channels();
        for p in crate::defocus::SPIRAL.iter().take(self.stages.aperture as usize) {
            let ux = S::from_q(Q::from_bits(i64::from(p[0]) << self.ap_shift));
            let uy = S::from_q(Q::from_bits(i64::from(p[1]) << self.ap_shift));
            let o = [ux.mul(self.ap_r), uy.mul(self.ap_r), S::ZERO];
            let d = [x.sub(ux.mul(self.ap_rz)), y.sub(uy.mul(self.ap_rz)), S::ONE];
            let (l, _) = if L::WIDE_SPECULAR && self.stages.specular {
                self.trace::<true, APERTURE>(o, d, dot(d, d), (x, y))
            } else {
                self.trace::<false, APERTURE>(o, d, dot(d, d), (x, y))
            };
            for (s, v) in sum.iter_mut().zip(l).take(channels) {
                *s = s.add(v);
            }
        }
        let key = if L::WIDE_SAMPLED && self.stages.adaptive {
            let chief = self.look::<PINHOLE>([S::ZERO; 3], [x, y, S::ONE], a, (x, y));
            chief.map_or(Key::NOTHING, |s| s.key)
        } else {
            Key::NOTHING
        };
        (sum.map(|s| s.mul(self.inv_m)), key)
    }

    /// What the ray at the distorted slopes `(x̂_d, ŷ_d)` (I64F64 raw) sees
    /// (through the aperture: its chief ray); `None` beyond the fold.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn key<const R: u8>(&self, xacc: i128, yacc: i128) -> Option<Key> {
        let PixelRay { o, d, a, xy } = self.ray::<R>(xacc, yacc)?;
        Some(self.look::<R>(o, d, a, xy).map_or(Key::NOTHING, |s| s.key))
    }

    /// The mean of the `n×n` grid of the pixel centred at `(xc, yc)`
    /// (I64F64 raw); `None` if any sample lies beyond the fold.
    #[cfg(feature = "sensor")]
    #[inline(never)]
    fn grid<L: Lines, const R: u8>(&self, xc: i128, yc: i128) -> Option<V3<S>> {
        let n = self.stages.samples as usize;
        let mut sum = [S::ZERO; 3];
        for oy in self.sub_y.iter().take(n) {
            for ox in self.sub_x.iter().take(n) {
                // Pixel coordinates grow as x̂_d, ŷ_d fall.
                let (e, _) = self.sample::<L, R>(xc - ox, yc - oy)?;
                for (s, v) in sum.iter_mut().zip(e) {
                    *s = s.add(v);
                }
            }
        }
        Some(sum.map(|s| s.mul(self.inv_n2)))
    }

    /// The nearest primitive the ray `o + t d` meets (`a = d·d`, `(x̂, ŷ)`
    /// its undistorted slopes), with the material at the hit.
    #[inline(always)]
    fn look<const R: u8>(&self, o: V3<S>, d: V3<S>, a: S, (x, y): (S, S)) -> Option<Seen<S>> {
        let mut nearest: Option<(usize, &CamPrim<S>, Hit<S>)> = None;
        for (i, p) in self.prims.iter().enumerate() {
            if let Some(b) = &p.bounds {
                if x < b[0] || x > b[1] || y < b[2] || y > b[3] {
                    continue;
                }
            }
            if let Some(h) = intersect::<S, R>(&p.shape, o, d, a) {
                if h.t < nearest.as_ref().map_or(S::MAX, |(_, _, b)| b.t) {
                    nearest = Some((i, p, h));
                }
            }
        }
        let (i, p, hit) = nearest?;
        // The point and the texture of the nearest hit only.
        let point = hit.point.unwrap_or_else(|| axpy(hit.t, d, o));
        let mut m = p.material as usize;
        let mut cell = (0, 0);
        if let Some(ch) = &p.checker {
            let rel = sub3(point, ch.origin);
            let cu = dot_k(ch.u, rel).mul(ch.inv_cell).floor_int();
            let cv = dot_k(ch.v, rel).mul(ch.inv_cell).floor_int();
            if (cu + cv) & 1 != 0 {
                m = ch.material as usize;
            }
            cell = (cu, cv);
        }
        Some(Seen {
            hit,
            point,
            material: m,
            key: Key { prim: i as u8, cell },
        })
    }

    /// Radiance (per channel) seen along the ray `o + t d`, `a = d·d`, of
    /// the undistorted slopes `(x̂, ŷ)`, and what it sees.
    #[inline]
    fn trace<const SPEC: bool, const R: u8>(&self, o: V3<S>, d: V3<S>, a: S, xy: (S, S)) -> (V3<S>, Key) {
        let Some(seen) = self.look::<R>(o, d, a, xy) else {
            return (self.background, Key::NOTHING);
        };
        let Some(mat) = self.materials.get(seen.material) else {
            return (self.background, seen.key);
        };
        let hit = seen.hit;
        // Two-sided surfaces: the normal faces the viewer.
        let normal = if hit.away { hit.n.map(S::neg) } else { hit.n };
        let view = if SPEC {
            if R != PARALLEL {
                let len = a.sqrt().unwrap_or(S::ONE);
                let inv = S::ONE.div(len).unwrap_or(S::ZERO);
                scale3(inv.neg(), d)
            } else {
                [S::ZERO, S::ZERO, S::ONE.neg()]
            }
        } else {
            [S::ZERO; 3]
        };
        let l = crate::shading::radiance::<S, SPEC>(
            mat,
            &self.lights,
            seen.point,
            normal,
            view,
            self.format.channels(),
        );
        (l, seen.key)
    }
}

/// Rays from the centre of projection, `o = 0`, `d = (x̂, ŷ, 1)`: the
/// const parameter `R` of the per-sample functions.
const PINHOLE: u8 = 0;
/// Parallel rays, `o = (k x̂, k ŷ, 0)`, `d = (0, 0, 1)`.
const PARALLEL: u8 = 1;
/// Rays through the aperture (camera-model.md §8): `o = (a_x, a_y, 0)`,
/// `d = (x̂ − a_x/Z̃, ŷ − a_y/Z̃, 1)`; a sample's chief ray is a pinhole ray
/// (the pixel loop runs as [`PINHOLE`]).
#[cfg_attr(not(feature = "sensor"), allow(dead_code))]
const APERTURE: u8 = 2;

/// A sample's ray: origin, direction, `d·d`, and the undistorted slopes.
struct PixelRay<S> {
    o: V3<S>,
    d: V3<S>,
    a: S,
    xy: (S, S),
}

/// What a ray sees, for the adaptive sampling rule: the primitive (255:
/// none) and, on a textured one, the texture cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Key {
    prim: u8,
    cell: (i64, i64),
}

impl Key {
    const NOTHING: Key = Key {
        prim: u8::MAX,
        cell: (0, 0),
    };
}

/// A ray's nearest hit with the material there.
struct Seen<S> {
    hit: Hit<S>,
    point: V3<S>,
    material: usize,
    key: Key,
}

/// `x̂_d` or `ŷ_d` from its I64F64 accumulator.
#[inline(always)]
pub(crate) fn from_acc(acc: i128) -> Q {
    Q::from_bits((acc >> 32) as i64)
}

/// A ray's hit on a shape.
struct Hit<S> {
    /// Ray parameter, > 0.
    t: S,
    /// Unit normal.
    n: V3<S>,
    /// The normal faces away from the viewer (`n̂·d > 0`).
    away: bool,
    /// `o + t d`, if the test computed it.
    point: Option<V3<S>>,
}

/// Nearest hit `t > 0` of the ray with a shape. `a = d·d` (1 for parallel
/// rays), computed once per ray.
#[inline]
fn intersect<S: Scalar, const R: u8>(s: &CamShape<S>, o: V3<S>, d: V3<S>, a: S) -> Option<Hit<S>> {
    // A flat shape's hit: n̂·d is the plane's denominator.
    let flat = |n, (t, denom): (S, S), point| Hit {
        t,
        n,
        away: denom > S::ZERO,
        point,
    };
    match *s {
        CamShape::Plane { n, dist } => plane_t::<S, R>(n, dist, o, d).map(|td| flat(n, td, None)),
        CamShape::Disc { n, dist, c, r2 } => {
            let td = plane_t::<S, R>(n, dist, o, d)?;
            let p = axpy(td.0, d, o);
            let rel = sub3(p, c);
            (dot(rel, rel) <= r2).then(|| flat(n, td, Some(p)))
        }
        CamShape::Rect {
            n,
            dist,
            c,
            u,
            v,
            hu,
            hv,
        } => {
            let td = plane_t::<S, R>(n, dist, o, d)?;
            let p = axpy(td.0, d, o);
            let rel = sub3(p, c);
            (dot_k(u, rel).abs() <= hu && dot_k(v, rel).abs() <= hv).then(|| flat(n, td, Some(p)))
        }
        CamShape::Sphere { c, r2, inv_r } => {
            // |o + t d − c|² = r²: a t² − 2 b t + cc = 0 with b = d·oc,
            // cc = |oc|² − r². The discriminant b² − a cc is computed as
            // a r² − |d × oc|² (Lagrange's identity): without the
            // cancellation of b² against a |oc|², its rounding next to the
            // silhouette is r/|c| of the other form's.
            let (b, disc) = if R != PARALLEL {
                // From an aperture point, the centre relative to it.
                let c = if R == APERTURE { sub3(c, o) } else { c };
                let x = [
                    d[1].mul(c[2]).sub(d[2].mul(c[1])),
                    d[2].mul(c[0]).sub(d[0].mul(c[2])),
                    d[0].mul(c[1]).sub(d[1].mul(c[0])),
                ];
                (dot(d, c), a.mul(r2).sub(dot(x, x)))
            } else {
                // d = (0, 0, 1): b = oc_z, disc = r² − oc_x² − oc_y².
                let oc = sub3(c, o);
                (oc[2], r2.sub(oc[0].mul(oc[0])).sub(oc[1].mul(oc[1])))
            };
            if disc < S::ZERO {
                return None;
            }
            let sq = disc.sqrt()?;
            let mut t = b.sub(sq).div(a)?;
            if t <= S::ZERO {
                t = b.add(sq).div(a)?;
                if t <= S::ZERO {
                    return None;
                }
            }
            let p = axpy(t, d, o);
            let n = scale3(inv_r, sub3(p, c));
            Some(Hit {
                t,
                n,
                away: dot(n, d) > S::ZERO,
                point: Some(p),
            })
        }
    }
}

#[inline]
/// `t > 0` and `n̂·d` where the ray meets the plane `n̂·P = dist`.
fn plane_t<S: Scalar, const R: u8>(n: V3<S>, dist: S, o: V3<S>, d: V3<S>) -> Option<(S, S)> {
    let denom = if R != PARALLEL { dot_k(n, d) } else { n[2] };
    let num = if R == PINHOLE {
        dist
    } else {
        // n_x o_x + n_y o_y (o_z = 0).
        dist.sub(dot_k([n[0], n[1], S::ZERO], o))
    };
    let t = num.div(denom)?;
    (t > S::ZERO).then_some((t, denom))
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
