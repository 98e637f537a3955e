//! The harness every command shares: the core's frame rendered line by
//! line (in parallel, byte-identical with one core), the f64 reference's,
//! their comparison ([`Tally`] → [`Metrics`]) and the plan as reported.
//! The commands (`render_cmd`, `hil_cmd`, `stream_cmd`, `tradeoff`) and the
//! tests use it; it uses none of them.

mod lines;

pub use lines::{
    collect, collect_into, collect_serial, collect_serial_into, render_carried, render_line, render_line_at,
    x86_level, X86Level,
};

use crate::reference::render::{RefFrame, RefRow, RefScene};
use crate::reference::sampling::Pattern;
use crate::scene_file::Resolved;
use hilcam::num::scalar::Scalar;
use hilcam::planner::{self, Budget, Plan};
use hilcam::render::{ClosedMean, Frame, FrameSink, Options, FLAG_OUTSIDE_FIELD};
use hilcam::scene::PixelFormat;
use serde::Serialize;

/// A core frame collected line by line.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Collect {
    /// Bytes of every line, in order.
    pub pixels: Vec<u8>,
    /// Flags of every pixel.
    pub flags: Vec<u8>,
}

impl Collect {
    /// Channel values of every pixel.
    pub fn dn(&self, format: PixelFormat) -> Vec<[u32; 3]> {
        decode_all(format, &self.pixels)
    }
}

impl FrameSink for Collect {
    type Error = std::convert::Infallible;
    fn line(&mut self, _y: u16, pixels: &[u8], flags: &[u8]) -> Result<(), Self::Error> {
        self.pixels.extend_from_slice(pixels);
        self.flags.extend_from_slice(flags);
        Ok(())
    }
}

/// One candidate the planner considered, as reported.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateReport {
    /// `fast-poly`, `wide-lut64`, …
    pub name: String,
    /// Why the arithmetic's formats cannot hold the scene (null: they can).
    pub unfit: Option<String>,
    /// Predicted pixel → undistorted error, px.
    pub geom_err_px: f64,
    /// Predicted largest |core − reference| before rounding, LSB.
    pub lsb: f64,
    /// Of `lsb`, the closed plane's mean's bound (0 without the mean:
    /// `planner::closed_mean_err`), LSB.
    pub mean_lsb: f64,
    /// Predicted cost, M3 instructions a pixel (the fitted cost model).
    pub m3_instructions_per_pixel: f64,
    /// Predicted fraction of all pixels that are edge pixels differing from
    /// the reference (an expected count, not a bound).
    pub edge_differing: f64,
    /// Fits and within the budget.
    pub meets_budget: bool,
}

