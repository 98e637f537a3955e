//! What a frame is rendered with: the ray model, the distortion
//! evaluation, the arithmetic, the sample grid and aperture (the planner's
//! [`Options`]), the stages they make ([`Stages`]), the line loops a build
//! holds ([`Lines`]) and why a frame cannot be rendered ([`RenderError`]).

use crate::geom::distortion::MAX_LUT;
use crate::num::{Len, Norm};
use crate::scene::{PixelFormat, Scene};

/// Flag bit: the pixel lies beyond the fold radius, outside the lens field
/// (its value is 0).
pub const FLAG_OUTSIDE_FIELD: u8 = 1;

/// The largest `|x̂|, |ŷ|` (undistorted) the renderer supports: 16, a
/// half-angle of 86.4°.
pub const MAX_SLOPE: i32 = 16;

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
    /// ([`crate::render::sensor::sampling`]).
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
    /// loop): pixel-area sampling ([`crate::render::sensor::sampling`]),
    const WIDE_SAMPLED: bool = true;
    /// the aperture's rays (defocus, [`crate::render::sensor::defocus`]),
    const WIDE_APERTURE: bool = true;
    /// and the specular lobe.
    const WIDE_SPECULAR: bool = true;
    /// The sampled fast loops carry their corner keys from line to line
    /// (`crate::render::sensor::sampling::Corners`); without, they trace both rows of
    /// corners a line whatever the caller passes (less code).
    const CARRY_CORNERS: bool = true;
}

/// Every line loop.
#[derive(Clone, Copy, Debug)]
pub struct AllLines;

impl Lines for AllLines {}

/// Every line loop the planner picks, the sampled ones without the corner
/// carry (the driven camera's build, which holds no keys: its flash and RAM
/// are spoken for). (Until the fast aperture loops were planned, it left
/// them out: they took the camera's flash from 222 704 to 238 292 B on the
/// M3, 226 116 to 244 920 B on the M0.)
#[derive(Clone, Copy, Debug)]
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
    /// With distortion, its relative illumination (the area factor `J`,
    /// camera-model.md §5; [`crate::render::vignetting::area_factor`]):
    /// the planner leaves it out where `J` stays within the LSB budget.
    pub relative_illumination: bool,
    /// Pixel-area integration: the side `n` of the `n×n` sample grid
    /// ([`crate::render::sensor::sampling`]; 1, 2, 4, 8 or 16; 1 is the centre alone).
    pub samples: u8,
    /// The grid only where a pixel's corners and centre disagree
    /// ([`crate::render::sensor::sampling`]'s adaptive rule).
    pub adaptive: bool,
    /// Defocus: points of the aperture pattern a sample is lit through
    /// ([`crate::render::sensor::defocus`]; 16, 64 or 256, perspective rays only); 0: the
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
    /// 32-bit fixed point with a format per quantity (`crate::render::fast`):
    /// the fast default, for every scene its formats hold.
    Fast,
    /// Every quantity in the frame's [`crate::num::scalar::Scalar`] (I32F32 for the planner's
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
            relative_illumination: true,
            samples: 1,
            adaptive: false,
            aperture: 0,
            closed_mean: ClosedMean::Off,
        }
    }

    /// These options with the sample pattern `scene` asks for
    /// ([`crate::render::sensor::sampling::of_scene`]), as the planner sets it.
    pub fn with_scene_sampling(self, scene: &Scene) -> Options {
        let (samples, adaptive) = crate::render::sensor::sampling::of_scene(scene);
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
    /// The `crate::render::fast` path cannot render the frame: it needs a stage
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

/// Why the fast arithmetic cannot render a frame: the one rule
/// ([`crate::render::Frame`]'s preparation refuses it, the planner asks it
/// of each fast candidate).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unfit {
    /// Content (primitives, point lights) farther than 8·2²⁰ m.
    TooFar,
    /// A sphere, disc radius or checker cell below 2⁻¹⁰ of the frame's
    /// length unit (the content's extent / 8).
    TooSmall,
    /// The distortion factor `g`, `k1 + k2 u` or the area factor's `g + 2u g'`
    /// leaves ±8 over the sensor.
    Distortion,
    /// A distorted slope of 32 or more, or an undistorted one beyond 16.
    FieldTooWide,
    /// Parallel rays whose origins leave ±64 units.
    OriginsTooFar,
    /// The fast arithmetic is not built in (the core's `mix32` feature is
    /// off).
    NotBuilt,
    /// The scene needs defocus and a sample grid: the fast arithmetic's
    /// aperture loop (`mix32::line_d`) takes pixel centres only. (Through
    /// the aperture, a ray next to a sphere's silhouette is decided exactly
    /// there, since nothing marks its pixel as an edge: decided only
    /// approximately, pixels at a blurred silhouette differ from the
    /// reference by 2 LSB.)
    Defocus,
    /// A distortion table: the fast arithmetic evaluates the polynomial.
    Table,
    /// A calibrated lens (OpenCV's models): solved per sample by the wide
    /// arithmetic only.
    Calibrated,
    /// Cast shadows the planner could not prove unneeded: tested per
    /// sample by the wide arithmetic only.
    Shadows,
}

