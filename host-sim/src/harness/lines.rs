//! The host's line rendering: the core's loops built for this processor's
//! x86-64 level ([`X86Level`]), a line or a frame through them, and a
//! frame collected into memory, its lines in parallel or in order.

use super::Collect;
use hilcam::num::scalar::Scalar;
use hilcam::render::{Frame, FrameError, FrameSink, LineBuffers, RenderError};

/// A build of the core's fast loops for an x86-64 level
/// ([`Frame::render_line_v3`], [`Frame::render_line_v4`]): the same bytes at
/// every level (tests/render.rs compares them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum X86Level {
    /// The baseline build (any x86-64 processor, and every other host).
    Baseline,
    /// x86-64-v3: AVX2, BMI1, BMI2, FMA, LZCNT, MOVBE, POPCNT (Haswell, Zen).
    V3,
    /// x86-64-v4: v3 and AVX-512 F, CD, VL, BW, DQ (Skylake-X, Zen 4).
    V4,
}

impl X86Level {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            X86Level::Baseline => "baseline",
            X86Level::V3 => "x86-64-v3",
            X86Level::V4 => "x86-64-v4",
        }
    }

    /// The levels up to this one, lowest first.
    pub fn up_to(self) -> Vec<X86Level> {
        [X86Level::Baseline, X86Level::V3, X86Level::V4]
            .into_iter()
            .filter(|l| *l <= self)
            .collect()
    }
}

/// The highest level whose build of the core's loops this processor runs
/// (the baseline in a build without them: the `x86-levels` feature).
fn processor_level() -> X86Level {
    #[cfg(all(target_arch = "x86_64", feature = "x86-levels"))]
    {
        use std::arch::is_x86_feature_detected as has;
        static LEVEL: std::sync::OnceLock<X86Level> = std::sync::OnceLock::new();
        *LEVEL.get_or_init(|| {
            let v3 = has!("avx2")
                && has!("bmi1")
                && has!("bmi2")
                && has!("fma")
                && has!("lzcnt")
                && has!("movbe")
                && has!("popcnt");
            let v4 = has!("avx512f")
                && has!("avx512cd")
                && has!("avx512vl")
                && has!("avx512bw")
                && has!("avx512dq");
            match (v3, v4) {
                (true, true) => X86Level::V4,
                (true, false) => X86Level::V3,
                _ => X86Level::Baseline,
            }
        })
    }
    #[cfg(not(all(target_arch = "x86_64", feature = "x86-levels")))]
    X86Level::Baseline
}

/// The level the host renders with: the highest this processor runs,
/// capped by `HILCAM_X86_LEVEL` (`1`: the baseline build, `3`: at most
/// x86-64-v3; unset or `4`: no cap; another value is named on stderr once
/// and caps nothing). Read once a process (a line asks).
pub fn x86_level() -> X86Level {
    static CAP: std::sync::OnceLock<X86Level> = std::sync::OnceLock::new();
    let cap = *CAP.get_or_init(|| match std::env::var("HILCAM_X86_LEVEL") {
        Ok(v) if v == "1" => X86Level::Baseline,
        Ok(v) if v == "3" => X86Level::V3,
        Ok(v) if v == "4" => X86Level::V4,
        Err(std::env::VarError::NotPresent) => X86Level::V4,
        Ok(v) => {
            eprintln!("HILCAM_X86_LEVEL={v:?}: expected 1, 3 or 4; the level is not capped");
            X86Level::V4
        }
        Err(e) => {
            eprintln!("HILCAM_X86_LEVEL: {e}; the level is not capped");
            X86Level::V4
        }
    });
    processor_level().min(cap)
}

/// [`Frame::render_line`], in the core's loops built for this processor
/// ([`x86_level`]): the same bytes at every level.
pub fn render_line<S: Scalar>(
    frame: &Frame<S>,
    j: u16,
    pixels: &mut [u8],
    flags: &mut [u8],
) -> Result<(), RenderError> {
    render_line_at(x86_level(), frame, j, pixels, flags)
}

