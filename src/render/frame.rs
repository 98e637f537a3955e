//! [`Frame`]: a frame prepared for rendering, and its entry points.

use crate::geom::distortion::{Lut, MAX_LUT};
use crate::num::scalar::Scalar;
#[cfg(feature = "mix32")]
use crate::render::fast::Carry;
use crate::render::options::{
    AllLines, Arithmetic, FrameError, LineLoop, Lines, Options, RenderError, RenderModel, Stages,
};
use crate::render::prepare::Prepared;
use crate::render::shadows::Occluders;
use crate::render::sink::{FrameInfo, FrameSink, LineBuffers};
use crate::render::wide::{WideFrame, PARALLEL, PINHOLE};
use crate::scene::{PixelFormat, Scene, Q};
use core::marker::PhantomData;

/// Without the fast arithmetic nothing carries from line to line.
#[cfg(not(feature = "mix32"))]
struct Carry;

#[cfg(not(feature = "mix32"))]
impl Carry {
    fn new(_keys: &mut [u64]) -> Carry {
        Carry
    }
}

/// A frame prepared for rendering, with per-pixel values in `S`: one of
/// the two arithmetics' per-frame state (never both), the distortion table
/// (if the plan uses one) holding at most `T` entries.
///
/// `T` is the table storage the frame reserves (`4 T` bytes): a device sizes
/// it to the tables its scenes' plans use ([`crate::planner::Budget`]'s
/// `max_table_entries`), 0 if none.
///
/// `L` is the set of line loops the build compiles in ([`Lines`]; every
/// loop by default): a frame whose loop `L` leaves out is refused
/// ([`RenderError::NotBuilt`]) before a line is rendered.
#[derive(Clone, Debug)]
pub struct Frame<S: Scalar = Q, const T: usize = MAX_LUT, L: Lines = AllLines> {
    width: u16,
    height: u16,
    format: PixelFormat,
    stages: Stages,
    path: Path<S, T>,
    lines: PhantomData<fn() -> L>,
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
    Fast(crate::render::fast::Mix32),
}

impl Frame<Q> {
    /// Prepares `scene` for rendering with `opts`, in I32F32: the renderer
    /// the planner's predictions hold for.
    pub fn new(scene: &Scene, opts: &Options) -> Result<Frame, RenderError> {
        Frame::build(scene, opts)
    }

    /// Plans `scene` within `budget` ([`crate::planner::plan`]: the
    /// cheapest rendering predicted to meet it) and prepares that
    /// rendering. [`crate::planner::plan`] gives the plan itself: its
    /// candidates, predicted errors and costs.
    pub fn plan(scene: &Scene, budget: &crate::planner::Budget) -> Result<Frame, RenderError> {
        Frame::build(scene, &crate::planner::plan(scene, budget).options)
    }
}

/// The fast arithmetic's entry points built for one x86-64 level (its
/// name, features in words, `target_feature` list, then `Mix32`'s line of
/// that level and the three functions' names): [`Frame::render_line`],
/// [`Frame::render`] and the line both call. The same bytes as the
/// baseline build (integer arithmetic; host-sim's tests compare every
/// shipped scene at every level the processor has); the wide arithmetic's
/// loops are the baseline's. The caller checks the processor (host-sim's
/// `harness::x86_level`).
#[cfg(feature = "x86-levels")]
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
                            "[`Frame::render`] with the fast loops built for ",
                            $level, ".\n\n# Safety\n\nCall only on a processor with ", $level, "'s features."
                        )]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        pub fn $carried<K: FrameSink>(&self, lines: LineBuffers<'_>, sink: &mut K) -> Result<(), FrameError<K::Error>> {
            let LineBuffers { pixels, flags, keys } = lines;
            let mut carry = Carry::new(keys);
            if !self.is_built() {
                return Err(FrameError::Render(RenderError::NotBuilt));
            }
            self.render_each(pixels, flags, sink, |j, p, f| {
                self.$line_in(j, p, f, &mut carry)
            })
        }

        /// A line with the fast loops of this level.
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
                if !self.is_built() {
                    return Err(RenderError::NotBuilt);
                }
                m.$mix::<L>(j, pixels, flags, carry);
                return Ok(());
            }
            self.line_in(j, pixels, flags, carry)
        }
    };
}

impl<S: Scalar, const T: usize, L: Lines> Frame<S, T, L> {
    /// Prepares `scene` for rendering with `opts`, per-pixel values in `S`.
    pub fn build(scene: &Scene, opts: &Options) -> Result<Frame<S, T, L>, RenderError> {
        let mut f = Frame::empty();
        f.prepare(scene, opts)?;
        Ok(f)
    }