impl Unfit {
    /// Why, in words.
    pub const fn reason(self) -> &'static str {
        match self {
            Unfit::TooFar => "content beyond the 32-bit formats' range",
            Unfit::TooSmall => "a radius or checker cell below 2^-10 of the frame's length unit",
            Unfit::Distortion => "the distortion factor leaves +-8",
            Unfit::FieldTooWide => "slopes beyond the 32-bit formats",
            Unfit::OriginsTooFar => "parallel-ray origins beyond 64 length units",
            Unfit::NotBuilt => "the fast arithmetic is not built in (feature mix32)",
            Unfit::Defocus => "defocus with a sample grid: the fast aperture loop takes pixel centres only",
            Unfit::Table => "a distortion table: the fast arithmetic evaluates the polynomial",
            Unfit::Calibrated => "a calibrated lens: solved per sample by the wide arithmetic only",
            Unfit::Shadows => "cast shadows: tested per sample by the wide arithmetic only",
        }
    }
}

/// The error of [`crate::render::Frame::render`]: the renderer's or the sink's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError<E> {
    /// Rendering failed.
    Render(RenderError),
    /// The sink failed.
    Sink(E),
}

impl core::fmt::Display for RenderError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            RenderError::BufferTooSmall => "the line or flag buffer is shorter than a line",
            RenderError::FieldTooWide => "an undistorted sensor corner lies beyond the largest slope (16)",
            RenderError::Degenerate => "degenerate frame: a primitive at the centre of projection, or a ray model, sample grid or aperture pattern out of range",
            RenderError::DistortionOutOfRange => "the distortion factor g exceeds ±32 768 over the sensor",
            RenderError::OutsideFormat => "the fast arithmetic's formats cannot hold this frame",
            RenderError::NotBuilt => "this frame's line loop or stage is not built in",
            RenderError::TableTooLarge => "the distortion table has more entries than the frame holds",
        })
    }
}

impl core::error::Error for RenderError {}

impl<E: core::fmt::Display> core::fmt::Display for FrameError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::Render(e) => write!(f, "cannot render: {e}"),
            FrameError::Sink(e) => write!(f, "the sink failed: {e}"),
        }
    }
}

impl<E: core::fmt::Display + core::fmt::Debug> core::error::Error for FrameError<E> {}

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
    /// The distortion's area factor `J` (its relative illumination).
    pub relative_illumination: bool,
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
    /// Cast shadows: some surface is tested against an occluder under
    /// some light ([`crate::render::shadows`]; the tests the planner could
    /// not prove unneeded).
    pub shadows: bool,
}

impl Stages {
    /// No stages (a frame of no pixels).
    pub(crate) const NONE: Stages = Stages {
        model: RenderModel::Perspective,
        distortion: None,
        distortion_lut: None,
        vignetting: false,
        relative_illumination: false,
        specular: false,
        format: PixelFormat::Gray8,
        arithmetic: Arithmetic::Wide,
        samples: 1,
        adaptive: false,
        aperture: 0,
        noise: false,
        shadows: false,
    };

    /// Stage names, in pipeline order.
    pub fn names(&self) -> heapless::Vec<&'static str, 14> {
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
        if self.shadows {
            let _ = v.push("shadows");
        }
        let _ = v.push("shade:lambertian");
        if self.specular {
            let _ = v.push("shade:specular");
        }
        if self.vignetting {
            let _ = v.push("vignetting:cos4");
        }
        if self.relative_illumination {
            let _ = v.push("relative-illumination");
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