/// The planner's choice, as reported.
#[derive(Clone, Debug, Serialize)]
pub struct PlanReport {
    /// The arithmetic the core rendered with (`fast`, `wide`).
    pub arithmetic: String,
    /// The candidate the planner chose (the frame may be a variant of it).
    pub chosen: String,
    /// Why it was chosen.
    pub why: String,
    /// Every candidate considered.
    pub candidates: Vec<CandidateReport>,
    /// Predicted cost of the chosen candidate, M3 instructions a pixel.
    pub predicted_m3_instructions_per_pixel: f64,
    /// Ray model the core rendered with.
    pub model: String,
    /// Mean depth if weak perspective was chosen, metres.
    pub mean_depth_m: Option<f64>,
    /// Distortion table entries (0: no distortion stage).
    pub lut_entries: usize,
    /// The entries' format, chosen for the camera (e.g. "I4F28").
    pub lut_format: Option<String>,
    /// Predicted pixel → undistorted error, px.
    pub predicted_geom_err_px: f64,
    /// §2 weak-perspective bound over the scene, px (null: unbounded scene).
    pub weak_perspective_err_px: Option<f64>,
    /// Predicted largest |core − reference| before rounding, LSB.
    pub predicted_lsb: f64,
    /// All predictions within the budget.
    pub meets_budget: bool,
    /// The budget.
    pub budget_geom_px: f64,
    /// The budget.
    pub budget_lsb: f64,
    /// Sample grid side (1: one sample at the pixel centre).
    pub samples: u8,
    /// The adaptive rule spends the grid only where a pixel's corners and
    /// centre disagree.
    pub adaptive: bool,
    /// Predicted edge-placement error of the sample pattern, px.
    pub predicted_edge_err_px: f64,
    /// Predicted samples of a pixel's area (with the adaptive rule: the
    /// centre, and the grid on the estimated share of edge pixels).
    pub predicted_samples_per_pixel: f64,
    /// What the pixel's samples (grid, corner looks, aperture points) cost
    /// as a multiple of one sample (the planner's fitted factor), which the
    /// predicted cost includes.
    pub predicted_sample_factor: f64,
    /// Aperture points each sample is lit through (0: a pinhole).
    pub aperture_points: u16,
    /// Through the aperture, the share of the pixels in the field whose
    /// aperture rays the fast loop does not trace (their sums are one: the
    /// chief ray's; `Frame::aperture_classes`, every pixel). `None`
    /// without defocus or in the wide arithmetic.
    pub aperture_spared: Option<f64>,
    /// Through the aperture, the planner's shares of the pixels whose rays
    /// the loop traces through every primitive, and tests against one
    /// rectangle alone (`planner::Samples::traced`, `only`: the frame's rule
    /// on every `planner::APERTURE_STRIDE`-th row and column), which the
    /// predicted cost counts; `None` without defocus.
    pub aperture_shares: Option<[f64; 2]>,
    /// Rays from one the closed plane shades to the next: 2 or 4 where
    /// those between take interpolated sums (`Options::closed_mean`; its
    /// bound is in `predicted_lsb`), 1 without.
    pub closed_mean: u32,
    /// Largest blur-circle diameter of content in view, px.
    pub blur_px: f64,
    /// Content in view lies outside the depth of field.
    pub outside_dof: bool,
    /// Predicted defocus error, px: the aperture pattern's placement error,
    /// or the blur left out when the aperture is not sampled.
    pub predicted_defocus_err_px: f64,
    /// Shadow tests a sample takes on average, predicted (0: none needed),
    /// and their share of the predicted M3 instructions a pixel.
    pub predicted_shadow_tests: f64,
    pub predicted_shadow_m3: f64,
    /// Of the shadow tests, those that take the exact test (the rest the
    /// fast arithmetic's pre-test clears).
    pub predicted_shadow_exact: f64,
}

/// `metrics.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Metrics {
    /// Scene name.
    pub scene: String,
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Output format.
    pub format: String,
    /// Significant bits per channel (largest channel).
    pub bits: u32,
    /// Stages the core ran.
    pub stages: Vec<String>,
    /// The planner's choice.
    pub plan: PlanReport,
    /// Distortion table bytes.
    pub table_bytes: usize,
    /// Largest |core − reference| over all pixels and channels, LSB.
    pub max_abs_lsb: u32,
    /// RMS difference over all samples, LSB.
    pub rms_lsb: f64,
    /// Fraction of pixels identical in every channel.
    pub exact_fraction: f64,
    /// PSNR over all pixels, dB (per-channel full scale); null when identical.
    pub psnr_db: Option<f64>,
    /// Largest distance between the core's and the reference's pixel →
    /// undistorted image point, over pixels both place in the lens field, px.
    pub max_geom_err_px: f64,
    /// RMS of that distance, px.
    pub rms_geom_err_px: f64,
    /// Pixels a 1/256 px move of whose centre changes what the reference ray
    /// hits (primitive, texture cell) or its in-field flag.
    pub edge_pixels: usize,
    /// Edge pixels whose values differ.
    pub edge_pixels_differing: usize,
    /// `edge_pixels_differing` as a fraction of all pixels.
    pub edge_pixels_differing_fraction: f64,
    /// Largest |core − reference| over smooth (non-edge) pixels, LSB.
    pub max_abs_lsb_smooth: u32,
    /// RMS over smooth pixels, LSB.
    pub rms_lsb_smooth: f64,
    /// PSNR over smooth pixels, dB; null when identical.
    pub psnr_db_smooth: Option<f64>,
    /// Fraction of smooth pixels identical.
    pub exact_fraction_smooth: f64,
    /// Pixels outside the lens field (reference).
    pub outside_field_pixels: usize,
    /// Pixels whose in-field flag differs between core and reference.
    pub field_flags_differing: usize,
    /// The sample pattern's own error: the reference with the frame's
    /// pattern against the reference with 16×16 samples a pixel, before
    /// rounding and without noise (null when the frame has one sample a
    /// pixel).
    pub sampling_error: Option<SamplingError>,
    /// The aperture pattern's own error: the reference with the frame's
    /// aperture points against the reference with
    /// [`crate::reference::defocus::CONVERGED`], before rounding and without
    /// noise (null when the frame does not sample the aperture).
    pub defocus_error: Option<DefocusError>,
}