/// [`render_line`] at `level`, or the highest below it that the processor
/// runs.
pub fn render_line_at<S: Scalar>(
    level: X86Level,
    frame: &Frame<S>,
    j: u16,
    pixels: &mut [u8],
    flags: &mut [u8],
) -> Result<(), RenderError> {
    #[cfg(all(target_arch = "x86_64", feature = "x86-levels"))]
    match level.min(processor_level()) {
        // SAFETY: the processor has the level's features (`processor_level`).
        X86Level::V4 => return unsafe { frame.render_line_v4(j, pixels, flags) },
        // SAFETY: as above.
        X86Level::V3 => return unsafe { frame.render_line_v3(j, pixels, flags) },
        X86Level::Baseline => {}
    }
    let _ = level;
    frame.render_line(j, pixels, flags)
}

/// [`Frame::render`] (every line through `sink`, the sampled loop's
/// corner keys carried in `keys`; empty, none), in the core's loops built
/// for this processor ([`x86_level`]).
pub fn render_carried<S: Scalar, K: FrameSink>(
    frame: &Frame<S>,
    pixels: &mut [u8],
    flags: &mut [u8],
    keys: &mut [u64],
    sink: &mut K,
) -> Result<(), FrameError<K::Error>> {
    #[cfg(all(target_arch = "x86_64", feature = "x86-levels"))]
    match x86_level() {
        // SAFETY: the processor has the level's features (`x86_level` is
        // at most `processor_level`).
        X86Level::V4 => {
            return unsafe { frame.render_v4(LineBuffers::new(pixels, flags).with_keys(keys), sink) }
        }
        // SAFETY: as above.
        X86Level::V3 => {
            return unsafe { frame.render_v3(LineBuffers::new(pixels, flags).with_keys(keys), sink) }
        }
        X86Level::Baseline => {}
    }
    frame.render(LineBuffers::new(pixels, flags).with_keys(keys), sink)
}

/// Renders a prepared frame into memory, its lines in parallel on every
/// core (rayon): each line is rendered straight into its place, so the
/// bytes are those of [`collect_serial`] (tested).
pub fn collect<S: Scalar>(frame: &Frame<S>) -> Result<Collect, String> {
    let mut core = Collect::default();
    collect_into(frame, &mut core)?;
    Ok(core)
}

/// [`collect`] into `core`'s buffers, resized to the frame (a stream of
/// frames reuses them: no allocation and no page faults a frame). Every
/// byte is the frame's, whatever the buffers held (tested).
pub fn collect_into<S: Scalar>(frame: &Frame<S>, core: &mut Collect) -> Result<(), String> {
    use rayon::prelude::*;
    let (w, h) = frame.size();
    let lb = frame.line_bytes();
    core.pixels.resize(lb * h as usize, 0);
    core.flags.resize(w as usize * h as usize, 0);
    if lb == 0 || w == 0 {
        return Ok(());
    }
    core.pixels
        .par_chunks_mut(lb)
        .zip(core.flags.par_chunks_mut(w as usize))
        .enumerate()
        .try_for_each(|(j, (p, f))| render_line(frame, j as u16, p, f))
        .map_err(|e| format!("render failed: {e:?}"))
}

/// Renders a prepared frame into memory a line at a time through the
/// core's [`FrameSink`] (one core), as the firmware does: the sampled
/// loop's corner keys carried from line to line ([`render_carried`]).
pub fn collect_serial<S: Scalar>(frame: &Frame<S>) -> Result<Collect, String> {
    let mut core = Collect::default();
    collect_serial_into(frame, &mut core)?;
    Ok(core)
}

/// [`collect_serial`] into `core`'s buffers (emptied first; a stream of
/// frames reuses them).
pub fn collect_serial_into<S: Scalar>(frame: &Frame<S>, core: &mut Collect) -> Result<(), String> {
    let (w, h) = frame.size();
    let mut line = vec![0u8; frame.line_bytes()];
    let mut flags = vec![0u8; w as usize];
    core.pixels.clear();
    core.flags.clear();
    core.pixels.reserve(frame.line_bytes() * h as usize);
    core.flags.reserve(w as usize * h as usize);
    let mut keys = vec![0u64; w as usize + 1];
    render_carried(frame, &mut line, &mut flags, &mut keys, core).map_err(|e| format!("render failed: {e:?}"))
}