    /// A frame of no pixels, to be prepared in place by [`Frame::prepare`].
    pub fn empty() -> Frame<S, T, L> {
        Frame {
            width: 0,
            height: 0,
            format: PixelFormat::Gray8,
            stages: Stages::NONE,
            path: Path::Wide(WideFrame::empty()),
            lines: PhantomData,
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
        // Prepared once, whichever arithmetic renders the frame.
        let mut p = Prepared::new(scene, opts)?;
        let occ = crate::render::shadows::of_frame(scene, opts, p.origin_scale);
        p.stages.shadows = occ.any();
        (self.width, self.height, self.format, self.stages) = (p.width, p.height, scene.format, p.stages);
        match opts.arithmetic {
            Arithmetic::Fast => self.prepare_fast(scene, opts, (&p, &occ)),
            Arithmetic::Wide => {
                if !matches!(self.path, Path::Wide(_)) {
                    self.path = Path::Wide(WideFrame::empty());
                }
                // (Irrefutable without the fast path.)
                #[allow(irrefutable_let_patterns)]
                let Path::Wide(w) = &mut self.path
                else {
                    return Err(RenderError::Degenerate);
                };
                let r = w.fill((&p, &occ), scene, opts);
                self.stages = w.stages;
                r
            }
        }
    }

    /// The fast arithmetic's state ([`crate::render::fast`]) filled from
    /// the frame's preparation `p`: what its formats cannot hold
    /// ([`crate::render::Unfit`]) refused.
    #[cfg(feature = "mix32")]
    #[inline(never)]
    fn prepare_fast(
        &mut self,
        scene: &Scene,
        opts: &Options,
        (p, occ): (&Prepared, &Occluders),
    ) -> Result<(), RenderError> {
        let input = crate::render::fast::Input::of(scene, opts, p, *occ);
        self.path = Path::Fast(crate::render::fast::Mix32::EMPTY);
        let Path::Fast(m) = &mut self.path else {
            return Err(RenderError::OutsideFormat);
        };
        m.fill(&input)
    }

    /// Without the `mix32` feature the fast arithmetic is not built in.
    #[cfg(not(feature = "mix32"))]
    fn prepare_fast(
        &mut self,
        _: &Scene,
        _: &Options,
        _: (&Prepared, &Occluders),
    ) -> Result<(), RenderError> {
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
    pub fn aperture_classes(&self, stride: u16) -> Option<crate::render::ApertureClasses> {
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

    /// Renders line `j` alone into `pixels` (at least
    /// [`Frame::line_bytes`]) and `flags` (at least the width): lines in any
    /// order, or in parallel (the same bytes as [`Frame::render`]'s).
    pub fn render_line(&self, j: u16, pixels: &mut [u8], flags: &mut [u8]) -> Result<(), RenderError> {
        self.line_in(j, pixels, flags, &mut Carry::new(&mut []))
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

    /// Whether this frame's line loop is one of `L`'s (otherwise it is
    /// refused: [`RenderError::NotBuilt`]).
    pub fn is_built(&self) -> bool {
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

    /// Line `j` with what the line before (the same frame's line `j − 1`,
    /// rendered with `carry`) left in `carry`: the same bytes, with one
    /// row of the sampled loop's corners traced instead of two.
    fn line_in(
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
        if !self.is_built() {
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

    /// Renders the frame, line by line in order, through `sink`: each line
    /// where the sink places it ([`FrameSink::place`]) or else in
    /// `lines`' pixel buffer, handed to the sink ([`FrameSink::line`]).
    /// `lines` holds a line's flags, and the corner keys pixel-area
    /// sampling carries from line to line (with them, one row of corners
    /// is traced a line instead of two; the same bytes). Out of line: its
    /// carry (1.4 KB) is on the stack only while the frame renders, not
    /// while its caller prepares the next.
    #[inline(never)]
    pub fn render<K: FrameSink>(
        &self,
        lines: LineBuffers<'_>,
        sink: &mut K,
    ) -> Result<(), FrameError<K::Error>> {
        let LineBuffers { pixels, flags, keys } = lines;
        let mut carry = Carry::new(keys);
        if !self.is_built() {
            return Err(FrameError::Render(RenderError::NotBuilt));
        }
        self.render_each(pixels, flags, sink, |j, p, f| self.line_in(j, p, f, &mut carry))
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

    #[cfg(feature = "x86-levels")]
    x86_entry_points!(
        "x86-64-v3",
        "AVX2, BMI1, BMI2, FMA, LZCNT, MOVBE, POPCNT",
        "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt",
        line_v3,
        render_line_v3,
        render_v3,
        render_line_v3_in
    );
    #[cfg(feature = "x86-levels")]
    x86_entry_points!(
        "x86-64-v4",
        "x86-64-v3's and AVX-512 F, CD, VL, BW, DQ",
        "bmi1,bmi2,lzcnt,avx2,fma,movbe,popcnt,avx512f,avx512cd,avx512vl,avx512bw,avx512dq",
        line_v4,
        render_line_v4,
        render_v4,
        render_line_v4_in
    );
}