impl Metrics {
    /// Where the frame exceeds what its plan predicted — smooth pixels
    /// beyond `⌊predicted LSB⌋ + 1` (the prediction is before rounding),
    /// geometry beyond the predicted error (+0.1 % and 10⁻⁹ px for the
    /// reference's own rounding) — one line naming each; `None` within.
    pub fn beyond_prediction(&self) -> Option<String> {
        let p = &self.plan;
        let mut out = Vec::new();
        if self.max_abs_lsb_smooth as f64 > p.predicted_lsb.floor() + 1.0 {
            out.push(format!(
                "smooth pixels {} LSB off, over the predicted {} (+ rounding)",
                self.max_abs_lsb_smooth, p.predicted_lsb
            ));
        }
        if self.max_geom_err_px > p.predicted_geom_err_px * 1.001 + 1e-9 {
            out.push(format!(
                "geometry {} px off, over the predicted {}",
                self.max_geom_err_px, p.predicted_geom_err_px
            ));
        }
        (!out.is_empty()).then(|| format!("{}: {}", self.scene, out.join("; ")))
    }
}

/// The aperture pattern's error against a converged estimate.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DefocusError {
    /// Largest |pattern − converged| over pixels and channels, DN.
    pub max_dn: f64,
    /// RMS over pixels and channels, DN.
    pub rms_dn: f64,
    /// Aperture points of the converged estimate.
    pub converged_points: u16,
}

/// The sample pattern's error against a converged estimate.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SamplingError {
    /// Largest |pattern − converged| over pixels and channels, DN.
    pub max_dn: f64,
    /// RMS over pixels and channels, DN.
    pub rms_dn: f64,
    /// Pixels the pattern sampled with the full grid (adaptive: the others
    /// took their centre).
    pub grid_pixels: usize,
}

/// Everything one render produced.
pub struct RenderOutput {
    /// Core frame bytes.
    pub core: Collect,
    /// Core values per channel.
    pub core_dn: Vec<[u32; 3]>,
    /// Reference frame.
    pub reference: RefFrame,
    /// Metrics.
    pub metrics: Metrics,
    /// The plan.
    pub plan: Plan,
    /// Output format.
    pub format: PixelFormat,
}

/// Decodes frame bytes into channel values, a pixel at a time.
pub fn decode_all(format: PixelFormat, bytes: &[u8]) -> Vec<[u32; 3]> {
    bytes
        .chunks_exact(format.bytes_per_pixel())
        .map(|b| format.unpack(b))
        .collect()
}

/// The core's scene, its plan for `budget`, and the frame prepared with
/// the options `options` takes from the plan (a variant's; `|p| p.options`
/// for the default path).
pub fn prepare<S: Scalar>(
    r: &Resolved,
    budget: &Budget,
    options: impl FnOnce(&Plan) -> Options,
) -> Result<(hilcam::scene::Scene, Plan, Frame<S>), String> {
    let scene = r.core_scene()?;
    let (plan, frame) = prepare_scene(&scene, &r.desc.name, budget, options)?;
    Ok((scene, plan, frame))
}

/// [`prepare`] of a core scene (`name` for errors).
pub fn prepare_scene<S: Scalar>(
    scene: &hilcam::scene::Scene,
    name: &str,
    budget: &Budget,
    options: impl FnOnce(&Plan) -> Options,
) -> Result<(Plan, Frame<S>), String> {
    let plan = planner::plan(scene, budget);
    let frame = Frame::<S>::build(scene, &options(&plan))
        .map_err(|e| format!("{name}: cannot render: {e} ({e:?})"))?;
    Ok((plan, frame))
}

/// The default path's frame `frame_id` of a core scene (the planner's
/// choice within `budget`, lines in parallel): what a camera planning
/// within `budget` sends for that scene and frame, and the stages it ran.
pub fn planned_frame(
    scene: &hilcam::scene::Scene,
    name: &str,
    budget: &Budget,
    frame_id: u32,
) -> Result<(Collect, hilcam::render::Stages), String> {
    let (_, mut frame) = prepare_scene::<hilcam::num::scalar::I32F32>(scene, name, budget, |p| p.options)?;
    frame.set_frame_id(frame_id);
    let core = collect(&frame).map_err(|e| format!("{name}: {e}"))?;
    Ok((core, frame.stages()))
}

/// The core's scene, its plan for `budget`, the prepared frame, and the
/// frame rendered line by line (bytes and flags).
pub fn core_render(
    r: &Resolved,
    budget: &Budget,
) -> Result<(hilcam::scene::Scene, Plan, Frame, Collect), String> {
    let (scene, plan, frame) = prepare(r, budget, |p| p.options)?;
    let core = collect(&frame).map_err(|e| format!("{}: {e}", r.desc.name))?;
    Ok((scene, plan, frame, core))
}

/// The comparison of core and reference pixels, accumulated a line at a
/// time (lines in any grouping, merged in any order).
#[derive(Clone, Debug, Default)]
pub struct Tally {
    max_geom: f64,
    sq_geom: f64,
    n_geom: usize,
    max_all: u32,
    max_smooth: u32,
    sq_all: f64,
    sq_smooth: f64,
    nsq_all: f64,
    nsq_smooth: f64,
    pixels: usize,
    exact: usize,
    exact_smooth: usize,
    smooth: usize,
    edges: usize,
    edges_diff: usize,
    flags_diff: usize,
    outside: usize,
    samp: StageTally,
    samp_grid: usize,
    def: StageTally,
}

/// A stage's estimate against its converged estimate, accumulated.
#[derive(Clone, Copy, Debug, Default)]
struct StageTally {
    max: f64,
    sq: f64,
    n: usize,
}

impl StageTally {
    fn merge(&mut self, o: &StageTally) {
        self.max = self.max.max(o.max);
        self.sq += o.sq;
        self.n += o.n;
    }

    fn add(&mut self, a: [f64; 3], b: [f64; 3], channels: usize) {
        for c in 0..channels {
            let d = (a[c] - b[c]).abs();
            self.max = self.max.max(d);
            self.sq += d * d;
            self.n += 1;
        }
    }

    fn rms(&self) -> f64 {
        (self.sq / self.n.max(1) as f64).sqrt()
    }
}

impl Tally {
    /// Adds the counts of `o`.
    pub fn merge(&mut self, o: &Tally) {
        self.max_geom = self.max_geom.max(o.max_geom);
        self.sq_geom += o.sq_geom;
        self.n_geom += o.n_geom;
        self.max_all = self.max_all.max(o.max_all);
        self.max_smooth = self.max_smooth.max(o.max_smooth);
        self.sq_all += o.sq_all;
        self.sq_smooth += o.sq_smooth;
        self.nsq_all += o.nsq_all;
        self.nsq_smooth += o.nsq_smooth;
        self.pixels += o.pixels;
        self.exact += o.exact;
        self.exact_smooth += o.exact_smooth;
        self.smooth += o.smooth;
        self.edges += o.edges;
        self.edges_diff += o.edges_diff;
        self.flags_diff += o.flags_diff;
        self.outside += o.outside;
        self.samp.merge(&o.samp);
        self.samp_grid += o.samp_grid;
        self.def.merge(&o.def);
    }
}

/// Compares line `j` of a core frame (its channel values and flags) with
/// the reference's.
pub fn tally_line<S: Scalar>(
    rs: &RefScene,
    frame: &Frame<S>,
    j: usize,
    core_dn: &[[u32; 3]],
    core_flags: &[u8],
    reference: RefRow<'_>,
) -> Tally {
    let format = rs.format;
    let (fx, fy) = (rs.sensor.f / rs.sensor.sx, rs.sensor.f / rs.sensor.sy);
    let channels = format.channels();
    let dn_max = [0, 1, 2].map(|c| format.dn_max(c.min(channels - 1)) as f64);
    let mut t = Tally::default();
    for (i, (c, cf)) in core_dn.iter().zip(core_flags).enumerate() {
        // Geometry: the core's pixel → undistorted mapping against the
        // reference, where both place the pixel in the lens field.
        if let (Some((cx, cy)), Some((rx, ry))) =
            (frame.undistorted(i as u16, j as u16), reference.undistorted[i])
        {
            let e = ((cx.to_f64() - rx) * fx).hypot((cy.to_f64() - ry) * fy);
            t.max_geom = t.max_geom.max(e);
            t.sq_geom += e * e;
            t.n_geom += 1;
        }
        let rf = reference.dn[i];
        let mut same = true;
        let mut pmax = 0;
        let (mut psq, mut pnsq) = (0.0, 0.0);
        for ch in 0..channels {
            let d = c[ch].abs_diff(rf[ch]);
            same &= d == 0;
            pmax = pmax.max(d);
            psq += (d as f64).powi(2);
            pnsq += (d as f64 / dn_max[ch]).powi(2);
        }
        let core_in = cf & FLAG_OUTSIDE_FIELD == 0;
        t.flags_diff += (core_in != reference.in_field[i]) as usize;
        t.outside += (!reference.in_field[i]) as usize;
        t.pixels += 1;
        t.max_all = t.max_all.max(pmax);
        t.sq_all += psq;
        t.nsq_all += pnsq;
        t.exact += same as usize;
        if reference.edge[i] {
            t.edges += 1;
            t.edges_diff += (!same) as usize;
        } else {
            t.smooth += 1;
            t.max_smooth = t.max_smooth.max(pmax);
            t.sq_smooth += psq;
            t.nsq_smooth += pnsq;
            t.exact_smooth += same as usize;
        }
    }
    t
}

/// Whether a render measures its sampling and defocus stages against
/// converged estimates ([`Converged`]), as `host-sim render` does
/// (`metrics.json`'s `sampling_error` and `defocus_error`). Where a frame
/// samples, they cost more than the comparison itself: 16×16 reference
/// samples a pixel, [`crate::reference::defocus::CONVERGED`] aperture
/// points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageErrors {
    /// Measured: the metrics have them where the frame samples.
    Measured,
    /// Not measured: `sampling_error` and `defocus_error` are `None`; the
    /// comparison with the reference sampled as the frame is, whole.
    Skipped,
}

/// The converged estimates a frame's stages are measured against: the
/// reference with 16×16 samples a pixel (where the frame samples the pixel
/// area) and with [`crate::reference::defocus::CONVERGED`] aperture points
/// (where it samples the aperture), the rest of the pattern the frame's.
pub struct Converged {
    grid: Option<RefScene>,
    aperture: Option<RefScene>,
}

impl Converged {
    /// For `rs` (sampled as the frame is); none where `stage_errors` skips
    /// them.
    pub fn of(rs: &RefScene, stage_errors: StageErrors) -> Converged {
        let p = rs.pattern;
        let measured = stage_errors == StageErrors::Measured;
        Converged {
            grid: (measured && p.n > 1).then(|| rs.with_pattern(p.converged_grid())),
            aperture: (measured && p.aperture > 0).then(|| rs.with_pattern(p.converged_aperture())),
        }
    }

    /// Adds line `j`'s stage errors (`rs`'s pattern against the converged
    /// ones) to `t`, before rounding and without noise.
    fn tally(&self, rs: &RefScene, j: usize, t: &mut Tally) {
        if self.grid.is_none() && self.aperture.is_none() {
            return;
        }
        let channels = rs.format.channels();
        for i in 0..rs.sensor.width as usize {
            let Some(a) = rs.area_mean(i, j) else {
                continue;
            };
            if let Some(Some(b)) = self.grid.as_ref().map(|g| g.area_mean(i, j)) {
                t.samp_grid += rs.takes_grid(i, j) as usize;
                t.samp.add(a, b, channels);
            }
            if let Some(Some(b)) = self.aperture.as_ref().map(|g| g.area_mean(i, j)) {
                t.def.add(a, b, channels);
            }
        }
    }
}

/// The render metrics of a core frame against the reference frame of the
/// same scene.
pub fn compare<S: Scalar>(
    r: &Resolved,
    rs: &RefScene,
    reference: &RefFrame,
    plan: &Plan,
    budget: &Budget,
    frame: &Frame<S>,
    core: &Collect,
) -> Metrics {
    let (w, h) = frame.size();
    let (w, lb) = (w as usize, frame.line_bytes());
    let mut t = Tally::default();
    for j in 0..h as usize {
        let dn = decode_all(r.format, &core.pixels[j * lb..(j + 1) * lb]);
        t.merge(&tally_line(
            rs,
            frame,
            j,
            &dn,
            &core.flags[j * w..(j + 1) * w],
            reference.row(j),
        ));
    }
    // The pattern's own errors against converged estimates, lines in
    // parallel.
    {
        use rayon::prelude::*;
        let conv = Converged::of(rs, StageErrors::Measured);
        let parts: Vec<Tally> = (0..h as usize)
            .into_par_iter()
            .map(|j| {
                let mut l = Tally::default();
                conv.tally(rs, j, &mut l);
                l
            })
            .collect();
        for p in &parts {
            t.merge(p);
        }
    }
    metrics(r, plan, budget, frame, &t, StageErrors::Measured)
}

/// The planner's choice as reported, for the frame prepared from it.
pub fn plan_report<S: Scalar>(plan: &Plan, budget: &Budget, frame: &Frame<S>) -> PlanReport {
    let stages = frame.stages();
    PlanReport {
        arithmetic: stages.arithmetic.name().into(),
        chosen: plan
            .candidates
            .get(plan.chosen)
            .map_or_else(String::new, |c| c.name().to_string()),
        why: plan_why(plan, budget),
        candidates: plan
            .candidates
            .iter()
            .map(|c| CandidateReport {
                name: c.name().to_string(),
                unfit: c.fits.err().map(|u| u.reason().to_string()),
                geom_err_px: c.geom_err_px,
                lsb: c.lsb,
                mean_lsb: c.mean_lsb,
                m3_instructions_per_pixel: c.m3_instructions_per_pixel,
                edge_differing: c.edge_differing,
                meets_budget: c.meets(budget),
            })
            .collect(),
        predicted_m3_instructions_per_pixel: plan.predicted_m3_instructions_per_pixel,
        model: stages.model.name().trim_start_matches("rays:").into(),
        mean_depth_m: match stages.model {
            hilcam::render::RenderModel::WeakPerspective { mean_depth } => Some(mean_depth.to_num()),
            _ => None,
        },
        lut_entries: stages.distortion_lut.unwrap_or(0),
        lut_format: frame.table_frac_bits().map(|f| format!("I{}F{}", 32 - f, f)),
        predicted_geom_err_px: plan.predicted_geom_err_px,
        weak_perspective_err_px: plan.weak_perspective_err_px,
        predicted_lsb: plan.predicted_lsb,
        meets_budget: plan.meets_budget,
        budget_geom_px: budget.max_geom_err_px,
        budget_lsb: budget.max_lsb,
        samples: stages.samples,
        adaptive: stages.adaptive,
        predicted_edge_err_px: plan.predicted_edge_err_px,
        predicted_samples_per_pixel: plan.samples.grid,
        predicted_sample_factor: plan.predicted_sample_factor,
        aperture_points: stages.aperture,
        aperture_spared: frame
            .aperture_classes(1)
            .map(|n| 1.0 - f64::from(n.traced + n.only) / f64::from(n.field.max(1))),
        aperture_shares: (stages.aperture > 0).then_some([plan.samples.traced, plan.samples.only]),
        closed_mean: plan.options.closed_mean.span(),
        predicted_shadow_tests: plan.candidates.get(plan.chosen).map_or(0.0, |c| c.shadow_tests),
        predicted_shadow_exact: plan.candidates.get(plan.chosen).map_or(0.0, |c| c.shadow_exact),
        predicted_shadow_m3: plan.candidates.get(plan.chosen).map_or(0.0, |c| c.shadow_m3),
        blur_px: plan.defocus.blur_px,
        outside_dof: plan.defocus.outside_dof,
        predicted_defocus_err_px: if stages.aperture > 0 {
            hilcam::render::sensor::defocus::placement(stages.aperture) * plan.defocus.blur_px
        } else {
            plan.defocus.blur_px
        },
    }
}

/// The metrics from a whole frame's [`Tally`] (its stage errors as
/// `stage_errors` says it measured them).
pub fn metrics<S: Scalar>(
    r: &Resolved,
    plan: &Plan,
    budget: &Budget,
    frame: &Frame<S>,
    t: &Tally,
    stage_errors: StageErrors,
) -> Metrics {
    let measured = stage_errors == StageErrors::Measured;
    let (w, h) = frame.size();
    let (w, h) = (w as usize, h as usize);
    let format = r.format;
    let channels = format.channels();
    let n_all = (t.pixels * channels).max(1) as f64;
    let n_smooth = (t.smooth * channels).max(1) as f64;
    let psnr = |nsq: f64, n: f64| (nsq > 0.0).then(|| 10.0 * (n / nsq).log10());
    let bits = (0..channels)
        .map(|c| 32 - format.dn_max(c).leading_zeros())
        .max()
        .unwrap_or(8);
    let px = t.pixels.max(1) as f64;
    Metrics {
        scene: r.desc.name.clone(),
        width: w,
        height: h,
        format: format.name().into(),
        bits,
        stages: frame.stages().names().iter().map(|s| s.to_string()).collect(),
        plan: plan_report(plan, budget, frame),
        table_bytes: frame.table_bytes(),
        max_abs_lsb: t.max_all,
        rms_lsb: (t.sq_all / n_all).sqrt(),
        exact_fraction: t.exact as f64 / px,
        psnr_db: psnr(t.nsq_all, n_all),
        max_geom_err_px: t.max_geom,
        rms_geom_err_px: (t.sq_geom / t.n_geom.max(1) as f64).sqrt(),
        edge_pixels: t.edges,
        edge_pixels_differing: t.edges_diff,
        edge_pixels_differing_fraction: t.edges_diff as f64 / px,
        max_abs_lsb_smooth: t.max_smooth,
        rms_lsb_smooth: (t.sq_smooth / n_smooth).sqrt(),
        psnr_db_smooth: psnr(t.nsq_smooth, n_smooth),
        exact_fraction_smooth: t.exact_smooth as f64 / t.smooth.max(1) as f64,
        outside_field_pixels: t.outside,
        field_flags_differing: t.flags_diff,
        sampling_error: (measured && frame.stages().samples > 1).then(|| SamplingError {
            max_dn: t.samp.max,
            rms_dn: t.samp.rms(),
            grid_pixels: t.samp_grid,
        }),
        defocus_error: (measured && frame.stages().aperture > 0).then(|| DefocusError {
            max_dn: t.def.max,
            rms_dn: t.def.rms(),
            converged_points: crate::reference::defocus::CONVERGED,
        }),
    }
}

/// One line rendered by both, and compared.
pub struct LineOut {
    /// Core bytes.
    pub pixels: Vec<u8>,
    /// Core flags.
    pub flags: Vec<u8>,
    /// Core channel values.
    pub core_dn: Vec<[u32; 3]>,
    /// The reference's line.
    pub reference: RefFrame,
    /// The comparison.
    pub tally: Tally,
}

/// The samples a pixel and aperture points `frame` renders with, as the
/// reference's pattern: the reference sampled as the frame is.
pub fn frame_pattern<S: Scalar>(frame: &Frame<S>) -> Pattern {
    let st = frame.stages();
    Pattern {
        n: st.samples,
        adaptive: st.adaptive,
        aperture: st.aperture,
    }
}

/// Renders every line with the core and the reference, compares them, and
/// hands the lines to `sink` in order. Lines are rendered in parallel on
/// every core, a band at a time, so memory stays O(width).
pub fn run_lines<S: Scalar>(
    frame: &Frame<S>,
    rs: &RefScene,
    stage_errors: StageErrors,
    sink: &mut dyn FnMut(LineOut) -> Result<(), String>,
) -> Result<Tally, String> {
    use rayon::prelude::*;
    let (w, h) = frame.size();
    // The reference samples each pixel as the frame does; where the frame
    // has more than one sample a pixel, the pattern's own error is measured
    // against 16×16 (unless `stage_errors` skips it).
    let rs = &rs.with_pattern(frame_pattern(frame));
    let converged = Converged::of(rs, stage_errors);
    let band = rayon::current_num_threads().max(1) * 4;
    let mut total = Tally::default();
    for j0 in (0..h as usize).step_by(band) {
        let lines = (j0..(j0 + band).min(h as usize))
            .into_par_iter()
            .map(|j| -> Result<LineOut, String> {
                let mut pixels = vec![0u8; frame.line_bytes()];
                let mut flags = vec![0u8; w as usize];
                render_line(frame, j as u16, &mut pixels, &mut flags)
                    .map_err(|e| format!("render failed: {e:?}"))?;
                let core_dn = decode_all(rs.format, &pixels);
                let reference = rs.render_line(j);
                let mut tally = tally_line(rs, frame, j, &core_dn, &flags, reference.row(0));
                converged.tally(rs, j, &mut tally);
                Ok(LineOut {
                    pixels,
                    flags,
                    core_dn,
                    reference,
                    tally,
                })
            })
            .collect::<Vec<_>>();
        for l in lines {
            let l = l?;
            total.merge(&l.tally);
            sink(l)?;
        }
    }
    Ok(total)
}

/// Renders with both, and compares, in memory: what `host-sim render`
/// measures, the stage errors too.
pub fn render(r: &Resolved, budget: &Budget) -> Result<RenderOutput, String> {
    render_with(r, budget, StageErrors::Measured, |o| o)
}

/// [`render`] without the stage errors ([`StageErrors::Skipped`]): the
/// frame against the reference sampled as it is, for what asks no more.
pub fn render_skipping_stage_errors(r: &Resolved, budget: &Budget) -> Result<RenderOutput, String> {
    render_with(r, budget, StageErrors::Skipped, |o| o)
}

/// [`render`] with the plan's options as `options` changes them (a
/// variant's), measuring the stage errors as `stage_errors` says; the
/// metrics still report the plan.
pub fn render_with(
    r: &Resolved,
    budget: &Budget,
    stage_errors: StageErrors,
    options: impl FnOnce(Options) -> Options,
) -> Result<RenderOutput, String> {
    let (scene, plan, frame) = prepare::<hilcam::num::scalar::I32F32>(r, budget, |p| options(p.options))?;
    let rs = RefScene::new(r);
    let (w, h) = frame.size();
    let mut core = Collect {
        pixels: Vec::with_capacity(frame.line_bytes() * h as usize),
        flags: Vec::with_capacity(w as usize * h as usize),
    };
    let mut core_dn = Vec::with_capacity(w as usize * h as usize);
    let mut reference = RefFrame {
        width: w as usize,
        height: h as usize,
        dn: Vec::new(),
        in_field: Vec::new(),
        edge: Vec::new(),
        undistorted: Vec::new(),
    };
    let t = run_lines(&frame, &rs, stage_errors, &mut |l| {
        core.pixels.extend_from_slice(&l.pixels);
        core.flags.extend_from_slice(&l.flags);
        core_dn.extend_from_slice(&l.core_dn);
        reference.append(l.reference);
        Ok(())
    })?;
    let metrics = metrics(r, &plan, budget, &frame, &t, stage_errors);
    Ok(RenderOutput {
        core,
        core_dn,
        reference,
        metrics,
        plan,
        format: scene.format(),
    })
}

/// Why the planner chose what it chose, in a sentence.
pub fn plan_why(plan: &Plan, budget: &Budget) -> String {
    let Some(c) = plan.candidates.get(plan.chosen) else {
        return "no candidate".into();
    };
    let within = plan.candidates.iter().filter(|c| c.meets(budget)).count();
    // A weak-perspective candidate predicted cheaper by less than
    // `planner::WEAK_MARGIN`: perspective rays kept.
    let weak = plan.candidates.iter().find(|w| {
        w.meets(budget)
            && matches!(w.model, hilcam::render::RenderModel::WeakPerspective { .. })
            && w.m3_instructions_per_pixel < c.m3_instructions_per_pixel
    });
    if c.meets(budget) {
        format!(
            "{} is the cheapest of {within} candidate(s) within the budget ({:.0} predicted M3 \
             instructions/pixel; {:.2e} px, {:.3} LSB before rounding{}){}",
            c.name(),
            c.m3_instructions_per_pixel,
            c.geom_err_px,
            plan.predicted_lsb,
            match plan.options.closed_mean {
                ClosedMean::Off => "",
                ClosedMean::Pairs => ", with the closed plane's mean over 2 rays",
                ClosedMean::Quads => ", with the closed plane's mean over 4 rays",
                ClosedMean::Octs => ", with the closed plane's mean over 8 rays",
            },
            match weak {
                Some(w) => format!(
                    "; {}, predicted {:.1} % cheaper, is not: weak perspective must save {} %",
                    w.name(),
                    100.0 * (1.0 - w.m3_instructions_per_pixel / c.m3_instructions_per_pixel),
                    100.0 * hilcam::planner::WEAK_MARGIN
                ),
                None => String::new(),
            }
        )
    } else {
        format!(
            "no candidate meets the budget ({} px, {} LSB, {} % differing at edges): {} is the most \
             accurate that fits ({:.2e} px, {:.3} LSB before rounding)",
            budget.max_geom_err_px,
            budget.max_lsb,
            100.0 * budget.max_edge_differing,
            c.name(),
            c.geom_err_px,
            plan.predicted_lsb
        )
    }
}
