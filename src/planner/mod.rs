//! The planner: given a scene and an error budget, predicts for every way of
//! rendering it considers the error (geometric px, LSB) and the cost (M3
//! instructions a pixel), and picks the cheapest within the budget.
//!
//! - **Ray model.** A telecentric (orthographic) camera is rendered
//!   orthographically. A perspective camera is rendered with parallel
//!   (weak-perspective) rays when every primitive is bounded and the §2 error
//!   bound over the camera-frame box around them, at `Z̄` = the box's mean
//!   depth, is within half the geometric budget; otherwise in perspective.
//! - **Candidates.** The arithmetic ([`Arithmetic::Fast`], the 32-bit path
//!   with a format per quantity, or [`Arithmetic::Wide`], I32F32) times the
//!   distortion evaluation: the polynomial, or the smallest power-of-two
//!   table (2 to 1 024 entries, linearly interpolated) whose error
//!   `|k2| h²/4` plus the entries' rounding is within half the geometric
//!   budget (the fast arithmetic evaluates the polynomial only).
//! - **Error** ([`ErrorModel`]): the geometric error of the pixel →
//!   undistorted mapping, and a bound on `|core − reference|` before the
//!   final rounding, from the arithmetic's resolution propagated through the
//!   scene's own magnitudes: relative rounding of the radiometric chain,
//!   hit points and normals (including the ill-conditioned band next to a
//!   sphere's silhouette, down to 1/256 px from it, where pixels stop being
//!   edge pixels), and the specular lobe, whose exponent multiplies the
//!   error of `r̂·v̂`. At edges, the expected share of pixels that differ
//!   from the reference ([`Candidate::edge_differing`]): every look a pixel
//!   takes (samples, the adaptive rule's corners) within the geometric
//!   error of an edge may see the other side, so the fast arithmetic's
//!   larger error weighs with the sample count (an 8×8 grid of a fine
//!   checkerboard goes to the wide one).
//! - **Cost** ([`CostModel`]): M3 instructions a pixel, linear in the
//!   scene's features (primitives by kind, their sampled screen coverage,
//!   lights per shaded pixel, the lobe per pixel that sees it, distortion,
//!   colour, parallel rays),
//!   with coefficients fitted to QEMU counts (`host-sim costfit` fits them
//!   and reports predicted vs measured; `docs/cost-model.md`); a pixel's
//!   samples (a grid over its area, points of the aperture) cost a fixed
//!   overhead plus that per sample, times a factor per aperture point,
//!   fitted to the same counts ([`SampleCost`]).
//! - **Choice.** The cheapest candidate that the arithmetic's formats hold
//!   and whose predictions are within the budget; if none is, the most
//!   accurate, with `meets_budget = false`.
//!
//! Planning runs once per scene, like construction, and uses f64.

use crate::geom::projection::{weak_perspective_bound, DepthBox};
use crate::num::FixedF64;
use crate::render::sensor::noise::{Z_ERR, Z_MAX};
use crate::render::{Arithmetic, ClosedMean, DistortionEval, Options, RenderModel};
use crate::scene::{Light, Scene, Shape};
use crate::{CameraPoint, Len, Model};

/// What the renderer may get wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Largest geometric error, pixels.
    pub max_geom_err_px: f64,
    /// Largest error in pixel value, LSB, over smooth pixels.
    pub max_lsb: f64,
    /// Most distortion-table entries the device holds (its frame's `T`; 2
    /// to [`crate::geom::distortion::MAX_LUT`], fewer than 2: no table).
    pub max_table_entries: usize,
    /// Largest fraction of all pixels that are edge pixels whose value
    /// differs from the reference's (predicted: [`Candidate::edge_differing`]).
    pub max_edge_differing: f64,
}

impl Default for Budget {
    /// 1/256 px, 1 LSB and 0.05 % of the pixels differing at edges.
    fn default() -> Self {
        Budget {
            max_geom_err_px: 1.0 / 256.0,
            max_lsb: 1.0,
            max_table_entries: crate::geom::distortion::MAX_LUT,
            max_edge_differing: 0.0005,
        }
    }
}

/// Why a candidate cannot render a scene on its arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unfit {
    /// Content (primitives, point lights) farther than 8·2²⁰ m.
    TooFar,
    /// A sphere, disc radius or checker cell below 2⁻¹⁰ of the frame's
    /// length unit (the content's extent / 8).
    TooSmall,
    /// The distortion factor `g` or `k1 + k2 u` leaves ±8 over the sensor.
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
    /// there, since nothing marks its pixel as an edge; before
    /// c5d6afa on shallow-dof 14 pixels differed from the reference, one
    /// by 2 LSB, and the loop was never planned.)
    Defocus,
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
        }
    }
}

/// One way of rendering the scene, with its predictions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// The ray model.
    pub model: RenderModel,
    /// The arithmetic.
    pub arithmetic: Arithmetic,
    /// How distortion is evaluated (`None`: the lens has none).
    pub distortion: Option<DistortionEval>,
    /// Table entries when a table is used (0 otherwise).
    pub lut_entries: usize,
    /// `Err` if the arithmetic's formats cannot hold the scene.
    pub fits: Result<(), Unfit>,
    /// Predicted largest pixel → undistorted error, px.
    pub geom_err_px: f64,
    /// Predicted largest `|core − reference|` before the final rounding,
    /// LSB (both round, so the rounded values differ by at most this +½).
    pub lsb: f64,
    /// Predicted cost, M3 instructions a pixel.
    pub m3_instructions_per_pixel: f64,
    /// How the closed plane's rays between those shaded take interpolated
    /// sums (`Options::closed_mean`; its bound is in `lsb`).
    pub closed_mean: ClosedMean,
    /// What the mean alone moves a value by at most, LSB (0 without it):
    /// its bound on the sum and, with noise, on `σ z` (`noise_moved`).
    pub mean_lsb: f64,
    /// Predicted fraction of all pixels that are edge pixels whose value
    /// differs from the reference's: a look (sample, corner, centre)
    /// within the geometric error of an edge can see the other side. The
    /// expected count, not a bound: edge length per pixel area
    /// (`edge_fraction`'s estimate) × 2 × `geom_err_px` × looks per pixel
    /// area (`n²`, with the adaptive rule `+ 5`: a corner decides for four
    /// pixels, the centre for one); a checkered plane's cells integrated
    /// over the field instead, with the arithmetic's error in the texture
    /// coordinate (`Geometry::cells_differing`).
    pub edge_differing: f64,
}

impl Candidate {
    /// True if the formats hold the scene and the predictions are within
    /// `budget` (geometry within half of it, the rest for the ray model).
    pub fn meets(&self, budget: &Budget) -> bool {
        self.fits.is_ok()
            && self.geom_err_px <= budget.max_geom_err_px / 2.0
            && self.lsb + 0.5 <= budget.max_lsb
            && self.edge_differing <= budget.max_edge_differing
    }

    /// A short name: `fast-poly`, `wide-lut64`, `wide`…, with `-weak` for
    /// weak-perspective rays.
    pub fn name(&self) -> heapless::String<32> {
        use core::fmt::Write as _;
        let mut s = heapless::String::new();
        let a = match self.arithmetic {
            Arithmetic::Fast => "fast",
            Arithmetic::Wide => "wide",
        };
        let _ = match self.distortion {
            None => write!(s, "{a}"),
            Some(DistortionEval::Polynomial) => write!(s, "{a}-poly"),
            Some(DistortionEval::Linear) => write!(s, "{a}-lut{}", self.lut_entries),
            Some(DistortionEval::Nearest) => write!(s, "{a}-lut{}-nearest", self.lut_entries),
        };
        if matches!(self.model, RenderModel::WeakPerspective { .. }) {
            let _ = s.push_str("-weak");
        }
        s
    }
}

/// How much cheaper (a fraction of its cost) weak perspective must be
/// predicted than perspective rays to be chosen for a perspective camera:
/// the two differ in the cost model's parallel-ray terms alone. (Until
/// the calibration measured weak perspective itself, those terms came from
/// orthographic cameras, and shallow-target's two were predicted 0.1 %
/// apart; now 221 and 183, measured 201 and 195: `docs/cost-model.md`.)
pub const WEAK_MARGIN: f64 = 0.01;

/// Most candidates a plan lists.
pub const MAX_CANDIDATES: usize = 6;

/// The planner's choice and its predictions.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// What the renderer is told.
    pub options: Options,
    /// Predicted error of the pixel → undistorted mapping, pixels.
    pub predicted_geom_err_px: f64,
    /// The §2 bound of the weak-perspective approximation over the scene's
    /// bounding box, pixels (`None` if the scene is unbounded or reaches
    /// behind the camera).
    pub weak_perspective_err_px: Option<f64>,
    /// Predicted largest `|core − reference|` before the final rounding,
    /// LSB, of the chosen candidate.
    pub predicted_lsb: f64,
    /// Predicted cost of the chosen candidate, M3 instructions a pixel.
    pub predicted_m3_instructions_per_pixel: f64,
    /// True if every prediction is within the budget.
    pub meets_budget: bool,
    /// Every candidate considered, the chosen one at `chosen`.
    pub candidates: heapless::Vec<Candidate, MAX_CANDIDATES>,
    /// Index of the chosen candidate.
    pub chosen: usize,
    /// Predicted edge-placement error of the sample pattern, pixels
    /// ([`crate::render::sensor::sampling::edge_error`]; ½ for one sample at the centre).
    pub predicted_edge_err_px: f64,
    /// What a pixel takes beyond one sample: its grid's samples (predicted
    /// with the adaptive rule), corner looks and aperture points.
    pub samples: Samples,
    /// What those cost, as a multiple of one sample's cost
    /// ([`SampleCost::factor`], the chosen arithmetic's): the costs above
    /// include it.
    pub predicted_sample_factor: f64,
    /// Defocus: the content's blur and the aperture pattern chosen for it.
    pub defocus: Defocus,
}

impl Plan {
    /// The mean depth `Z̄` of the plan's weak-perspective candidates, metres
    /// (`None`: weak perspective does not hold, or the camera's own model
    /// is not perspective).
    pub fn weak_mean_depth(&self) -> Option<Len> {
        self.candidates.iter().find_map(|c| match c.model {
            RenderModel::WeakPerspective { mean_depth } => Some(mean_depth),
            _ => None,
        })
    }
}

/// Defocus as planned (camera-model.md §8, [`crate::render::sensor::defocus`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Defocus {
    /// Largest blur-circle diameter `β f / s` of content in view, pixels,
    /// over the primitives' depth ranges (bounding spheres; planes over
    /// the field): infinite if content reaches the lens plane, 0 without
    /// content.
    pub blur_px: f64,
    /// Some content in view lies outside the depth of field (`b > b̃`).
    pub outside_dof: bool,
    /// Aperture pattern points (0: the chief ray alone).
    pub points: u16,
    /// Predicted error, px: the pattern's placement error at `blur_px`
    /// ([`crate::render::sensor::defocus::placement`]) with the aperture sampled, else the
    /// blur left out (within the depth of field: at most the tolerable
    /// blur).
    pub err_px: f64,
}

impl Defocus {
    /// No content: nothing blurs, the chief ray alone.
    pub const NONE: Defocus = Defocus {
        blur_px: 0.0,
        outside_dof: false,
        points: 0,
        err_px: 0.0,
    };
}

fn ray_model_and_bound(scene: &Scene, budget: &Budget) -> (RenderModel, Option<(f64, Len)>) {
    let half = budget.max_geom_err_px / 2.0;
    let wp = weak_perspective_over_scene(scene);
    let model = match scene.camera.model {
        Model::Orthographic { scale } => RenderModel::Orthographic { scale },
        Model::WeakPerspective { mean_depth } => RenderModel::WeakPerspective { mean_depth },
        Model::Perspective => match wp {
            Some((err, z_bar)) if err <= half => RenderModel::WeakPerspective { mean_depth: z_bar },
            _ => RenderModel::Perspective,
        },
    };
    (model, wp)
}

/// Whether the frame [`plan`] picks for `scene` with the default budget
/// prepares: what a camera checks before it shows a scene it was sent.
pub fn check<const T: usize>(scene: &Scene) -> Result<(), crate::render::RenderError> {
    let budget = Budget {
        max_table_entries: T,
        ..Budget::default()
    };
    let opts = plan(scene, &budget).options;
    prepares::<T>(scene, &opts)
}

/// Whether a frame prepares `scene` with `opts`. Out of line: the frame is
/// not on the stack while [`plan`] runs.
#[inline(never)]
fn prepares<const T: usize>(
    scene: &Scene,
    opts: &crate::render::Options,
) -> Result<(), crate::render::RenderError> {
    crate::render::Frame::<crate::scene::Q, T>::empty().prepare(scene, opts)
}

/// Plans `scene` within `budget`: every candidate (ray model, arithmetic,
/// distortion evaluation) predicted, the cheapest within the budget
/// chosen. A perspective camera whose content weak perspective holds
/// within half the geometric budget has both ray models among its
/// candidates; through the aperture, rays are perspective.
pub fn plan(scene: &Scene, budget: &Budget) -> Plan {
    let p = plan_with(scene, budget, Shares::TRACED);
    // Through the aperture, the fast loop traces only some pixels' rays:
    // the shares of its frame's pixels, then the candidates again with
    // them (the first plan's options are that frame's).
    if p.candidates
        .iter()
        .any(|c| c.arithmetic == Arithmetic::Fast && c.fits.is_ok())
    {
        let shares = fast_shares(scene, &p.options);
        if shares != Shares::TRACED {
            return plan_with(scene, budget, shares);
        }
    }
    p
}

/// The [`Shares`] of `scene` through `opts`' aperture in the fast
/// arithmetic ([`aperture_shares`]); every pixel traced without an
/// aperture, where that frame does not prepare, and in a `compact` build
/// (the driven camera: on the M0 the classification took 548 B more of its
/// planning stack and 7 872 B of flash, a second frame type; it predicts
/// every pixel traced, the same choice at a higher predicted cost).
#[inline]
fn fast_shares(scene: &Scene, opts: &Options) -> Shares {
    #[cfg(all(feature = "mix32", not(feature = "compact")))]
    if opts.aperture > 0 {
        if let Some(s) = aperture_shares(scene, opts) {
            return s;
        }
    }
    let _ = (scene, opts);
    Shares::TRACED
}

/// Through the aperture, the shares of the frame's pixels whose aperture
/// rays the fast loop traces through every primitive and tests against
/// one rectangle alone ([`Samples::traced`], [`Samples::only`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Shares {
    traced: f64,
    only: f64,
}

impl Shares {
    /// Every pixel's rays traced: the wide arithmetic's loop, and the
    /// pinhole's.
    const TRACED: Shares = Shares {
        traced: 1.0,
        only: 0.0,
    };
}

/// Every `APERTURE_STRIDE`-th row and column of a defocused frame is
/// classified for [`Samples::traced`] and [`Samples::only`] (a 160×120
/// frame: 1 200 pixels).
pub const APERTURE_STRIDE: u16 = 4;

/// [`Shares`] of `scene` rendered with `opts` in the fast arithmetic (its
/// polynomial distortion: the table is not the frame's to choose here),
/// from the frame's own rule (`mix32::Mix32::aperture_classes`) on every
/// [`APERTURE_STRIDE`]-th row and column; `None` where that frame does
/// not prepare or has no aperture. Out of line: the frame is not on the
/// stack while the planner's geometry is.
#[cfg(all(feature = "mix32", not(feature = "compact")))]
#[inline(never)]
fn aperture_shares(scene: &Scene, opts: &Options) -> Option<Shares> {
    let opts = Options {
        arithmetic: Arithmetic::Fast,
        distortion_eval: DistortionEval::Polynomial,
        lut_entries: 2,
        ..*opts
    };
    let mut frame = crate::render::Frame::<crate::scene::Q, 2>::empty();
    frame.prepare(scene, &opts).ok()?;
    let c = frame.aperture_classes(APERTURE_STRIDE)?;
    let n = f64::from(c.pixels.max(1));
    Some(Shares {
        traced: f64::from(c.traced) / n,
        only: f64::from(c.only) / n,
    })
}

/// [`plan`] with the fast arithmetic's aperture `shares`.
#[inline(never)]
fn plan_with(scene: &Scene, budget: &Budget, shares: Shares) -> Plan {
    let cam = &scene.camera;
    let half = budget.max_geom_err_px / 2.0;
    let (first, wp) = ray_model_and_bound(scene, budget);
    let both =
        matches!(first, RenderModel::WeakPerspective { .. }) && matches!(cam.model, Model::Perspective);
    let edge_budget = scene.sampling.map_or(0.5, |s| s.edge_error_px.f64());
    let (samples, adaptive) = crate::render::sensor::sampling::of_scene(scene);
    let mut cands: heapless::Vec<Candidate, MAX_CANDIDATES> = heapless::Vec::new();
    // Each model's sample terms and defocus (a geometry at a time: it is
    // large, and the M0's planning stack small).
    let mut per_model: heapless::Vec<(RenderModel, Samples, Defocus), 2> = heapless::Vec::new();
    for mut model in [Some(first), both.then_some(RenderModel::Perspective)]
        .into_iter()
        .flatten()
    {
        let mut g = Geometry::of(scene, model);
        let df = defocus(scene, &g, edge_budget);
        if df.points > 0 && model != RenderModel::Perspective {
            // Through the aperture, rays are perspective (the second
            // model, if any, is that one).
            model = RenderModel::Perspective;
            g = Geometry::of(scene, model);
        }
        if per_model.iter().any(|m| m.0 == model) {
            continue;
        }
        if df.points > 0 {
            g.through_aperture(scene);
        }
        let terms = Samples::of(scene, &g, samples, adaptive, df.points);
        let _ = per_model.push((model, terms, df));
        model_candidates(
            scene,
            &g,
            (model, df, terms, shares),
            (samples, adaptive),
            half,
            budget,
            &mut cands,
        );
    }
    let cheapest_within = cands
        .iter()
        .enumerate()
        .filter(|(_, c)| c.meets(budget))
        .min_by(|a, b| {
            a.1.m3_instructions_per_pixel
                .total_cmp(&b.1.m3_instructions_per_pixel)
        })
        .map(|(i, _)| i);
    let most_accurate = || {
        cands
            .iter()
            .enumerate()
            .filter(|(_, c)| c.fits.is_ok())
            .min_by(|a, b| {
                let score = |c: &Candidate| c.lsb + c.geom_err_px / budget.max_geom_err_px.max(1e-12);
                score(a.1).total_cmp(&score(b.1))
            })
            .map_or(0, |(i, _)| i)
    };
    let chosen = cheapest_within.unwrap_or_else(most_accurate);
    // Weak perspective approximates the camera (its error takes up to
    // half the geometric budget): kept only where it is predicted cheaper
    // than perspective rays by more than `WEAK_MARGIN`.
    let chosen = match cands.get(chosen) {
        Some(w) if matches!(w.model, RenderModel::WeakPerspective { .. }) && both => cands
            .iter()
            .position(|c| {
                c.model == RenderModel::Perspective
                    && (c.arithmetic, c.distortion) == (w.arithmetic, w.distortion)
                    && c.meets(budget) == w.meets(budget)
                    && c.m3_instructions_per_pixel <= w.m3_instructions_per_pixel * (1.0 + WEAK_MARGIN)
            })
            .unwrap_or(chosen),
        _ => chosen,
    };
    let c = cands.get(chosen).copied().unwrap_or(Candidate {
        model: first,
        arithmetic: Arithmetic::Wide,
        distortion: None,
        lut_entries: 0,
        fits: Ok(()),
        geom_err_px: f64::INFINITY,
        lsb: f64::INFINITY,
        m3_instructions_per_pixel: f64::INFINITY,
        closed_mean: ClosedMean::Off,
        mean_lsb: 0.0,
        edge_differing: 1.0,
    });
    let model = c.model;
    let (terms, df) = per_model
        .iter()
        .find(|m| m.0 == model)
        .map_or((Samples::ONE, Defocus::NONE), |m| {
            (m.1.with(c.arithmetic, shares), m.2)
        });
    let wp_used =
        matches!(model, RenderModel::WeakPerspective { .. }) && matches!(cam.model, Model::Perspective);
    let meets = c.meets(budget) && (!wp_used || wp.is_some_and(|(e, _)| e <= half));
    let mut options = Options::new(model, c.lut_entries.max(2));
    options.closed_mean = c.closed_mean;
    options.distortion_eval = c.distortion.unwrap_or(DistortionEval::Polynomial);
    options.arithmetic = c.arithmetic;
    options.samples = samples;
    options.adaptive = adaptive;
    options.aperture = df.points;
    Plan {
        options,
        predicted_geom_err_px: c.geom_err_px,
        weak_perspective_err_px: wp.map(|(e, _)| e),
        predicted_lsb: c.lsb,
        predicted_m3_instructions_per_pixel: c.m3_instructions_per_pixel,
        meets_budget: meets,
        candidates: cands,
        chosen,
        predicted_edge_err_px: crate::render::sensor::sampling::edge_error(samples),
        samples: terms,
        predicted_sample_factor: CostModel::of(c.arithmetic)
            .samples
            .factor(c.m3_instructions_per_pixel, &terms),
        defocus: df,
    }
}

/// The candidates of one ray model (`g` its geometry, `df` and `terms`
/// its defocus and sample terms): each arithmetic with each distortion
/// evaluation, pushed to `cands`.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn model_candidates(
    scene: &Scene,
    g: &Geometry,
    (model, df, terms, shares): (RenderModel, Defocus, Samples, Shares),
    (samples, adaptive): (u8, bool),
    half: f64,
    budget: &Budget,
    cands: &mut heapless::Vec<Candidate, MAX_CANDIDATES>,
) {
    // Edge length per pixel area times looks per pixel area (see
    // `Candidate::edge_differing`).
    let looks = match (samples, adaptive) {
        (0 | 1, _) => 1.0,
        (n, false) => f64::from(n) * f64::from(n),
        (n, true) => f64::from(n) * f64::from(n) + 5.0,
    };
    let edge_looks = edge_fraction(scene, g, true) * core::f64::consts::FRAC_PI_4 * looks;
    // A checkered plane's cell lines, over the field (toward its horizon
    // they pass a pixel apart): the share of pixels whose looks may see
    // the other side of one, for the candidate's arithmetic and geometric
    // error.
    let cells = |a: Arithmetic, geom: f64| {
        g.prims
            .iter()
            .map(|p| g.cells_differing(p, a, geom, looks))
            .sum::<f64>()
    };
    for arithmetic in [Arithmetic::Fast, Arithmetic::Wide] {
        let mut evals: heapless::Vec<(Option<DistortionEval>, usize), 2> = heapless::Vec::new();
        if scene.distortion.is_none() {
            let _ = evals.push((None, 0));
        } else {
            let _ = evals.push((Some(DistortionEval::Polynomial), 0));
            // (Only the wide arithmetic reads a table.)
            let entries = (arithmetic == Arithmetic::Wide).then(|| table_entries(scene, g, half));
            if let Some(entries) = entries.filter(|e| *e <= budget.max_table_entries) {
                let _ = evals.push((Some(DistortionEval::Linear), entries));
            }
        }
        // What the distortion evaluation does not change, once.
        let fits = match arithmetic {
            // (The fast aperture loop takes pixel centres only.)
            Arithmetic::Fast if df.points > 0 && samples > 1 => Err(Unfit::Defocus),
            Arithmetic::Fast => g.fast_fits(scene),
            Arithmetic::Wide => Ok(()),
        };
        // (Aperture rays' slopes: the chief ray's, shifted to 1.5·2⁻²⁶.)
        let shifted = match (arithmetic, g.aperture) {
            (Arithmetic::Fast, Some(_)) => 1.5 * core::f64::consts::SQRT_2 * g.f_px * libm::ldexp(1.0, -26),
            _ => 0.0,
        };
        let lsb = ErrorModel::of(arithmetic, g).lsb(scene, g, g.direct_geom_err(arithmetic, scene) + shifted);
        // The closed form runs in the fast one-sample loop; the rays
        // between those it shades take interpolated sums (perspective
        // rays): over 8 rays where that bound keeps the LSB within budget,
        // else over 4, else over 2.
        let closed = arithmetic == Arithmetic::Fast && samples <= 1 && df.points == 0;
        let pair_err = match (closed, model) {
            (true, RenderModel::Perspective) => closed_mean_err(scene, g),
            _ => None,
        };
        let mean = [ClosedMean::Octs, ClosedMean::Quads, ClosedMean::Pairs]
            .into_iter()
            .find_map(|m| {
                let e = pair_err? * closed_mean_factor(m);
                let moved = (noise_moved(scene, g, lsb + e), noise_moved(scene, g, e));
                (moved.0 + noise_draw_lsb(scene, g) + 0.5 <= budget.max_lsb).then_some((m, moved))
            });
        let (closed_mean, (moved, mean_lsb)) =
            mean.unwrap_or_else(|| (ClosedMean::Off, (noise_moved(scene, g, lsb), 0.0)));
        let lsb = moved + noise_draw_lsb(scene, g);
        for (distortion, entries) in evals {
            let geom = match distortion {
                Some(DistortionEval::Linear) | Some(DistortionEval::Nearest) => {
                    table_geom_err(scene, g, entries)
                }
                _ => g.direct_geom_err(arithmetic, scene),
            };
            let cost_model = CostModel::of(arithmetic);
            let fast = arithmetic == Arithmetic::Fast;
            let one = cost_model.predict(&Features::of(scene, g, distortion, fast, closed, closed_mean));
            let cost = cost_model.samples.cost(one, &terms.with(arithmetic, shares));
            let _ = cands.push(Candidate {
                model,
                arithmetic,
                distortion,
                lut_entries: entries,
                fits,
                geom_err_px: geom,
                lsb,
                m3_instructions_per_pixel: cost,
                closed_mean,
                mean_lsb,
                edge_differing: (edge_looks * 2.0 * geom + cells(arithmetic, geom)).min(1.0),
            });
        }
    }
}

/// Defocus for `scene` ([`Defocus`]): the inverse depths `w = 1/z` of the
/// content in view — a bounded primitive's over its bounding sphere (if
/// its slope bounds meet the field), a plane's over the undistorted field's
/// bounding box (`w = n̂·(x̂, ŷ, 1) / (n̂·c)` is linear in the slopes: its
/// extremes are at the box's corners, and a horizon in view takes `w` to
/// 0) — against the depth of field's `[1/Ẑ_f, 1/Ẑ_n]`; the blur is
/// `d |w − 1/Z̃|` normalized, times `f/s`. The aperture is sampled for a
/// perspective camera with content outside the depth of field, with the
/// smallest pattern within `edge_budget_px` ([`crate::render::sensor::defocus::points_for`]).
#[inline(never)]
fn defocus(scene: &Scene, g: &Geometry, edge_budget_px: f64) -> Defocus {
    let lens = &scene.camera.lens;
    let (d, f) = (lens.diameter().f64(), lens.focal_length().f64());
    let (zt, b) = (lens.focus_distance().f64(), lens.tolerable_blur().f64());
    let inv_focus = 1.0 / zt;
    // §4's planes as inverse depths: 1/Ẑ_n = (d f + b̃ Z̃) / (Z̃ f (d + b̃)),
    // 1/Ẑ_f = (d f − b̃ Z̃) / (Z̃ f (d − b̃)), 0 (infinite) when ≤ 0.
    let inv_near = (d * f + b * zt) / (zt * f * (d + b));
    let inv_far = ((d * f - b * zt) / (zt * f * (d - b))).max(0.0);
    let (xs, ys) = g.field;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &g.prims {
        if let Shape::Plane { .. } = p.shape {
            let Some((wmin, wmax)) = g.plane_w(p) else {
                continue;
            };
            if wmax <= 0.0 {
                continue;
            }
            lo = lo.min(wmin.max(0.0));
            hi = hi.max(wmax);
            continue;
        }
        // A disc or rectangle lies in its plane: its inverse depths are
        // within the plane's over the field too (finite where its bounding
        // sphere reaches the lens plane).
        let flat = match p.shape {
            Shape::Disc { .. } | Shape::Rectangle { .. } => g.plane_w(p),
            _ => None,
        };
        if flat.is_some_and(|(_, wmax)| wmax <= 0.0) {
            continue;
        }
        let (flat_lo, flat_hi) = flat.map_or((0.0, f64::INFINITY), |(a, b)| (a.max(0.0), b));
        // The radius widened by 1 nm: the scene's positions are rounded
        // to 2⁻³² m.
        let (c, r) = (p.c, p.r + 1e-9);
        if c[2] + r <= 0.0 {
            continue;
        }
        let near = if c[2] > r {
            // The bounding sphere's tangent slopes against the field.
            let zz = c[2] * c[2] - r * r;
            let meets = |cx: f64, half: f64| {
                let s = libm::sqrt((cx * cx + zz).max(0.0));
                (cx * c[2] - r * s) / zz <= half && (cx * c[2] + r * s) / zz >= -half
            };
            if !(meets(c[0], xs) && meets(c[1], ys)) {
                continue;
            }
            1.0 / (c[2] - r)
        } else {
            f64::INFINITY
        };
        hi = hi.max(near.min(flat_hi));
        lo = lo.min((1.0 / (c[2] + r)).max(flat_lo));
    }
    if lo > hi {
        return Defocus::NONE;
    }
    let blur_px = d * g.f_px * libm::fabs(hi - inv_focus).max(libm::fabs(lo - inv_focus));
    let outside_dof = hi > inv_near || lo < inv_far;
    let points = if outside_dof && matches!(scene.camera.model, Model::Perspective) {
        crate::render::sensor::defocus::points_for(blur_px, edge_budget_px)
    } else {
        0
    };
    Defocus {
        blur_px,
        outside_dof,
        points,
        err_px: if points > 0 {
            crate::render::sensor::defocus::placement(points) * blur_px
        } else {
            blur_px
        },
    }
}

/// The fraction of pixels an edge crosses, estimated from the edges'
/// length on the sensor (pixels, at each primitive's centre distance, seen
/// face on): a sphere's or disc's outline (`2π f r / |c|`), a rectangle's
/// (`4 f (h_u + h_v) / |c|`), a plane's horizon (the sensor's width), and a
/// checker texture's cell boundaries (two families of lines a projected
/// cell apart over the area the primitive covers; with `integrated`, not
/// those [`Geometry::cells_differing`] integrates over the field); a line
/// crosses `4/π` pixels per pixel of length on average over its
/// directions.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
fn edge_fraction(scene: &Scene, g: &Geometry, integrated: bool) -> f64 {
    use core::f64::consts::PI;
    let (w, h) = scene.camera.intrinsics.size();
    let area = f64::from(w) * f64::from(h);
    let mut length = 0.0;
    for (p, pg) in scene.primitives.iter().zip(&g.prims) {
        let k = g.f_px / norm3(pg.c).max(1e-9);
        let covered = match p.shape {
            Shape::Plane { .. } => {
                length += f64::from(w);
                g.coverage * area
            }
            Shape::Rectangle { half, .. } => {
                let (hu, hv) = (half[0].f64() * k, half[1].f64() * k);
                length += 4.0 * (hu + hv);
                4.0 * hu * hv
            }
            _ => {
                let r = pg.r * k;
                length += 2.0 * PI * r;
                PI * r * r
            }
        };
        if let Some(ch) = p.checker.filter(|_| !(integrated && g.integrates_cells(pg))) {
            let cell = (ch.cell.f64() * k).max(1e-9);
            length += 2.0 * covered.min(area) / cell;
        }
    }
    (4.0 / PI * length / area).min(1.0)
}

/// An arithmetic's error in a plane coordinate `u = t (â·d)` of a
/// perspective ray's hit, `t = dist / (n̂·d)` ([`Geometry::cells_differing`]):
/// bounds on each rounding, whose errors are each within the bound and,
/// truncations or rounding, half of it on average.
struct HitError {
    /// `t`'s relative error.
    t: f64,
    /// `n̂·d`'s absolute error.
    w: f64,
    /// `â·d`'s absolute error.
    a: f64,
    /// Where `t` and the coordinate are stored: `t`'s absolute error is
    /// this, and the stored coordinate's `|â·d| + 1/2 + 2⁻⁵` times this,
    /// metres.
    stored: f64,
}

impl HitError {
    /// Fast (`mix32::Ray::plane_t`, `Ray::along`, `MixChecker::cell`):
    /// `n̂·d` and `â·d` truncated to S24, `1/(n̂·d)` within 2⁻²¹ and `dist`
    /// in S24 U; `t` floored to S18 U, times `â·d`, less the texture's
    /// origin (floored to S24 U: within `|â|₁ 2⁻²⁴ U < 2⁻²³ U`), and the
    /// coordinate rounded to S18 U: `(|â·d| + 1/2 + 2⁻⁵) 2⁻¹⁸ U`
    /// (`mix32::tests::a_hit_s_texture_coordinate_is_within_the_planner_s_hit_error`
    /// measures it).
    /// Wide (I32F32, `render::WideFrame::look`): `n̂·d`, `â·d`, `dist`, `t` and
    /// the point rounded to 2⁻³², a few each.
    fn of(a: Arithmetic, unit: f64, dist: f64) -> HitError {
        match a {
            Arithmetic::Fast => HitError {
                t: libm::ldexp(1.0, -21) + libm::ldexp(unit, -24) / dist,
                w: libm::ldexp(1.0, -24),
                a: libm::ldexp(1.0, -24),
                stored: libm::ldexp(unit, -18),
            },
            Arithmetic::Wide => HitError {
                t: libm::ldexp(2.0, -32) / dist,
                w: libm::ldexp(3.0, -32),
                a: libm::ldexp(3.0, -32),
                stored: libm::ldexp(2.0, -32),
            },
        }
    }
}

/// The mean of `φ(w) = min(1, a/w + b/w² + c)` (0 where `w ≤ 0`) over `w`
/// in `[wc − h, wc + h]`, `a, b, c ≥ 0`: from its antiderivative, `w` up to
/// `w*` (where `φ = 1`), then `w* + a ln(w/w*) + b (1/w* − 1/w) + c (w −
/// w*)`.
fn capped_mean((a, b, c): (f64, f64, f64), wc: f64, h: f64) -> f64 {
    if c >= 1.0 {
        return if wc - h >= 0.0 {
            1.0
        } else if wc + h <= 0.0 {
            0.0
        } else {
            (wc + h) / (2.0 * h)
        };
    }
    let r = 1.0 - c;
    let star = (a + libm::sqrt(a * a + 4.0 * b * r)) / (2.0 * r);
    let phi = |w: f64| {
        if w <= 0.0 {
            0.0
        } else {
            (a / w + b / (w * w) + c).min(1.0)
        }
    };
    let big = |w: f64| {
        if w <= 0.0 {
            0.0
        } else if w <= star {
            w
        } else {
            star + a * libm::log(w / star) + b * (1.0 / star - 1.0 / w) + c * (w - star)
        }
    };
    if star.is_nan() || star <= 0.0 || h <= 1e-9 * libm::fabs(wc).max(star) {
        phi(wc)
    } else {
        ((big(wc + h) - big(wc - h)) / (2.0 * h)).clamp(0.0, 1.0)
    }
}

/// The smallest power-of-two table whose error is within `half` (or the
/// largest table).
fn table_entries(scene: &Scene, g: &Geometry, half: f64) -> usize {
    let mut entries = 2;
    while table_geom_err(scene, g, entries) > half && entries < crate::geom::distortion::MAX_LUT {
        entries *= 2;
    }
    entries
}

/// The geometric error of a linearly interpolated table of `entries`, px:
/// `|k2| h²/4` at the widest corner plus the entries' rounding.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
fn table_geom_err(scene: &Scene, g: &Geometry, entries: usize) -> f64 {
    let r_max = libm::sqrt(g.u_max);
    let frac = scene
        .distortion
        .entry_frac_bits(crate::num::from_f64(g.u_max).unwrap_or(crate::scene::Q::MAX));
    let rounding = g.f_px * r_max * libm::ldexp(1.0, -(frac as i32 + 1)) + g.f_px * libm::ldexp(1.0, -31);
    g.f_px * r_max * scene.distortion.lut_interp_error(g.u_max, entries) + rounding
}

/// The fast arithmetic's length unit `U = 2^e`: the smallest with content
/// of `extent` metres within 8 U (e in [−20, 20]).
fn unit_exp(extent: f64) -> i32 {
    let mut e = -20;
    while e < 20 && extent > libm::ldexp(8.0, e) {
        e += 1;
    }
    e
}

/// What the planner knows of the scene in the camera frame, in f64.
struct Geometry {
    /// Largest focal length in pixels.
    f_px: f64,
    /// The focal length along a row (`f_x`), pixels.
    f_row: f64,
    /// The focal length along a column (`f_y`), pixels.
    f_col: f64,
    /// Largest `u = r_d²` over the sensor (clipped to the fold).
    u_max: f64,
    /// Largest |distorted slope| at the corners (x, y).
    slope_d: [f64; 2],
    /// The undistorted field's box of slopes, half-widths (x, y)
    /// ([`crate::render::prepare::field_box`]).
    field: (f64, f64),
    /// Largest `g` and `|k1| + |k2| u` over `[0, u_max]`.
    g_max: f64,
    s_max: f64,
    /// Largest |undistorted slope|.
    slope: f64,
    /// Parallel rays' origin scale, metres (`None`: perspective).
    origin_scale: Option<f64>,
    /// Content extent (primitives, point lights) from the camera, and
    /// from where the fast arithmetic's rays start, metres; that
    /// arithmetic's length unit `U = 2^e`.
    extent: f64,
    fast_extent: f64,
    unit: f64,
    /// Through the aperture (defocus): its radius `d/2`, metres, and
    /// `d/(2Z̃)`, the largest shift of a ray's slopes from its chief ray's.
    aperture: Option<(f64, f64)>,
    /// Per primitive: kind, camera-frame centre (or a point), distance of
    /// its centre, radius (spheres, discs; 0 otherwise), smallest length
    /// the fast path must resolve (radius, cell).
    prims: heapless::Vec<PrimGeom, { crate::scene::MAX_PRIMITIVES }>,
    /// Per light: camera-frame position (point lights) or `None`.
    lights: heapless::Vec<Option<[f64; 3]>, { crate::scene::MAX_LIGHTS }>,
    /// Largest per-channel gain: DN per unit radiance on the axis.
    gain: f64,
    /// Largest DN of any channel.
    dn_max: f64,
    /// Fraction of the sensor whose rays hit a primitive (sampled).
    coverage: f64,
    /// Sum over the bounded primitives of the fraction of the sensor whose
    /// rays hit each (sampled).
    bounded_area: f64,
    /// Fraction of the sensor whose rays see the plane the fast arithmetic
    /// shades in closed form (`mix32::Closed`) and no other primitive
    /// (sampled; 0 without such a plane).
    closed_area: f64,
    /// Fraction of the sensor whose rays first meet a primitive with a
    /// specular lobe (sampled).
    lobe_area: f64,
    /// Sum over the flat primitives facing the camera (normal along the
    /// optical axis: `mix32::flat_pass` takes one `t` a chunk for them)
    /// of the fraction of the sensor whose rays hit each (sampled), the
    /// plane shaded in closed form (`closed_area`'s) left out...
    facing_area: f64,
    /// ... and that plane's, if it faces the camera.
    closed_facing_area: f64,
    /// Fraction of the sensor whose rays first meet a flat primitive (a
    /// plane, disc or rectangle) without a lobe in a scene lit by
    /// directional lights alone: its shading is kept from hit to hit
    /// (`Mix32::shade_flat`), the plane in closed form (`closed_area`'s)
    /// left out...
    flat_area: f64,
    /// ... and that plane's.
    closed_flat_area: f64,
    /// That plane's index among the primitives.
    closed: Option<usize>,
}

/// How far a primitive's points lie from the camera, in the camera frame:
/// a plane's distance `|n·c|` (planes keep the rays at the camera), or a
/// centre and a radius around it (`r`; `a + b` for a rectangle), metres.
#[derive(Clone, Copy)]
enum Reach {
    Plane(f64),
    Around([f64; 3], f64),
}

/// The coverage sample grid (columns, rows): the sampled features'
/// resolution (a sample is 1/108 of the sensor). At 8 × 6 a sample was
/// 2 % of it, and moving spheres-specular's principal point by 3.8 px
/// moved its coverage 0.83 → 0.67 (50 instructions a pixel of
/// prediction); refitted, the shipped scenes' error 9.2 → 8.5 % RMS and
/// their off-centre copies' 10.1 → 8.1 %, for a plan of 635 k M3
/// instructions against 482 k (16 × 12: 7.9 and 7.8 %, 838 k;
/// `docs/cost-model.md`).
const COVERAGE_GRID: (u32, u32) = (12, 9);

impl PrimGeom {
    /// What [`PrimGeom::hit`] takes of a ray's origin `o`, whatever its
    /// direction: once a primitive for perspective rays (all from `o = 0`).
    fn seen_from(&self, o: [f64; 3]) -> FromOrigin {
        let oc = sub3(self.c, o);
        let cc = dot3(oc, oc);
        FromOrigin {
            o,
            v: match self.shape {
                Shape::Sphere { .. } => oc,
                _ => self.n,
            },
            vx: 0.0,
            inside: cc <= self.r * self.r,
            cc_rr: cc - self.r * self.r,
            noc: dot3(self.n, oc),
        }
    }

    /// Where the ray `o + t d`, `t > 0`, first meets the primitive (a
    /// rectangle as the disc through its corners: coverage, not shading):
    /// its `t` (0 from inside a sphere), or `None`. `k` is
    /// [`PrimGeom::seen_from`] `o`, `dd` is `d·d` and `vd` is `k.v·d`.
    fn hit(&self, k: &FromOrigin, d: [f64; 3], dd: f64, vd: f64) -> Option<f64> {
        match self.shape {
            Shape::Sphere { .. } => {
                let t = vd;
                if k.inside {
                    Some(0.0)
                } else if t > 0.0 {
                    let disc = t * t - dd * k.cc_rr;
                    (disc >= 0.0).then(|| (t - libm::sqrt(disc)) / dd)
                } else {
                    None
                }
            }
            _ => {
                let den = vd;
                if libm::fabs(den) < 1e-12 {
                    return None;
                }
                let t = k.noc / den;
                if matches!(self.shape, Shape::Plane { .. }) {
                    return (t > 0.0).then_some(t);
                }
                let o = k.o;
                let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
                (t > 0.0 && norm3(sub3(p, self.c)) <= self.r).then_some(t)
            }
        }
    }
}

/// A ray origin's terms for one primitive ([`PrimGeom::seen_from`]).
#[derive(Clone, Copy, Debug, Default)]
struct FromOrigin {
    /// The origin `o`, camera frame.
    o: [f64; 3],
    /// What a ray's direction `d` is dotted with: `c − o` (a sphere's), or
    /// the normal (a flat shape's).
    v: [f64; 3],
    /// `v₀ x̂` for the perspective rays of one column (`x̂` its slope).
    vx: f64,
    /// `|c − o| ≤ r` (a sphere's).
    inside: bool,
    /// `|c − o|² − r²`.
    cc_rr: f64,
    /// `n·(c − o)`.
    noc: f64,
}

#[derive(Clone, Copy, Debug)]
struct PrimGeom {
    shape: Shape,
    /// A point of the primitive (its centre) in the camera frame.
    c: [f64; 3],
    /// Unit normal (flat shapes), camera frame.
    n: [f64; 3],
    /// Radius (sphere, disc), half-diagonal (rectangle), 0 (plane).
    r: f64,
    /// The smallest length the fast path represents for it.
    smallest: f64,
    /// Largest diffuse and specular constants (n ρ/π, (1−n) ρ_s (s+2)/2π)
    /// over its materials, and the largest exponent of a lobe.
    kd: f64,
    ks: f64,
    exponent: u16,
    /// No perspective ray meets it: behind the lens plane
    /// ([`crate::render::prepare::behind_lens`], [`crate::render::prepare::plane_unseen`]).
    unseen: bool,
    /// A checkered plane's, disc's or rectangle's texture.
    cells: Option<Cells>,
}

/// A flat primitive's checker texture, camera frame.
#[derive(Clone, Copy, Debug)]
struct Cells {
    /// Its axes (unit). In f32, as `seen`: an estimate needs no more, and
    /// the driven camera plans with up to 16 primitives on its stack (in
    /// f64, with `seen` an `Option`, its peak RAM grew by 584 B on the M3
    /// and 396 B on the M0 in the fresh-clone run of 8853415).
    u: [f32; 3],
    v: [f32; 3],
    /// Its cell, metres.
    cell: f64,
    /// The box of undistorted slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` that holds
    /// the shape's image (a disc's, its bounding square's), rounded
    /// outward, or infinite: any slope (a plane; a shape reaching the lens
    /// plane).
    seen: [f32; 4],
}

impl Cells {
    fn new(u: [f64; 3], v: [f64; 3], cell: f64, seen: Option<[f64; 4]>) -> Cells {
        let (down, up) = (|x: f64| (x as f32).next_down(), |x: f64| (x as f32).next_up());
        Cells {
            u: u.map(|x| x as f32),
            v: v.map(|x| x as f32),
            cell,
            seen: seen.map_or(
                [f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY],
                |[a, b, c, d]| [down(a), up(b), down(c), up(d)],
            ),
        }
    }
}

/// The box of slopes `[x̂_lo, x̂_hi, ŷ_lo, ŷ_hi]` of the rectangle centred
/// on `c` with half-axes `a u`, `b v` (camera frame, metres): its corners'
/// (all in front of the lens, the image of the rectangle lies within
/// their hull); `None` where one is not in front by 10⁻⁶ of its distance.
fn corner_slopes(c: [f64; 3], u: [f64; 3], v: [f64; 3], a: f64, b: f64) -> Option<[f64; 4]> {
    let mut bx = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    for (su, sv) in [(-a, -b), (a, -b), (-a, b), (a, b)] {
        let at = |k: [f64; 3]| dot3(k, [1.0, su, sv]);
        let p = [
            at([c[0], u[0], v[0]]),
            at([c[1], u[1], v[1]]),
            at([c[2], u[2], v[2]]),
        ];
        if !p.iter().all(|v| v.is_finite()) || p[2] <= 1e-6 * norm3(p) {
            return None;
        }
        let (x, y) = (p[0] / p[2], p[1] / p[2]);
        bx = [bx[0].min(x), bx[1].max(x), bx[2].min(y), bx[3].max(y)];
    }
    Some(bx)
}

fn norm3(v: [f64; 3]) -> f64 {
    libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `x^y` for `x > 0`, as `e^(y ln x)`: within a few units of the last
/// place times `|y ln x|` (10⁻¹¹ relative at `s = 65 535`), which the
/// estimates here do not feel. libm's `pow` took 2.6 KB of the driven M0
/// camera's flash, which plans on the device; `exp` and `log` take less.
fn pow(x: f64, y: f64) -> f64 {
    libm::exp(y * libm::log(x))
}

impl Geometry {
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    fn of(scene: &Scene, model: RenderModel) -> Geometry {
        let cam = &scene.camera;
        let intr = &cam.intrinsics;
        let (fx, fy) = intr.focal_px();
        let (fx, fy) = (fx.f64(), fy.f64());
        let (w, h) = intr.size();
        let (ox, oy) = intr.principal_point();
        let (ox, oy) = (ox.f64(), oy.f64());
        let mut slope_d = [0.0f64; 2];
        let mut u_corner: f64 = 0.0;
        for (i, j) in [
            (0.0, 0.0),
            (w as f64 - 1.0, 0.0),
            (0.0, h as f64 - 1.0),
            (w as f64 - 1.0, h as f64 - 1.0),
        ] {
            let xd = (ox - i) / fx;
            let yd = (oy - j) / fy;
            slope_d[0] = slope_d[0].max(libm::fabs(xd));
            slope_d[1] = slope_d[1].max(libm::fabs(yd));
            u_corner = u_corner.max(xd * xd + yd * yd);
        }
        let (k1, k2) = scene.distortion.coefficients();
        let (k1, k2) = (k1.f64(), k2.f64());
        let u_max = match scene.distortion.fold_u() {
            Some(f) if !scene.distortion.is_none() => u_corner.min(f.f64()),
            _ => u_corner,
        };
        let s_max = libm::fabs(k1) + libm::fabs(k2) * u_max;
        let g_max = 1.0 + s_max * u_max;
        let slope = slope_d[0].max(slope_d[1]) * g_max;
        let origin_scale = match model {
            RenderModel::Perspective => None,
            RenderModel::WeakPerspective { mean_depth } => Some(mean_depth.f64()),
            RenderModel::Orthographic { scale } => Some(intr.focal_length().f64() / scale.f64().max(1e-300)),
        };
        let cam_pt = |p: crate::WorldPoint| cam_point(scene, p);
        let cam_dir = |d: [crate::Norm; 3]| cam_direction(scene, d);
        let field = crate::render::prepare::field_box(scene);
        let mut prims = heapless::Vec::new();
        // Per primitive, for the extents: how far it reaches, and its
        // checker's origin (the primitive's point or centre).
        let mut reaches: heapless::Vec<(Reach, Option<[f64; 3]>), { crate::scene::MAX_PRIMITIVES }> =
            heapless::Vec::new();
        let mat = |i: u8| scene.materials.get(i as usize);
        for p in &scene.primitives {
            // A disc's or rectangle's centre and in-plane half-axes (a
            // disc's bounding square, along its checker's axes).
            let mut flat: Option<([f64; 3], [f64; 3], f64, f64)> = None;
            let (c, n, r, mut smallest, reach) = match p.shape {
                Shape::Plane { point, normal } => {
                    let c = cam_pt(point);
                    let n = cam_dir(normal);
                    // The fast path holds the plane's distance n·c.
                    (c, n, 0.0, f64::INFINITY, Reach::Plane(libm::fabs(dot3(n, c))))
                }
                Shape::Sphere { centre, radius } => {
                    let c = cam_pt(centre);
                    let r = radius.f64();
                    (c, [0.0; 3], r, r, Reach::Around(c, r))
                }
                Shape::Disc {
                    centre,
                    normal,
                    radius,
                } => {
                    let c = cam_pt(centre);
                    let r = radius.f64();
                    (c, cam_dir(normal), r, f64::INFINITY, Reach::Around(c, r))
                }
                Shape::Rectangle {
                    centre,
                    u_axis,
                    v_axis,
                    half,
                } => {
                    let c = cam_pt(centre);
                    let (a, b) = (half[0].f64(), half[1].f64());
                    let (u, v) = (cam_dir(u_axis), cam_dir(v_axis));
                    let n = [
                        u[1] * v[2] - u[2] * v[1],
                        u[2] * v[0] - u[0] * v[2],
                        u[0] * v[1] - u[1] * v[0],
                    ];
                    let r = libm::sqrt(a * a + b * b);
                    flat = Some((u, v, a, b));
                    (c, n, r, f64::INFINITY, Reach::Around(c, a + b))
                }
            };
            let _ = reaches.push((reach, p.checker.map(|_| c)));
            let mut kd: f64 = 0.0;
            let mut ks: f64 = 0.0;
            let mut exponent = 0;
            let mut take = |m: Option<&crate::scene::Material>| {
                if let Some(m) = m {
                    let b = crate::render::shading::Brdf::new(m, [crate::scene::Q::ZERO; 3]);
                    for c in 0..3 {
                        kd = kd.max(b.kd.get(c).map_or(0.0, |v| v.f64()));
                        ks = ks.max(b.ks.get(c).map_or(0.0, |v| v.f64()));
                    }
                    if m.has_specular() {
                        exponent = exponent.max(m.exponent);
                    }
                }
            };
            take(mat(p.material));
            let mut cells = None;
            if let Some(k) = &p.checker {
                take(mat(k.material));
                smallest = smallest.min(k.cell.f64());
                let (ku, kv) = (cam_dir(k.u_axis), cam_dir(k.v_axis));
                let seen = match p.shape {
                    Shape::Plane { .. } => Some(None),
                    Shape::Disc { .. } => Some(corner_slopes(c, ku, kv, r, r)),
                    Shape::Rectangle { .. } => {
                        Some(flat.and_then(|(u, v, a, b)| corner_slopes(c, u, v, a, b)))
                    }
                    Shape::Sphere { .. } => None,
                };
                cells = seen.map(|seen| Cells::new(ku, kv, k.cell.f64(), seen));
            }
            let unseen = origin_scale.is_none()
                && match p.shape {
                    Shape::Plane { .. } => crate::render::prepare::plane_unseen(n, dot3(n, c), field, 0.0),
                    _ => crate::render::prepare::behind_lens(c[2], r),
                };
            let _ = prims.push(PrimGeom {
                shape: p.shape,
                c,
                n,
                r,
                smallest,
                kd,
                ks,
                exponent,
                unseen,
                cells,
            });
        }
        let mut lights = heapless::Vec::new();
        for l in &scene.lights {
            let p = match *l {
                Light::Point { position, .. } => Some(cam_pt(position)),
                Light::Directional { .. } => None,
            };
            let _ = lights.push(p);
        }
        // The content's extent from where the rays start, z = z0 (the
        // fast path's `mix32::parallel_start` and `content_extent`).
        let extent_at = |z0: f64| {
            let at = |c: [f64; 3]| norm3([c[0], c[1], c[2] - z0]);
            let mut e = match origin_scale {
                Some(k) if z0 > 0.0 => k / 8.0,
                _ => 0.0,
            };
            for (reach, checker) in &reaches {
                e = e.max(match *reach {
                    Reach::Plane(d) => d,
                    Reach::Around(c, r) => at(c) + r,
                });
                if let Some(o) = checker {
                    e = e.max(at(*o));
                }
            }
            for p in lights.iter().flatten() {
                e = e.max(at(*p));
            }
            e
        };
        let extent = extent_at(0.0);
        let near = (reaches.iter())
            .map(|(reach, _)| match *reach {
                Reach::Plane(_) => f64::NEG_INFINITY,
                Reach::Around(c, r) => c[2] - r,
            })
            .fold(f64::INFINITY, f64::min);
        let z0 = libm::ceil(near) - 1.0;
        let fast_extent = if origin_scale.is_some() && near.is_finite() && z0 > 0.0 {
            extent_at(z0).min(extent)
        } else {
            extent
        };
        let e = unit_exp(fast_extent);
        let lens = &cam.lens;
        let d_over_f = lens.diameter().f64() / lens.focal_length().f64();
        let fmt = scene.format;
        let gain = (0..fmt.channels())
            .map(|c| {
                let (n, d) = fmt.channel_scale(c);
                scene.exposure.f64() * core::f64::consts::PI / 4.0 * d_over_f * d_over_f * n as f64 / d as f64
            })
            .fold(0.0, f64::max);
        let dn_max = (0..fmt.channels()).map(|c| fmt.dn_max(c)).max().unwrap_or(255) as f64;
        // The plane the fast arithmetic shades in closed form, as
        // `mix32::Mix32::closed_plane` picks it: the first plane without a
        // checker or a lobe, perspective rays, the camera and every point
        // light off it by 2⁻¹⁰ of the fast unit or more.
        let unit = libm::ldexp(1.0, e);
        let closed = (origin_scale.is_none())
            .then(|| {
                prims.iter().zip(&scene.primitives).position(|(p, sp)| {
                    matches!(p.shape, Shape::Plane { .. })
                        && !p.unseen
                        && sp.checker.is_none()
                        && p.ks == 0.0
                        && libm::fabs(dot3(p.c, p.n)) >= unit / 1024.0
                        && lights
                            .iter()
                            .flatten()
                            .all(|l| prim_light_distance(p, *l) >= unit / 1024.0)
                })
            })
            .flatten();
        // Coverage: a grid of COVERAGE_GRID rays over the sensor (distortion
        // ignored), each tested against every primitive.
        let (gx, gy) = COVERAGE_GRID;
        let (mut hits, mut bounded, mut closed_hits, mut lobe_hits) = (0u32, 0u32, 0u32, 0u32);
        let (mut facing_hits, mut closed_facing_hits) = (0u32, 0u32);
        let (mut flat_hits, mut closed_flat_hits) = (0u32, 0u32);
        // Directional lights alone: a flat primitive's shading is one sum
        // (`mix32::Mix32::shade_flat`).
        let directional = lights.iter().all(Option::is_none);
        // Facing: the fast arithmetic's S30 normal has n_x = n_y = 0 (to
        // within these f64 components' rounding, which need not be the
        // fixed-point frame's: half an S30 unit either way). Once a
        // primitive, not per hit: soft-float compares on the driven
        // camera, which plans every frame.
        const S30_HALF_UNIT: f64 = 1.0 / (1u64 << 31) as f64;
        let mut facing = [false; crate::scene::MAX_PRIMITIVES];
        for (f, p) in facing.iter_mut().zip(&prims) {
            *f = !matches!(p.shape, Shape::Sphere { .. })
                && libm::fabs(p.n[0]) < S30_HALF_UNIT
                && libm::fabs(p.n[1]) < S30_HALF_UNIT;
        }
        // The origin's terms: once a primitive for perspective rays, once
        // a ray and primitive for parallel ones.
        let mut at = [FromOrigin::default(); crate::scene::MAX_PRIMITIVES];
        if origin_scale.is_none() {
            for (k, p) in at.iter_mut().zip(&prims) {
                *k = p.seen_from([0.0; 3]);
            }
        }
        // The rows' slopes, once.
        let mut ys = [0.0f64; COVERAGE_GRID.1 as usize];
        for (b, y) in ys.iter_mut().enumerate() {
            *y = (oy - (b as f64 + 0.5) * h as f64 / gy as f64) / fy;
        }
        for a in 0..gx {
            let x = (ox - (a as f64 + 0.5) * w as f64 / gx as f64) / fx;
            // A perspective ray's `v·d = (v₀ x̂ + v₁ ŷ) + v₂` (`dot3`'s
            // order, `d₂ = 1`), with `v₀ x̂` once a column.
            let xx = x * x;
            for k in &mut at {
                k.vx = k.v[0] * x;
            }
            for &y in &ys {
                let (o, d) = match origin_scale {
                    None => ([0.0; 3], [x, y, 1.0]),
                    Some(k) => ([x * k, y * k, 0.0], [0.0, 0.0, 1.0]),
                };
                let dd = match origin_scale {
                    None => (xx + y * y) + 1.0,
                    Some(_) => dot3(d, d),
                };
                if origin_scale.is_some() {
                    for (k, p) in at.iter_mut().zip(&prims) {
                        *k = p.seen_from(o);
                    }
                }
                let (mut any, mut others) = (false, false);
                let mut nearest: Option<(f64, &PrimGeom)> = None;
                for (i, (p, k)) in prims.iter().zip(&at).enumerate() {
                    let vd = match origin_scale {
                        None => (k.vx + k.v[1] * y) + k.v[2],
                        Some(_) => dot3(k.v, d),
                    };
                    if let Some(t) = p.hit(k, d, dd, vd) {
                        any = true;
                        bounded += !matches!(p.shape, Shape::Plane { .. }) as u32;
                        if facing.get(i) == Some(&true) {
                            if closed == Some(i) {
                                closed_facing_hits += 1;
                            } else {
                                facing_hits += 1;
                            }
                        }
                        others |= closed != Some(i);
                        if nearest.is_none_or(|(tn, _)| t < tn) {
                            nearest = Some((t, p));
                        }
                    }
                }
                hits += any as u32;
                closed_hits += (any && !others) as u32;
                lobe_hits += nearest.is_some_and(|(_, p)| p.ks > 0.0) as u32;
                if directional
                    && nearest.is_some_and(|(_, p)| p.ks == 0.0 && !matches!(p.shape, Shape::Sphere { .. }))
                {
                    if any && !others {
                        closed_flat_hits += 1;
                    } else {
                        flat_hits += 1;
                    }
                }
            }
        }
        Geometry {
            f_px: fx.max(fy),
            f_row: fx,
            f_col: fy,
            closed,
            u_max,
            slope_d,
            field,
            g_max,
            s_max,
            slope,
            origin_scale,
            extent,
            fast_extent,
            unit,
            aperture: None,
            prims,
            lights,
            gain,
            dn_max,
            coverage: hits as f64 / (gx * gy) as f64,
            bounded_area: bounded as f64 / (gx * gy) as f64,
            closed_area: closed_hits as f64 / (gx * gy) as f64,
            lobe_area: lobe_hits as f64 / (gx * gy) as f64,
            facing_area: facing_hits as f64 / (gx * gy) as f64,
            closed_facing_area: closed_facing_hits as f64 / (gx * gy) as f64,
            flat_area: flat_hits as f64 / (gx * gy) as f64,
            closed_flat_area: closed_flat_hits as f64 / (gx * gy) as f64,
        }
    }

    /// The point lights on the side of the plane in closed form
    /// ([`Geometry::closed`]) that the camera, at the origin, sees: those
    /// whose terms `mix32::Closed` keeps. 0 without such a plane.
    fn closed_lights(&self) -> usize {
        let Some(p) = self.closed.and_then(|i| self.prims.get(i)) else {
            return 0;
        };
        // The camera's side: the sign of `n·(0 − c)`.
        let camera = -dot3(p.c, p.n);
        let lit = |l: &[f64; 3]| dot3(sub3(*l, p.c), p.n) * camera > 0.0;
        self.lights.iter().flatten().filter(|l| lit(l)).count()
    }

    /// A plane's inverse depths over the field box (the pixel centres'
    /// slopes and half a pixel more, undistorted): `w = n̂·(x̂, ŷ, 1) /
    /// (n̂·c)` is linear in the slopes, so its extremes are at the box's
    /// corners; `None` for a plane through the lens centre (seen edge on).
    fn plane_w(&self, p: &PrimGeom) -> Option<(f64, f64)> {
        let (n, (xs, ys)) = (p.n, self.field);
        let dist = dot3(n, p.c);
        if libm::fabs(dist) < 1e-12 {
            return None;
        }
        let w =
            [(-xs, -ys), (xs, -ys), (-xs, ys), (xs, ys)].map(|(x, y)| (n[0] * x + n[1] * y + n[2]) / dist);
        Some(w.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        }))
    }

    /// Whether the cell lines of `p`, a checkered plane, disc or
    /// rectangle, are estimated over the field
    /// ([`Geometry::cells_differing`]): perspective rays (under parallel
    /// rays a plane's cells project at one size).
    fn integrates_cells(&self, p: &PrimGeom) -> bool {
        p.cells.is_some() && !p.unseen && self.origin_scale.is_none()
    }

    /// The expected fraction of pixels at which a look sees the other side
    /// of one of the cell lines of `p` (a checkered plane, disc or
    /// rectangle), for `looks` a pixel placed within `geom` pixels by
    /// arithmetic `a`: the mean over the field box of `min(1, looks Σ 2
    /// δu/c)`, `δu` a family's coordinate error where the plane is seen and
    /// within the box of a disc's or rectangle's image ([`Cells::seen`],
    /// counted as covered throughout; 0 elsewhere; other primitives in
    /// front ignored), `c` the cell.
    ///
    /// With `w = n̂·d / dist` (`d = (x̂, ŷ, 1)`, `n̂·P = dist` the plane:
    /// seen where `w > 0`, the horizon at `w = 0`), a family's coordinate
    /// is `u = â·P = t (â·d)`, `t = 1/w`. Its error is the placement's,
    /// `geom |∇u|` — the slope gradient `∂u/∂x̂ = (â_x w dist − (â·d) n̂_x)
    /// / (w² dist)` per pixel (`/f_x`, `/f_y`): `|∇u| ≤ α/w + β/w²`, `α =
    /// |(â_x/f_x, â_y/f_y)|`, `β = |â·d| |(n̂_x/f_x, n̂_y/f_y)| / |dist|` —
    /// plus the arithmetic's own on `t` (relative `ε_t`, and `ε_w` of `n̂·d`
    /// absolute), on `â·d` (`ε_a`) and where `t` and the coordinate are
    /// stored (`δ`, metres): `δu ≤ (|â·d| ε_t + ε_a)/w + |â·d| ε_w/(|dist|
    /// w²) + (|â·d| + 1/2 + 2⁻⁵) δ` ([`HitError`]). The placement's error
    /// is a bound of either sign: a look within it of a line may cross it,
    /// `2 geom |∇u| / c` of the looks. The arithmetic's crosses a line at
    /// `|δu| / c` of them, and its roundings average half their bounds: the
    /// estimate takes half of `δu` (on random hits the fast arithmetic's
    /// averaged 0.26 of `δu`, its largest 0.93, in
    /// `mix32::tests::a_hit_s_texture_coordinate_is_within_the_planner_s_hit_error`;
    /// taking the whole bound twice over, as the placement's, sent
    /// calibration-board, predicted 0.31 % of its pixels against a
    /// measured 0.008 %, to the wide arithmetic). Toward the horizon (`w →
    /// 0`) the cells pass a pixel apart and the sum passes 1. `w` is linear in the slopes: the box is
    /// cut into strips across the axis along which `w` changes more, and
    /// cells along it; in each cell the coefficients are taken at its
    /// centre and `min(1, A/w + B/w² + C)` is integrated along that axis in
    /// closed form ([`capped_mean`]).
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    fn cells_differing(&self, p: &PrimGeom, a: Arithmetic, geom: f64, looks: f64) -> f64 {
        const CELLS: usize = 4;
        const STRIPS: usize = 8;
        let Some(Cells { u, v, cell, seen }) = p.cells.filter(|_| self.integrates_cells(p)) else {
            return 0.0;
        };
        let (a_u, a_v) = (u.map(f64::from), v.map(f64::from));
        let n = p.n;
        let dist = dot3(n, p.c);
        if libm::fabs(dist) < 1e-12 {
            return 0.0;
        }
        // The field box, or its part where a disc's or rectangle's image
        // lies.
        let (xs, ys) = self.field;
        let [lo_x, hi_x, lo_y, hi_y] = seen.map(f64::from);
        let [x0, x1, y0, y1] = [lo_x.max(-xs), hi_x.min(xs), lo_y.max(-ys), hi_y.min(ys)];
        // (NaN, from no overlap, gives 0.)
        let share = (x1 - x0).max(0.0) * (y1 - y0).max(0.0) / (4.0 * xs * ys).max(1e-300);
        if share <= 0.0 {
            return 0.0;
        }
        let e = HitError::of(a, self.unit, libm::fabs(dist));
        let (fx, fy) = (self.f_row.max(1e-300), self.f_col.max(1e-300));
        let hyp = |x: f64, y: f64| libm::sqrt(x * x + y * y);
        // Per look, both families: 2 δu / c for the placement (`geom` a
        // bound, of either sign), the arithmetic's mean `|δu|` / c (half
        // its bound) for the hit's.
        let (k, kh) = (2.0 * looks / cell, 0.5 * looks / cell);
        let alpha = k * geom * (hyp(a_u[0] / fx, a_u[1] / fy) + hyp(a_v[0] / fx, a_v[1] / fy));
        let beta = (k * geom * hyp(n[0] / fx, n[1] / fy) + kh * e.w) / libm::fabs(dist);
        // `w = w0 + wx x̂ + wy ŷ`; `s` runs along the axis of the larger
        // change of `w` over the box, `t` across it.
        let (w0, wx, wy) = (n[2] / dist, n[0] / dist, n[1] / dist);
        let along_x = libm::fabs(wx) * (x1 - x0) >= libm::fabs(wy) * (y1 - y0);
        let ((s0, s1, ws), (t0, t1, wt)) = if along_x {
            ((x0, x1, wx), (y0, y1, wy))
        } else {
            ((y0, y1, wy), (x0, x1, wx))
        };
        let seg = (s1 - s0) / CELLS as f64;
        let mut sum = 0.0;
        for j in 0..STRIPS {
            let t = t0 + (j as f64 + 0.5) * (t1 - t0) / STRIPS as f64;
            for i in 0..CELLS {
                let s = s0 + (i as f64 + 0.5) * seg;
                let (x, y) = if along_x { (s, t) } else { (t, s) };
                let ad = |a: [f64; 3]| libm::fabs(a[0] * x + a[1] * y + a[2]);
                let ads = ad(a_u) + ad(a_v);
                let big_a = alpha + kh * (ads * e.t + 2.0 * e.a);
                let big_b = ads * beta;
                let c = kh * (ads + 2.0 * (0.5 + 1.0 / 32.0)) * e.stored;
                let wc = w0 + ws * s + wt * t;
                sum += capped_mean((big_a, big_b, c), wc, libm::fabs(ws) * seg / 2.0);
            }
        }
        share * sum / (CELLS * STRIPS) as f64
    }

    /// Through the aperture, the largest `|1 − z/Z̃|` over `p`'s depths
    /// (camera-frame `z`; a plane's up to the content's extent); 0 without.
    fn defocus_factor(&self, p: &PrimGeom) -> f64 {
        let Some((r, rz)) = self.aperture else {
            return 0.0;
        };
        let focus = r / rz.max(1e-300);
        let (near, far) = match p.shape {
            Shape::Plane { .. } => (0.0, self.extent),
            _ => (p.c[2] - p.r, p.c[2] + p.r),
        };
        libm::fabs(1.0 - near / focus).max(libm::fabs(1.0 - far / focus))
    }

    /// Rays through the aperture: they start up to its radius off the axis
    /// (the fast arithmetic's unit holds the content from there too).
    fn through_aperture(&mut self, scene: &Scene) {
        let lens = &scene.camera.lens;
        let r = lens.diameter().f64() / 2.0;
        let rz = r / lens.focus_distance().f64().max(1e-300);
        self.aperture = Some((r, rz));
        self.fast_extent += r;
        self.unit = libm::ldexp(1.0, unit_exp(self.fast_extent));
    }

    /// The pixel → undistorted error without a table, px: per axis, the
    /// slopes' rounding and the polynomial's — `u = r_d²` (δu) times
    /// `g' = k1 + 2 k2 u`, and `g` (δg), times the slope — and √2 of it for
    /// the distance. Fast: S26 slopes, `u` S20, `k`, `s`, `g` S28, all
    /// truncated; wide: I32F32, a few roundings of 2⁻³².
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    fn direct_geom_err(&self, a: Arithmetic, scene: &Scene) -> f64 {
        let (du, dg, dx) = match a {
            Arithmetic::Fast => (
                libm::ldexp(1.0, -20) + 2.0 * self.slope * libm::ldexp(1.0, -26),
                (2.0 + self.u_max) * libm::ldexp(1.0, -28),
                (1.0 + self.g_max) * libm::ldexp(1.0, -26),
            ),
            Arithmetic::Wide => (
                libm::ldexp(3.0, -32),
                libm::ldexp(3.0, -32),
                libm::ldexp(2.0, -32),
            ),
        };
        let dist = if scene.distortion.is_none() {
            0.0
        } else {
            let (k1, k2) = scene.distortion.coefficients();
            let deriv = libm::fabs(k1.f64()) + 2.0 * libm::fabs(k2.f64()) * self.u_max;
            self.slope_d[0].max(self.slope_d[1]) * (deriv * du + dg)
        };
        core::f64::consts::SQRT_2 * self.f_px * (dist + dx)
    }

    /// Whether the fast arithmetic's formats hold the scene (the checks
    /// [`crate::render::fast`] makes when a frame is prepared, in f64).
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    fn fast_fits(&self, scene: &Scene) -> Result<(), Unfit> {
        if !cfg!(feature = "mix32") {
            return Err(Unfit::NotBuilt);
        }
        if self.fast_extent > libm::ldexp(8.0, 20) {
            return Err(Unfit::TooFar);
        }
        // 2^-10 U, with a margin for the rounding of the prepared values.
        let small = libm::ldexp(self.unit, -10) * 1.01;
        if self.prims.iter().any(|p| p.smallest < small) {
            return Err(Unfit::TooSmall);
        }
        let shift = self.aperture.map_or(0.0, |(_, rz)| rz);
        if self.slope_d[0].max(self.slope_d[1]) >= 31.0 || self.slope + shift > 15.9 {
            return Err(Unfit::FieldTooWide);
        }
        if !scene.distortion.is_none() && (self.s_max >= 7.9 || self.g_max >= 7.9) {
            return Err(Unfit::Distortion);
        }
        if let Some(k) = self.origin_scale {
            if k <= 0.0 || k >= 127.0 * self.unit || self.slope * k > 63.0 * self.unit {
                return Err(Unfit::OriginsTooFar);
            }
        }
        Ok(())
    }
}

/// The resolutions an arithmetic computes with, from which the planner
/// bounds its error in LSB.
#[derive(Clone, Copy, Debug)]
pub struct ErrorModel {
    /// Relative error of the radiometric chain (irradiance, `1/r³`,
    /// products, `cos⁴α`).
    pub rel: f64,
    /// Absolute error of a hit point, metres (rounding of `t` and of the
    /// point).
    pub point: f64,
    /// How far a flat shape's boundary test can move, metres (the hit
    /// point's components as the test reads them): this, or with
    /// [`Boundary::FastHit`] a bound at each shape (`ErrorModel::boundary_m`).
    pub boundary: Boundary,
    /// Absolute error of `b = d·c` in the sphere test: metres, plus this
    /// much times `|c|`.
    pub b: f64,
    /// Of `b`, per metre of `|c|`.
    pub b_per_c: f64,
    /// Absolute error of `a r²` in the discriminant: m², plus this much
    /// times `r`.
    pub cc: f64,
    /// Of `a r²`, per metre of `r`.
    pub cc_per_c: f64,
    /// Relative error of `a = d·d`.
    pub a_rel: f64,
    /// Absolute error of the discriminant's own roundings, m².
    pub disc: f64,
    /// Absolute error of a unit vector's components (normals, `l̂`, `v̂`).
    pub unit: f64,
    /// Absolute error per term of the pixel sum, DN (truncations).
    pub per_term_dn: f64,
    /// Through the aperture, how far a ray's start is off its aperture
    /// point, metres: it moves a hit at depth `z` by this times
    /// `|1 − z/Z̃|` (the ray still meets its chief ray at `Z̃`).
    pub ap_origin: f64,
    /// A sphere under a specular lobe takes its normal from the ray and the
    /// sphere (`mix32::fine_normal`), not from the rounded hit point.
    pub fine_normal: bool,
    /// A plane without a lobe seen by perspective rays may be shaded in
    /// closed form (`mix32::Closed`): its point lights' terms from
    /// `w = n·d` and `q = w P_L − dist d` instead of the hit point. Its
    /// length unit `U`, metres, or `None`.
    pub closed_plane: Option<f64>,
}

impl ErrorModel {
    /// The model of `a` for the scene's geometry (the fast arithmetic's
    /// lengths are in the frame's unit `U`).
    fn of(a: Arithmetic, g: &Geometry) -> ErrorModel {
        let u = g.unit;
        let ap = if g.aperture.is_some() { 0.25 } else { 0.0 };
        let q32 = libm::ldexp(1.0, -32);
        match a {
            // S18 U hit points and t, S22 U b and d × c (from S24 U
            // centres, S26 slopes), the discriminant by Lagrange's identity
            // with r² in S24 U², S20 a, S30 unit vectors; 1/r to 2⁻¹⁹ (so E
            // to 3·2⁻¹⁹), n·l truncated 2⁻²¹, cos⁴α from 1/a (2⁻²¹,
            // squared), Pf products 2⁻³¹ each.
            // Through the aperture: each ray starts at its point rounded to
            // S18 U (`ap_origin`, ≤ 0.71·2⁻¹⁸ U off) and meets the chief
            // ray at the focused depth up to its slope shift's rounding (half
            // a unit of S26: 2⁻²⁴ U at 8 U; `n·A` truncated to S24 U).
            Arithmetic::Fast => ErrorModel {
                rel: 3.0 * libm::ldexp(1.0, -19) + libm::ldexp(1.0, -21) + libm::ldexp(1.0, -20) + 1e-8,
                point: (4.0 + ap) * libm::ldexp(u, -18),
                // Through the aperture, the bound as it was (the point's
                // S18 rounding): a flipped aperture ray moves a pixel that
                // the reference counts as smooth (it classifies by the
                // chief ray) by a share of the contrast, which a bound in
                // angle does not cover. With the shape's bound, a target
                // 6 m off focused at 20 m planned fast and 52 of its
                // smooth pixels differed by 2–3 LSB (2026-12-04).
                boundary: if g.aperture.is_some() {
                    Boundary::Fixed((2.0 + ap) * libm::ldexp(u, -18))
                } else {
                    Boundary::FastHit { unit: u }
                },
                b: libm::ldexp(u, -21) + ap * libm::ldexp(u, -23),
                ap_origin: if g.aperture.is_some() {
                    0.71 * libm::ldexp(u, -18)
                } else {
                    0.0
                },
                b_per_c: 0.0,
                cc: libm::ldexp(u * u, -24),
                cc_per_c: 2.0 * libm::ldexp(u, -24),
                a_rel: libm::ldexp(1.0, -20),
                disc: 0.0,
                unit: libm::ldexp(1.0, -28),
                per_term_dn: libm::ldexp(1.0, -14),
                fine_normal: true,
                closed_plane: Some(u),
            },
            // I32F32 throughout: 2⁻³² m per rounding (each product, the
            // camera-frame centre's components), some 40 roundings of
            // quantities below 2⁸ in the radiometric chain (2⁻²⁰ relative);
            // the sphere's discriminant by Lagrange's identity (`r²` rounded
            // once).
            Arithmetic::Wide => ErrorModel {
                rel: libm::ldexp(1.0, -20),
                point: (8.0 + 2.0 * g.extent) * q32,
                boundary: Boundary::Fixed((4.0 + g.extent) * q32),
                b: 4.0 * q32,
                b_per_c: 2.0 * q32,
                cc: 2.0 * q32,
                cc_per_c: 0.0,
                a_rel: 2.0 * q32,
                disc: 2.0 * q32,
                unit: 4.0 * q32,
                per_term_dn: q32,
                ap_origin: 0.0,
                fine_normal: false,
                closed_plane: None,
            },
        }
    }

    /// Predicted largest `|core − reference|` before the final rounding,
    /// LSB, over smooth pixels.
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    fn lsb(&self, scene: &Scene, g: &Geometry, geom_px: f64) -> f64 {
        // The radiometric chain: relative to the value, which matters only
        // up to DN_max (a value far above it saturates in both).
        let terms = (2 + 2 * scene.lights.len()) as f64;
        let base = self.rel * g.dn_max * 1.01 + terms * self.per_term_dn;
        let mut worst: f64 = base;
        // An angle of 1/256 px: a pixel that far inside a silhouette is
        // not an edge pixel.
        let dtheta = 1.0 / (256.0 * g.f_px);
        for p in &g.prims {
            // Through the aperture, the rays' start moves their hits.
            let shift = self.ap_origin * g.defocus_factor(p);
            // Normal error, and the hit point's.
            let (dn, dp) = match p.shape {
                Shape::Sphere { .. } => {
                    // a t² − 2 b t + cc = 0 with b ≈ |c| √a, cc = |c|² − r²
                    // (a ≥ 1; the worst case is a = 1).
                    let c = norm3(p.c).max(p.r);
                    let db = self.b + self.b_per_c * c + shift;
                    // a r² − |d × c|² (Lagrange's identity; both
                    // arithmetics): |d × c| = r √a at the silhouette, its
                    // components as b's.
                    let ddisc = 2.0 * p.r * 1.8 * db
                        + p.r * p.r * self.a_rel
                        + self.cc
                        + self.cc_per_c * p.r
                        + self.disc;
                    // The discriminant a (r² − h²) at 1/256 px inside the
                    // silhouette: 2 r |c| δθ. Its error moves the hit point
                    // along the ray by δdisc / (2 √disc) (at most √δdisc).
                    // (Parallel rays: 1/256 px is k δθ sideways.)
                    let lateral = g.origin_scale.unwrap_or(c);
                    let disc_min = (2.0 * p.r * lateral * dtheta).max(1e-300);
                    if ddisc >= disc_min {
                        // The rounding can flip hit and miss farther than
                        // 1/256 px inside the silhouette: a smooth pixel may
                        // see what lies behind the sphere instead.
                        return g.dn_max * 2.0;
                    }
                    let along = ddisc / (2.0 * libm::sqrt(disc_min));
                    let dp = self.point + db + along;
                    (dp / p.r + self.unit, dp)
                }
                Shape::Disc { .. } | Shape::Rectangle { .. } => {
                    // The boundary test moves with the hit point: by more
                    // than 1/256 px where the boundary is nearest.
                    // Its distance from the lens is at least that of the
                    // plane, h, and of the circle around it in the plane.
                    let h = libm::fabs(dot3(p.c, p.n));
                    let c_in = libm::sqrt((dot3(p.c, p.c) - h * h).max(0.0));
                    let out = match p.shape {
                        Shape::Disc { .. } => libm::fabs(c_in - p.r),
                        _ => (c_in - p.r).max(0.0),
                    };
                    let nearest = libm::sqrt(h * h + out * out).max(1e-300);
                    let lateral = g.origin_scale.unwrap_or(nearest);
                    if (self.boundary_m(g, p) + shift) / lateral >= dtheta {
                        return g.dn_max * 2.0;
                    }
                    (self.unit, self.point + shift)
                }
                Shape::Plane { .. } => (self.unit, self.point + shift),
            };
            let e = if self.fine_normal && p.exponent > 0 && matches!(p.shape, Shape::Sphere { .. }) {
                // Pixels whose n̂·v̂ is at least ν take the fine normal's
                // error (A); below ν, next to the silhouette, the lobe is
                // bounded by geometry (B): r̂·v̂ = 2 (n̂·l̂)(n̂·v̂) − l̂·v̂ < 2ν
                // − λ, λ a lower bound of l̂·v̂ over the sphere. The best ν
                // of a few, or the bound without the split if smaller.
                let mut best = self.light_terms(scene, g, p, dn, dp, dn, None);
                for nu in [0.7, 0.5, 0.35, 0.25, 0.125] {
                    let (dn_a, dp_a) = self.fine_normal_err(g, p, nu, geom_px, dp);
                    let a = self.light_terms(scene, g, p, dn, dp_a, dn_a, None);
                    let b = self.light_terms(scene, g, p, dn, dp, dn, Some(nu));
                    best = best.min(a.max(b));
                }
                best
            } else {
                self.light_terms(scene, g, p, dn, dp, dn, None)
            };
            // A plane's rays that meet nothing else take the closed form.
            let e = match (self.closed_plane, p.shape, g.origin_scale) {
                (Some(u), Shape::Plane { .. }, None) => e.max(self.closed_terms(scene, g, p, dn, u)),
                _ => e,
            };
            worst = worst.max(base + e.min(g.dn_max * 2.0));
        }
        worst
    }
}

/// How far an arithmetic's flat-shape boundary test can move
/// ([`ErrorModel::boundary`]).
#[derive(Clone, Copy, Debug)]
pub enum Boundary {
    /// At most this many metres anywhere.
    Fixed(f64),
    /// The fast arithmetic's, whose lengths are in the frame's unit `U`
    /// (metres): `fast_boundary_m` at each shape.
    FastHit {
        /// `U`, metres.
        unit: f64,
    },
}

/// How far the fast arithmetic's boundary test of a disc or rectangle
/// (`mix32::MixShape::nearest`) can move its boundary, metres, for rays
/// whose direction `d` (a perspective ray's `(x̂, ŷ, 1)`, a parallel
/// ray's `(0, 0, 1)`) has an in-plane part of at most `s` and a length of
/// at most `d_len`, hits at `t ≤ t_max` (depth from where the rays start,
/// metres) with `1/|n̂·d| ≤ k` (a parallel ray's `1/|n_z|`), on a shape of
/// radius (a rectangle's half-diagonal) `r`, in a frame of unit `u`.
///
/// The test reads the hit as `t` (S18 U) times the ray's slopes or axes,
/// not as a point rounded to S18, against a centre and half sizes in S24
/// U. `t = dist/(n̂·d)` errs by `δt ≤ t 2⁻²¹` (the reciprocal) `+ 3
/// 2⁻²⁴ U k` (`dist`; a parallel ray's `n·o`, an aperture ray's `n·A`)
/// `+ t 2⁻²⁴ k` (`n̂·d`, or `n_z` in S30) `+ (2 + 2⁻⁵ k) 2⁻¹⁸ U`
/// (`mul_shr_t`'s floors, whose left shift `l` has `2^l < 2⁻⁵ k`). The hit
/// moves by `δt` along the ray: the coordinate of a rectangle's axis, or a
/// disc's distance from its centre, by `s δt`. Then a rectangle's `d·â` is truncated to S24 and its axis
/// rounded to S30 (`t (2⁻²⁴ + 2⁻³⁰ |d|)`); the centre, the point's
/// coordinates and the half sizes or radius are floored to S24 (`5 2⁻²⁴
/// U`); and a disc's distance takes the square of the error vector over
/// `2 r` (`(|d| δt + 4 2⁻²⁴ U)² / 2r`).
/// `mix32::tests::a_flat_shape_s_boundary_moves_within_the_planner_s_bound`
/// measures it.
pub(crate) fn fast_boundary_m(u: f64, s: f64, d_len: f64, t_max: f64, k: f64, r: f64) -> f64 {
    let ld = libm::ldexp;
    let dt = t_max * ld(1.0, -21)
        + 3.0 * ld(u, -24) * k
        + t_max * ld(1.0, -24) * k
        + (2.0 + ld(k, -5)) * ld(u, -18);
    let e = libm::fabs(d_len) * dt + 4.0 * ld(u, -24);
    s * dt + t_max * (ld(1.0, -24) + ld(d_len, -30)) + 5.0 * ld(u, -24) + e * e / (2.0 * r).max(1e-300)
}

impl ErrorModel {
    /// How far the boundary test of `p` (a disc or rectangle) can move,
    /// metres ([`ErrorModel::boundary`]). The fast arithmetic's from
    /// [`fast_boundary_m`] with the largest in-plane part of the rays'
    /// directions over the field box's corners (where that quadratic form
    /// is largest), `t` up to the shape's farthest depth, and `1/|n̂·d|`
    /// up to that over the plane's distance.
    fn boundary_m(&self, g: &Geometry, p: &PrimGeom) -> f64 {
        let unit = match self.boundary {
            Boundary::Fixed(m) => return m,
            Boundary::FastHit { unit } => unit,
        };
        let n = p.n;
        let t_max = (p.c[2] + p.r).max(0.0);
        let (s, d_len, k) = match g.origin_scale {
            Some(_) => {
                let nz = libm::fabs(n[2]);
                (libm::sqrt((1.0 - nz * nz).max(0.0)), 1.0, 1.0 / nz.max(1e-300))
            }
            None => {
                let (xs, ys) = g.field;
                let mut s2: f64 = 0.0;
                for (x, y) in [(xs, ys), (xs, -ys), (-xs, ys), (-xs, -ys)] {
                    let d = [x, y, 1.0];
                    let nd = dot3(n, d);
                    s2 = s2.max(dot3(d, d) - nd * nd);
                }
                let d_len = libm::sqrt(1.0 + xs * xs + ys * ys);
                (
                    libm::sqrt(s2),
                    d_len,
                    t_max / libm::fabs(dot3(n, p.c)).max(1e-300),
                )
            }
        };
        fast_boundary_m(unit, s, d_len, t_max, k, p.r)
    }

    /// The error, DN, of the terms of every light on primitive `p`, with
    /// the normal's error `dn` (diffuse), the hit point's `dp` (metres),
    /// and for the lobe the normal's error `lobe_dn` or, with `cap = ν`,
    /// the lobe bounded by geometry: both values lie in `[0, D X^s]` with
    /// `X = 2ν − λ + δx`.
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn light_terms(
        &self,
        scene: &Scene,
        g: &Geometry,
        p: &PrimGeom,
        dn: f64,
        dp: f64,
        lobe_dn: f64,
        cap: Option<f64>,
    ) -> f64 {
        let gain = g.gain;
        let mut e = 0.0;
        for (l, lp) in scene.lights.iter().zip(&g.lights) {
            let (strength, r_min) = match (*l, lp) {
                (Light::Point { intensity, .. }, Some(pos)) => {
                    let i = intensity.iter().map(|v| v.f64()).fold(0.0, f64::max);
                    let r = prim_light_distance(p, *pos).max(1e-9);
                    (i / (r * r), r)
                }
                (Light::Directional { irradiance, .. }, _) => (
                    irradiance.iter().map(|v| v.f64()).fold(0.0, f64::max),
                    f64::INFINITY,
                ),
                _ => (0.0, f64::INFINITY),
            };
            // cos moves by the normal's error (absolute: D δn, also
            // where a grazing pixel is dim), 1/r² by 3 δp / r relative
            // (of a value that matters only up to DN_max).
            let d = gain * p.kd * strength;
            let rel = 3.0 * dp / r_min + self.rel;
            e += d * dn + d.min(g.dn_max * 1.01) * rel;
            let d_spec = gain * p.ks * strength;
            if d_spec > 0.0 {
                // r̂·v̂ = x moves by 4 δn + 3 δl̂ + 3 δv̂; x^s by s x^(s−1)
                // δx. Where the term exceeds DN_max the pixel saturates
                // in both: x^s ≤ DN_max / D, so the error is at most
                // s δx DN_max / x with x = min(1, (DN_max / D)^(1/s)).
                let dx = 4.0 * lobe_dn + 3.0 * (dp / r_min + self.unit) + 3.0 * self.unit;
                let s = p.exponent.max(1) as f64;
                e += match cap {
                    Some(nu) => {
                        let x = 2.0 * nu - view_light_cos_min(scene, g, p, l, *lp) + dx;
                        if x <= 0.0 {
                            0.0
                        } else {
                            (d_spec * pow(x.min(1.0), s)).min(g.dn_max * 1.01)
                        }
                    }
                    None => {
                        let x = pow((g.dn_max / d_spec).min(1.0), 1.0 / s).max(1e-9);
                        d_spec * lobe_dn
                            + d_spec.min(g.dn_max * 1.01) * rel
                            + s * dx * g.dn_max.min(d_spec) / x
                    }
                };
            }
        }
        e
    }

    /// The error, DN, of the terms of every light on plane `p` shaded in
    /// closed form (`mix32::Closed`, lengths in `U = u` metres), with the
    /// normal's error `dn`. A point light at distance `L` from the camera
    /// and height `h` over the plane (distance `dist` from the camera)
    /// gives `E = D h³/r³` at distance `r = x h ≥ h` (`D` its term at `h`),
    /// and `E ∝ (|w|/|q|)³` with `|q| = |w| r` and `1/|w| ≤ (r + L)/dist`
    /// (the hit lies within `r + L` of the camera). So `w`'s error `δw`
    /// (its S24 truncation, `n`'s and `d`'s roundings: below 2⁻²³) moves
    /// `E` by `3 δw (r + L)²/(dist r) ≤ 3 δw x (h + L)²/(dist h)` relative,
    /// which grows with `r` where `E` falls: with the pixel saturating above
    /// `DN_max`, `min(E, DN_max) x ≤ min(D, DN_max) x_c`, `x_c = max(1,
    /// (D/DN_max)^⅓)` where `E` reaches `DN_max`. `q`'s roundings (its S22
    /// truncation, `dist`'s and `d`'s over `|w| r`, `P_L`'s S18 over `r`)
    /// and the rest (`1/√` three times, the products) are largest at
    /// `r = h`.
    #[inline(never)]
    fn closed_terms(&self, scene: &Scene, g: &Geometry, p: &PrimGeom, dn: f64, u: f64) -> f64 {
        let cap = g.dn_max * 1.01;
        let dist = libm::fabs(dot3(p.c, p.n)).max(1e-300);
        let mut e = 0.0;
        for (l, lp) in scene.lights.iter().zip(&g.lights) {
            let (irradiance, pos) = match (*l, lp) {
                (Light::Point { intensity, .. }, Some(pos)) => (intensity, *pos),
                (Light::Directional { irradiance, .. }, _) => (irradiance, [f64::INFINITY; 3]),
                _ => continue,
            };
            let i = irradiance.iter().map(|v| v.f64()).fold(0.0, f64::max);
            // Directional terms are the general path's, summed once a frame.
            let (d, rel) = if pos[0].is_finite() {
                let h = prim_light_distance(p, pos).max(1e-9);
                let hl = h + norm3(pos);
                let d = g.gain * p.kd * i / (h * h);
                let rel_q = (1.74 * libm::ldexp(u, -22) + libm::ldexp(u, -24)) * hl / dist
                    + 1.74 * libm::ldexp(u, -18)
                    + 1.42 * libm::ldexp(hl, -26);
                let x_c = pow((d / cap).max(1.0), 1.0 / 3.0);
                (
                    d,
                    1e-8 + 3.0 * (rel_q + libm::ldexp(x_c * hl * hl / dist, -23)) / h,
                )
            } else {
                (g.gain * p.kd * i, 0.0)
            };
            e += d * dn + d.min(cap) * (self.rel + rel);
        }
        e
    }

    /// The error of `mix32::fine_normal` (absolute, per component) on a
    /// sphere's pixels whose `n̂·v̂ ≥ ν`, and the hit point's there (`dp`
    /// with the silhouette's along-ray term at `ν` instead of 1/256 px):
    /// the ray's direction error `δθ` (the geometric error over `f`, plus
    /// `d̂`'s 2⁻²⁸) moves `c⊥` by `2 |c| δθ` (parallel rays: their origin
    /// by `k δθ`), and `s = √(r² − |c⊥|²)` by `|c⊥| δc⊥ / s ≤ δc⊥ / ν`;
    /// roundings of a few S24 units, the square root's 2⁻²⁷.
    fn fine_normal_err(&self, g: &Geometry, p: &PrimGeom, nu: f64, geom_px: f64, dp: f64) -> (f64, f64) {
        let u = g.unit;
        let s24 = libm::ldexp(u, -24);
        let dtheta = geom_px / g.f_px + libm::ldexp(1.0, -28);
        let (lever, rounding) = match g.origin_scale {
            None => (2.0 * norm3(p.c), 4.0 * s24),
            Some(k) => (k, libm::ldexp(u, -18)),
        };
        let r = p.r.max(1e-300);
        let e_perp = lever * dtheta + rounding;
        let e_s = e_perp / nu + r * libm::ldexp(1.0, -27) + 2.0 * s24 / nu;
        let e_sd = r * dtheta + s24;
        let dn = (e_perp + e_s + e_sd) / r + libm::ldexp(1.0, -27);
        // The S18 hit point still serves the light's direction; next to
        // the silhouette its along-ray error is at most that at ν.
        let c = norm3(p.c).max(p.r);
        let db = self.b + self.b_per_c * c;
        let ddisc = 2.0 * p.r * 1.8 * db + p.r * p.r * self.a_rel + self.cc + self.cc_per_c * p.r + self.disc;
        let disc_nu = (nu * nu * r * r - ddisc).max(1e-300);
        let dp_a = (self.point + db + ddisc / (2.0 * libm::sqrt(disc_nu))).min(dp);
        (dn, dp_a)
    }
}

/// A lower bound of `l̂·v̂` over sphere `p`'s points (`v̂` towards the
/// camera, `l̂` towards light `l`): the angle at a point between the two
/// directions exceeds that at the centre by at most `asin(r / distance)`
/// for each end (the camera's only for perspective rays); −1 if an end
/// lies within the sphere.
fn view_light_cos_min(scene: &Scene, g: &Geometry, p: &PrimGeom, l: &Light, lp: Option<[f64; 3]>) -> f64 {
    let spread = |d: f64| {
        if d > p.r {
            libm::asin(p.r / d)
        } else {
            core::f64::consts::PI
        }
    };
    let (v, sv) = match g.origin_scale {
        None => ([-p.c[0], -p.c[1], -p.c[2]], spread(norm3(p.c))),
        Some(_) => ([0.0, 0.0, -1.0], 0.0),
    };
    let (to_l, sl) = match (*l, lp) {
        (Light::Point { .. }, Some(pos)) => {
            let d = sub3(pos, p.c);
            (d, spread(norm3(d)))
        }
        (Light::Directional { towards, .. }, _) => (cam_direction(scene, towards), 0.0),
        _ => return -1.0,
    };
    let cos0 = dot3(v, to_l) / (norm3(v) * norm3(to_l)).max(1e-300);
    let angle = libm::acos(cos0.clamp(-1.0, 1.0)) + sv + sl;
    if angle >= core::f64::consts::PI {
        -1.0
    } else {
        libm::cos(angle)
    }
}

/// The bound of `closed_mean_err` (the pairs') times what the
/// interpolation `m` multiplies it by: over `s` rays its largest
/// curvature term is `s²/8 · max|φ''|` (`M`), 4 times the pairs' over 4
/// rays, 16 over 8; 0 without it. The means of means below it stay
/// within it: over 8 rays the rays 4 apart are within `8M`, those 2
/// apart within `2M + 8M/2`, the odd ones within `M/2 + (6M + 8M)/2`;
/// over 4, `2M` and `M/2 + 2M/2`. (The roundings down, one a level, are
/// within the `2⁻¹⁵` it scales.)
pub fn closed_mean_factor(m: ClosedMean) -> f64 {
    let s = f64::from(m.span());
    if m.on() {
        s * s / 4.0
    } else {
        0.0
    }
}

/// The share of the closed plane's light terms that the interpolation `m`
/// leaves out in a chunk of 32 rays ([`ClosedMean::shaded`]), in units of
/// the pairs' (15 of 32 left out): `Quads` leaves out 22 and `Octs` 25,
/// so 22/15 and 25/15.
pub fn closed_mean_skipped(m: ClosedMean) -> f64 {
    const RAYS: usize = 32;
    let left_out = |m: ClosedMean| (RAYS - m.shaded(RAYS)) as f64;
    left_out(m) / left_out(ClosedMean::Pairs)
}

/// A bound, DN, on what the closed plane's mean (`mix32::mean`,
/// [`Options::closed_mean`]) moves a pixel's sum: the plane's term under
/// its one point light, `T = D (h/r)³` (`D` at the light's foot, `h` its
/// height, `r = |p − P_L|`), taken at a ray between two as their mean.
/// Along a row `φ(i) = T(p(i))`, and `|φ(i) − (φ(i−1) + φ(i+1))/2| ≤
/// max|φ''|/2`, with `φ'' = p'ᵀ H p' + ∇T·p''`. The hit moves on the
/// plane, so `H` and `∇T` are those of `T` on the plane, a function of the
/// hit's distance `ρ = σ h` from the light's foot `F`: `T = D (1 +
/// s)^(−3/2)`, `s = σ²`, whose Hessian has the eigenvalues `−(3D/h²)(1 +
/// s)^(−5/2)` and `(3D/h²)(4s − 1)(1 + s)^(−7/2)` and whose gradient is
/// `(3D/h) σ (1 + σ²)^(−5/2)` (each bounded over a cell's `σ` range at its
/// largest point: the second is within the first for `s ≤ 2/3` and peaks
/// at `s = 3/4`, the gradient peaks at `σ = 1/2`; the 3-D bounds `12T/r²`
/// and `3T/r` gave the standard scene 0.404 LSB over 4 rays, these
/// 0.066). With the hit `p = t d` (`d = (x̂, ŷ, 1)`, `t ≤ R`, its distance
/// `R ≥ dist` from the camera) and `t' = −t κ`, `κ = n·d'/n·d` (`|n·d| =
/// dist/t`): `|p'| ≤ R (d₁ + R ν₁/dist)` and `|p''| ≤ R d₂ + 2R² ν₁
/// d₁/dist + R (2R² ν₁²/dist² + R ν₂/dist)`, where `d₁, d₂` bound `|d'|,
/// |d''|` along a row and `ν₁, ν₂` bound `|n·d'|, |n·d''|` (from `x̂ =
/// x̂_d g(u)`, `ŷ = ŷ_d g(u)` term by term: `|x̂'| ≤ (g + 2u(|k1| +
/// 2|k2|u))/f_x`, `|ŷ'| ≤ u(|k1| + 2|k2|u)/f_x`, `|x̂''| ≤ √u(6|k1| +
/// 20|k2|u)/f_x²`, `|ŷ''| ≤ √u(2|k1| + 12|k2|u)/f_x²`; `g`, `u` the
/// distortion's largest, [`Geometry`]). The hit lies `√(R² − dist²)` from
/// the camera's foot on the plane, and `F` at `foot` from it, so `ρ` lies
/// within that ring's nearest and farthest from `F`. The largest over
/// cells of `R` up to 10³ times the scene's distances (the bound falls as
/// `1/R` beyond): 10 % wide up to 4 times the distance at which the hit
/// passes the light's foot, 25 % beyond; before the noise
/// ([`noise_moved`] adds what it does). `None` without the plane, or with
/// more than one point light (no mean then). (The camera plans every
/// pose: some 50 cells, a few divisions and square roots each, the cells
/// past the fine ones cut short by [`MeanCells::worst`].)
/// [`closed_mean_factor`] scales it to an interpolation over more rays.
#[inline(never)]
fn closed_mean_err(scene: &Scene, g: &Geometry) -> Option<f64> {
    let p = g.prims.get(g.closed?)?;
    let mut points = scene
        .lights
        .iter()
        .zip(&g.lights)
        .filter_map(|(l, lp)| match (l, lp) {
            (Light::Point { intensity, .. }, Some(pos)) => Some((*intensity, *pos)),
            _ => None,
        });
    let (intensity, pos) = points.next()?;
    if points.next().is_some() {
        return None;
    }
    let i = intensity.iter().map(|v| v.f64()).fold(0.0, f64::max);
    let dist = libm::fabs(dot3(p.c, p.n)).max(1e-300);
    let h = prim_light_distance(p, pos).max(1e-300);
    let l = norm3(pos);
    let foot = libm::sqrt((l * l - (h - dist) * (h - dist)).max(0.0));
    let d = g.gain * p.kd * i / (h * h);
    let (u, f) = (g.u_max, g.f_row);
    let (k1, k2) = scene.distortion.coefficients();
    // (|k1| and |k2| u.)
    let (k1, k2u) = (libm::fabs(k1.f64()), libm::fabs(k2.f64()) * u);
    // Along a row (x̂ = x̂_d g(u), ŷ = ŷ_d g(u), u = x̂_d² + ŷ_d², x̂_d
    // stepping 1/f): ∂x̂/∂x̂_d = g + 2x̂_d² g', ∂ŷ/∂x̂_d = 2x̂_d ŷ_d g',
    // ∂²x̂/∂x̂_d² = 6x̂_d g' + 8k2 x̂_d³, ∂²ŷ/∂x̂_d² = ŷ_d (2g' + 8k2 x̂_d²),
    // with g' = k1 + 2k2 u, x̂_d² ≤ u and 2|x̂_d ŷ_d| ≤ u.
    let (x1, y1) = (
        (g.g_max + 2.0 * u * (k1 + 2.0 * k2u)) / f,
        u * (k1 + 2.0 * k2u) / f,
    );
    let (x2, y2) = (
        libm::sqrt(u) * (6.0 * k1 + 20.0 * k2u) / (f * f),
        libm::sqrt(u) * (2.0 * k1 + 12.0 * k2u) / (f * f),
    );
    let (nx, ny) = (libm::fabs(p.n[0]), libm::fabs(p.n[1]));
    let (d1, d2) = (libm::sqrt(x1 * x1 + y1 * y1), libm::sqrt(x2 * x2 + y2 * y2));
    let (n1, n2) = (nx * x1 + ny * y1, nx * x2 + ny * y2);
    let cells = MeanCells::new((dist, foot, h, l), d, (d1, d2, n1, n2));
    Some(cells.worst(true).0 + libm::ldexp(1.0, -15))
}

/// [`closed_mean_err`]'s cells of `R`: the plane's distance `dist`, the
/// light's foot `foot` from the camera's and its height `h` (m), `D`, the
/// bounds `d₁, d₂` on `|d'|, |d''|` and `ν₁ dist, ν₂ dist` on `|n·d'|,
/// |n·d''|` along a row, and the cells' end `top` and the end of the fine
/// ones `fine` (m).
#[derive(Clone, Copy, Debug)]
struct MeanCells {
    dist: f64,
    foot: f64,
    h: f64,
    d: f64,
    d1: f64,
    d2: f64,
    n1: f64,
    n2: f64,
    top: f64,
    fine: f64,
}

impl MeanCells {
    /// The cells for the plane `dist` from the camera, the light `h` from
    /// the plane and `l` from the camera, its foot `foot` from the
    /// camera's (m): cells of R (each bounded at its worst ends) up to 10³
    /// times the scene's distances, where the bound falls as 1/R — 10 %
    /// wide up to 4 times the distance at which the hit passes the light's
    /// foot (the bound's largest lie there), 25 % beyond.
    fn new(
        (dist, foot, h, l): (f64, f64, f64, f64),
        d: f64,
        (d1, d2, n1, n2): (f64, f64, f64, f64),
    ) -> MeanCells {
        MeanCells {
            dist,
            foot,
            h,
            d,
            d1,
            d2,
            n1,
            n2,
            top: 1e3 * (dist + l + h),
            fine: 4.0 * libm::sqrt(foot * foot + dist * dist),
        }
    }

    /// The largest cell's bound, LSB, and the cells taken. With `early`,
    /// the cells beyond the fine ones stop once [`closed_mean_tail`] bounds
    /// every one left within the largest so far: the same value (`tests`),
    /// with fewer cells (the camera plans every pose, at some 5 000 M3
    /// instructions a cell in soft-float).
    fn worst(&self, early: bool) -> (f64, u32) {
        let MeanCells {
            dist,
            foot,
            h,
            d,
            d1,
            d2,
            n1,
            n2,
            top,
            fine,
        } = *self;
        let inv_dist = 1.0 / dist;
        let (nu1, nu2) = (n1 * inv_dist, n2 * inv_dist);
        let (mut ra, mut ring_a, mut worst, mut cells) = (dist, 0.0, 0.0f64, 0);
        while ra < top {
            // Beyond the fine cells, once every cell from here on is
            // provably within `worst`, the rest cannot move it.
            if early
                && ra >= fine
                && closed_mean_tail((ra, ring_a - foot), (h, d), (d1, d2), (nu1, nu2)) <= worst
            {
                break;
            }
            let rb = ra * if ra < fine { 1.1 } else { 1.25 };
            // How far the hit lies from the camera's foot on the plane.
            let ring_b = libm::sqrt((rb * rb - dist * dist).max(0.0));
            // The hit's distance ρ from the light's foot, in units of h: σ in
            // [lo, hi].
            let (lo, hi) = (
                (ring_a - foot).max(foot - ring_b).max(0.0) / h,
                (ring_b + foot) / h,
            );
            let (s_lo, s_hi) = (lo * lo, hi * hi);
            // (1 + s)^(−5/2).
            let fall = |s: f64| 1.0 / ((1.0 + s) * (1.0 + s) * libm::sqrt(1.0 + s));
            // On the plane T = D (1 + s)^(−3/2), s = σ²: its Hessian's
            // eigenvalues are T'/ρ = −D (3/h²)(1 + s)^(−5/2), largest at s_lo,
            // and T'' = D (3/h²)(4s − 1)(1 + s)^(−7/2), within the first where
            // s ≤ 2/3 and beyond it largest at s = 3/4; its gradient is D (3/h)
            // σ (1 + σ²)^(−5/2), largest at σ = 1/2. (`max` and `min`, not
            // `clamp`, which would link a panic path.) Where the cell lies
            // beyond both peaks (s_lo ≥ 3/4, σ_lo ≥ 1/2) all three are taken
            // at s_lo: one square root, not three.
            let f_lo = fall(s_lo);
            let s = 0.75f64.max(s_lo).min(s_hi);
            let f_s = if s == s_lo { f_lo } else { fall(s) };
            let hess = 3.0 * f_lo.max(libm::fabs(4.0 * s - 1.0) * f_s / (1.0 + s)) / (h * h);
            let sg = 0.5f64.max(lo).min(hi);
            let sg2 = sg * sg;
            let f_g = if sg2 == s_lo { f_lo } else { fall(sg2) };
            let grad = 3.0 * sg * f_g / h;
            let m = rb * n1 * inv_dist;
            let dp = rb * (d1 + m);
            let ddp = rb * (d2 + 2.0 * m * d1 + 2.0 * m * m + rb * n2 * inv_dist);
            worst = worst.max(0.5 * d * (hess * dp * dp + grad * ddp));
            (ra, ring_a, cells) = (rb, ring_b, cells + 1);
        }
        (worst, cells)
    }
}

/// An upper bound on [`closed_mean_err`]'s cell values for every cell from
/// `ra` (m) on, decreasing in `ra`; infinite where it does not apply.
/// With `L = ring_a − foot ≥ κ ra` (`κ = L/ra`, which only grows with
/// `ra`) and `κ ra ≥ h/2`, every later cell `[r, r_b]` (`r_b ≤ 1.25 r`)
/// has `σ_lo ≥ L/h ≥ 1/2`, so its Hessian bound is at most `12 σ_lo⁻⁵/h²`
/// (`(1 + s)^(−5/2) ≤ σ⁻⁵`, `|4s − 1|/(1 + s) < 4`, the value at `s ≥
/// s_lo` at most that at `s_lo`) and its gradient bound `3 σ_lo⁻⁴/h`,
/// with `σ_lo ≥ κ r/h`; `|p'| ≤ 1.25 r (d₁ + 1.25 r ν₁)` and `|p''| ≤
/// 1.25 r (d₂ + 2.5 r ν₁ d₁ + 3.125 r² ν₁² + 1.25 r ν₂)` (`ν = n·d/dist`).
/// Each term is a positive multiple of `r^(−k)`, `k ≥ 1`: decreasing.
fn closed_mean_tail(
    (ra, l): (f64, f64),
    (h, d): (f64, f64),
    (d1, d2): (f64, f64),
    (nu1, nu2): (f64, f64),
) -> f64 {
    if !(l > 0.0 && 2.0 * l >= h) {
        return f64::INFINITY;
    }
    let k = l / ra;
    let (k2, r) = (k * k, ra);
    let hess = 12.0 / (k2 * k2 * k);
    let grad = 3.75 / (k2 * k2);
    let a = 1.25 * d1 + 1.5625 * r * nu1;
    let tail = hess * a * a / (r * r * r)
        + grad * (d2 / (r * r * r) + (2.5 * nu1 * d1 + 1.25 * nu2) / (r * r) + 3.125 * nu1 * nu1 / r);
    // (A hair above, for the roundings of the values it bounds.)
    0.5 * d * h * h * h * tail * (1.0 + 1e-9)
}

/// A bound (LSB) on what a move `e` of the noise-free value `μ` moves a
/// recorded value by, its noise included (the move itself if the scene has
/// none): the value is `μ + σ(μ) z + …`, `σ = √(K_sys μ + (K_sys σ_d)²)`,
/// `|z| ≤ Z_MAX`, so `σ z` moves by at most `Z_MAX √(K_sys e)` (the square
/// root's modulus of continuity) and at most `Z_MAX e/(2 σ_d)` (its
/// slope, `σ ≥ K_sys σ_d`).
fn noise_moved(scene: &Scene, g: &Geometry, e: f64) -> f64 {
    let Some(z) = scene.noise else {
        return e;
    };
    let k = g.dn_max / z.saturation_e.f64().max(1.0);
    let sd = z.dark_noise_e.f64();
    let slope = if sd > 0.0 {
        Z_MAX * e / (2.0 * sd)
    } else {
        f64::INFINITY
    };
    e + slope.min(Z_MAX * libm::sqrt(k * e))
}

/// What the core's noise draw adds to `|core − reference|` (LSB) at the
/// same noise-free value, 0 without noise: its `z` is within `Z_ERR` of the
/// reference's (its table) and its `σ` within 2⁻¹⁹ relative and 2⁻¹⁶ DN
/// (`mix32::sigma_z16`; the wide arithmetic's square root is finer), `σ ≤
/// √(DN_max²/μ_e,sat + (DN_max σ_d/μ_e,sat)²)`.
fn noise_draw_lsb(scene: &Scene, g: &Geometry) -> f64 {
    let Some(z) = scene.noise else {
        return 0.0;
    };
    let k = g.dn_max / z.saturation_e.f64().max(1.0);
    let sd = z.dark_noise_e.f64();
    let sigma = libm::sqrt(k * g.dn_max + k * k * sd * sd);
    sigma * Z_ERR + Z_MAX * (sigma * libm::ldexp(1.0, -19) + libm::ldexp(1.0, -16))
}

/// The distance from a point light to the nearest point of a primitive
/// (a lower bound), metres.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
fn prim_light_distance(p: &PrimGeom, l: [f64; 3]) -> f64 {
    match p.shape {
        Shape::Plane { .. } => libm::fabs(dot3(sub3(l, p.c), p.n)),
        Shape::Sphere { .. } => (norm3(sub3(l, p.c)) - p.r).max(0.0),
        Shape::Disc { .. } | Shape::Rectangle { .. } => {
            let d = sub3(l, p.c);
            let h = libm::fabs(dot3(d, p.n));
            let lateral = (norm3(d) * norm3(d) - h * h).max(0.0);
            let out = (libm::sqrt(lateral) - p.r).max(0.0);
            libm::sqrt(h * h + out * out)
        }
    }
}

/// The scene's features a cost prediction is linear in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Features {
    /// Primitives by kind: planes, spheres, discs, rectangles.
    pub planes: f64,
    /// Spheres.
    pub spheres: f64,
    /// Discs.
    pub discs: f64,
    /// Rectangles.
    pub rects: f64,
    /// Textured (checkered) primitives.
    pub checkers: f64,
    /// Point lights.
    pub point_lights: f64,
    /// Directional lights.
    pub dir_lights: f64,
    /// 1 if distortion is evaluated by the polynomial.
    pub poly: f64,
    /// 1 if by a table.
    pub table: f64,
    /// 1 if any material has a specular lobe (the lobe's code in the
    /// loop).
    pub specular: f64,
    /// Fraction of the sensor whose rays first meet a primitive with a
    /// lobe (sampled, as `coverage`): the pixels that evaluate it.
    pub lobe_area: f64,
    /// Colour channels beyond the first (2 for RGB565).
    pub extra_channels: f64,
    /// 1 for parallel rays.
    pub parallel: f64,
    /// Fraction of the sensor that sees a primitive (a sampled estimate):
    /// the lights', textures' and lobe's terms are per shaded pixel, so
    /// they are scaled by it.
    pub coverage: f64,
    /// Sum over the bounded primitives of the fraction of the sensor each
    /// covers (sampled): where a primitive is tested for every pixel, not
    /// culled by its screen bound.
    pub bounded_area: f64,
    /// Channels that draw sensor noise (the scene's channels if it has
    /// noise, else 0): the noise stage runs on every pixel in the field.
    pub noise_channels: f64,
    /// Fraction of the sensor shaded in closed form (the fast arithmetic's
    /// one-sample loop: a plane's pixels that see nothing else; a sampled
    /// estimate), alone and times [`Features::closed_lights`].
    pub closed: f64,
    /// Point lights on the side of that plane the camera sees: the closed
    /// form's terms (`mix32::Closed`'s lights; with none, its sum is one
    /// constant, `Mix32::closed_flat`). 0 without such a plane.
    pub closed_lights: f64,
    /// Sum over the flat primitives facing the camera of the fraction of
    /// the sensor whose rays hit each (sampled): their rays take one plane
    /// `t` a chunk (`mix32::flat_pass`), not a reciprocal each — but the
    /// plane shaded in closed form where [`Features::closed`] counts.
    pub facing_area: f64,
    /// [`Features::closed`] times the share of its light terms the
    /// interpolation (`Options::closed_mean`) leaves out, in units of the
    /// pairs' share ([`closed_mean_skipped`]): 0 without it (or without
    /// exactly one light on the plane's side, [`Features::closed_lights`],
    /// the only case it runs), 1 with `Pairs`, 22/15 with `Quads`, 25/15
    /// with `Octs`.
    pub closed_mean: f64,
    /// Fraction of the sensor whose rays first meet a flat primitive
    /// without a lobe, in a scene lit by directional lights alone (sampled):
    /// its shading is kept from hit to hit (`Mix32::shade_flat`) — but
    /// the plane shaded in closed form where [`Features::closed`] counts.
    pub flat_area: f64,
    /// 1 where a fast loop makes every ray of a line: the sampled and
    /// aperture loops always, the one-sample loop where the principal
    /// point is off the sensor's centre across
    /// ([`crate::geom::intrinsics::Intrinsics::is_centred_x`]), so no column's
    /// rays are another's mirrored (the right half's rays, distorted, are
    /// otherwise the left half's). Alone and times [`Features::poly`]: a
    /// sample's cost is one sample's ([`SampleCost`]) as the loop that
    /// mirrors nothing pays it.
    pub unmirrored: f64,
    /// 1 for an orthographic camera: parallel rays without the `cos⁴α`
    /// stage (weak perspective keeps it).
    pub orthographic: f64,
}

impl Features {
    /// The features of `scene` rendered with `opts` (what the cost model's
    /// calibration measures: `host-sim costfit`).
    pub fn of_options(scene: &Scene, opts: &Options) -> Features {
        let distortion =
            (!scene.distortion.is_none() || opts.keep_all_stages).then_some(opts.distortion_eval);
        let fast = opts.arithmetic == Arithmetic::Fast;
        let closed = fast && opts.samples <= 1 && opts.aperture == 0;
        let g = Geometry::of(scene, opts.model);
        let mean = if closed { opts.closed_mean } else { ClosedMean::Off };
        Features::of(scene, &g, distortion, fast, closed, mean)
    }

    /// The features of `scene` rendered with `distortion` and `g`'s rays,
    /// in the `fast` arithmetic or not, the plane in `closed` form (with
    /// its `mean`: the fast one-sample loop).
    // Out of line: planning runs once a frame; keeping it small saves flash.
    #[inline(never)]
    fn of(
        scene: &Scene,
        g: &Geometry,
        distortion: Option<DistortionEval>,
        fast: bool,
        closed: bool,
        mean: ClosedMean,
    ) -> Features {
        let mut f = Features::default();
        for (p, q) in scene.primitives.iter().zip(&g.prims) {
            // A primitive no ray can meet is tested on no chunk.
            if q.unseen {
                continue;
            }
            match p.shape {
                Shape::Plane { .. } => f.planes += 1.0,
                Shape::Sphere { .. } => f.spheres += 1.0,
                Shape::Disc { .. } => f.discs += 1.0,
                Shape::Rectangle { .. } => f.rects += 1.0,
            }
            if p.checker.is_some() {
                f.checkers += 1.0;
            }
        }
        for l in &scene.lights {
            match l {
                Light::Point { .. } => f.point_lights += 1.0,
                Light::Directional { .. } => f.dir_lights += 1.0,
            }
        }
        match distortion {
            Some(DistortionEval::Polynomial) => f.poly = 1.0,
            Some(_) => f.table = 1.0,
            None => {}
        }
        f.specular = if scene.has_specular() { 1.0 } else { 0.0 };
        f.lobe_area = g.lobe_area;
        f.extra_channels = (scene.format.channels() - 1) as f64;
        f.parallel = if g.origin_scale.is_some() { 1.0 } else { 0.0 };
        f.coverage = g.coverage;
        f.bounded_area = g.bounded_area;
        f.noise_channels = if scene.noise.is_some() {
            scene.format.channels() as f64
        } else {
            0.0
        };
        f.closed = if closed { g.closed_area } else { 0.0 };
        f.closed_lights = g.closed_lights() as f64;
        // The mean is taken under one light on the plane's side alone
        // (`Mix32::closed_run`).
        f.closed_mean = if f.closed_lights == 1.0 {
            f.closed * closed_mean_skipped(mean)
        } else {
            0.0
        };
        // The plane shaded in closed form takes no `t` where it is.
        f.facing_area = g.facing_area + if closed { 0.0 } else { g.closed_facing_area };
        f.flat_area = g.flat_area + if closed { 0.0 } else { g.closed_flat_area };
        // (The loop that mirrors is the one that shades the plane in
        // closed form, `closed`; the fast sampled and aperture loops make
        // every ray.)
        f.unmirrored = if fast && !(closed && scene.camera.intrinsics.is_centred_x()) {
            1.0
        } else {
            0.0
        };
        f.orthographic = if matches!(scene.camera.model, Model::Orthographic { .. }) {
            1.0
        } else {
            0.0
        };
        f
    }

    /// As a vector, in [`CostModel::coef`]'s order (the constant first).
    pub fn to_array(&self) -> [f64; COST_TERMS] {
        let c = self.coverage;
        [
            1.0,
            self.planes,
            self.spheres,
            self.discs,
            self.rects,
            self.checkers * c,
            self.point_lights * c,
            self.dir_lights * c,
            self.poly,
            self.table,
            self.specular,
            self.extra_channels,
            self.parallel,
            c,
            self.bounded_area,
            self.bounded_area * self.parallel,
            self.noise_channels,
            self.closed,
            self.closed * self.closed_lights,
            self.lobe_area,
            self.facing_area,
            self.closed_mean,
            self.flat_area,
            self.unmirrored,
            self.unmirrored * self.poly,
            self.orthographic,
        ]
    }
}

/// Terms of the cost model.
pub const COST_TERMS: usize = 26;

/// M3 instructions a pixel as a linear function of [`Features`] (one
/// sample a pixel), times what the pixel's samples cost ([`SampleCost`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Coefficients, in [`Features::to_array`]'s order.
    pub coef: [f64; COST_TERMS],
    /// A pixel's samples, as a multiple of one sample.
    pub samples: SampleCost,
}

/// What a pixel takes beyond one sample at its centre: the terms of
/// [`SampleCost`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Samples {
    /// Samples of the pixel's area: 1 for one sample; `n²` for an `n×n`
    /// grid on every pixel; with the adaptive rule 1 (the centre) plus `n²`
    /// times the estimated fraction of pixels an edge crosses.
    pub grid: f64,
    /// 1 where the adaptive rule looks at the pixel's corners, else 0.
    pub corners: f64,
    /// Aperture points each sample is lit through (0: the chief ray).
    pub aperture: f64,
    /// Through the aperture, the share of the pixels whose rays are traced
    /// through every primitive at every point (1 in the wide arithmetic;
    /// in the fast one, from its frame: `mix32::Mix32::aperture_classes`)...
    #[serde(default = "all")]
    pub traced: f64,
    /// ... and of those tested against one rectangle alone (the fast
    /// loop's). The rest take their chief ray's sum.
    #[serde(default)]
    pub only: f64,
    /// The primitives some ray can meet (those [`Features`] counts) where
    /// a pixel takes more than one sample: what a sample may test.
    #[serde(default)]
    pub prims: f64,
}

/// [`Samples::traced`] where a calibration file has none (written before
/// it): every pixel traced.
fn all() -> f64 {
    1.0
}

impl Samples {
    /// One sample at the pixel's centre, through the pinhole.
    pub const ONE: Samples = Samples {
        grid: 1.0,
        corners: 0.0,
        aperture: 0.0,
        traced: 1.0,
        only: 0.0,
        prims: 0.0,
    };

    /// These terms for `arithmetic`, with the fast loop's aperture
    /// `shares` (the wide loop traces every ray).
    fn with(self, arithmetic: Arithmetic, shares: Shares) -> Samples {
        let s = match arithmetic {
            Arithmetic::Fast if self.aperture > 0.0 => shares,
            _ => Shares::TRACED,
        };
        Samples {
            traced: s.traced,
            only: s.only,
            ..self
        }
    }

    /// The terms of `scene` rendered with `opts` (what `host-sim costfit`
    /// records with each measurement).
    pub fn of_options(scene: &Scene, opts: &Options) -> Samples {
        let s = Samples::of(
            scene,
            &Geometry::of(scene, opts.model),
            opts.samples,
            opts.adaptive,
            opts.aperture,
        );
        let shares = match opts.arithmetic {
            Arithmetic::Fast => fast_shares(scene, opts),
            Arithmetic::Wide => Shares::TRACED,
        };
        s.with(opts.arithmetic, shares)
    }

    fn of(scene: &Scene, g: &Geometry, n: u8, adaptive: bool, aperture: u16) -> Samples {
        let n2 = f64::from(n) * f64::from(n);
        let (grid, corners) = match (n, adaptive) {
            (0 | 1, _) => (1.0, 0.0),
            (_, false) => (n2, 0.0),
            (_, true) => (1.0 + n2 * edge_fraction(scene, g, false), 1.0),
        };
        // (Not for one sample through the pinhole, whose cost is the
        // features' alone.)
        let prims = if grid == 1.0 && corners == 0.0 && aperture == 0 {
            0.0
        } else {
            g.prims.iter().filter(|p| !p.unseen).count() as f64
        };
        Samples {
            grid,
            corners,
            aperture: f64::from(aperture),
            prims,
            ..Samples::ONE
        }
    }

    /// As arrays, in [`SampleCost`]'s order: the grid's terms (1 on every
    /// pixel, 1 with the adaptive rule, samples — times one sample's cost
    /// —, samples, and samples times primitives) and the aperture's (1 and
    /// points times the share traced, which multiply the grid's cost;
    /// points times the share tested against one rectangle, and points).
    pub fn terms(&self) -> ([f64; 5], [f64; 4]) {
        let m = self.aperture;
        (
            [
                1.0 - self.corners,
                self.corners,
                self.grid,
                self.grid,
                self.grid * self.prims,
            ],
            [1.0, m * self.traced, m * self.only, m],
        )
    }
}

/// What a pixel's [`Samples`] cost, given one sample's cost `one`
/// ([`CostModel::predict`] of the scene's features): a grid on every pixel
/// `grid[0] + samples · (grid[2] · one + grid[3] + grid[4] · prims)`, with
/// the adaptive rule `grid[1] + samples · (…)` (the constants, in
/// instructions: the sampled loop's own work a pixel and the corner looks,
/// much the same whatever the scene; per sample, the scene's cost in a
/// loop that neither mirrors rays nor shades a plane in closed form, a
/// sample's own work, and its tests of the primitives, which a background
/// sample makes too), times the aperture's
/// `aperture[0] + aperture[1] · points · traced`, plus `points ·
/// (aperture[2] · only + aperture[3])` instructions a sample (`traced`,
/// `only`: the shares of the pixels whose rays are traced through every
/// primitive, and tested against one rectangle alone, [`Samples`]; a
/// traced ray costs as the scene's content, a ray against one rectangle
/// and a point's own work the same whatever the scene); `one` for one
/// sample through the pinhole. Fitted per arithmetic by `host-sim
/// costfit` to QEMU counts of calibration scenes rendered with sample
/// grids and aperture points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleCost {
    /// The grid's constant on every pixel and with the adaptive rule (M3
    /// instructions a pixel), and its cost per sample: times one sample's,
    /// in instructions, and in instructions a primitive.
    pub grid: [f64; 5],
    /// The aperture's constant and per point of a pixel traced (times the
    /// grid's cost); per point of a pixel tested against one rectangle,
    /// and per point of every pixel (M3 instructions a sample).
    pub aperture: [f64; 4],
}

impl SampleCost {
    /// No overhead, each grid sample at one sample's cost, the aperture
    /// free: the stand-in of a model of the features alone (`host-sim
    /// costfit`'s first step, which predicts one sample only).
    pub const ONE: SampleCost = SampleCost {
        grid: [0.0, 0.0, 1.0, 0.0, 0.0],
        aperture: [1.0, 0.0, 0.0, 0.0],
    };

    /// The cost of `s`, M3 instructions a pixel, for one sample's `one`.
    pub fn cost(&self, one: f64, s: &Samples) -> f64 {
        let (fixed, per_one) = self.affine(s);
        fixed + per_one * one
    }

    /// [`SampleCost::cost`] over one sample's cost, from the total `cost`
    /// (`cost` is affine in one sample's, so that is recovered from it);
    /// 1 where it is not positive.
    pub fn factor(&self, cost: f64, s: &Samples) -> f64 {
        let (fixed, per_one) = self.affine(s);
        let one = (cost - fixed) / per_one;
        if one > 0.0 && one.is_finite() {
            cost / one
        } else {
            1.0
        }
    }

    /// [`SampleCost::cost`] as `fixed + per_one · one`: the grid's constant
    /// and its samples (one sample alone: 0 and 1), both times the
    /// aperture's factor (1 through the pinhole).
    fn affine(&self, s: &Samples) -> (f64, f64) {
        let (g, a) = s.terms();
        let (fixed, per_one) = if s.grid == 1.0 && s.corners == 0.0 {
            (0.0, 1.0)
        } else {
            let [c0, c1, c2, c3, c4] = self.grid;
            (c0 * g[0] + c1 * g[1] + c3 * g[3] + c4 * g[4], c2 * g[2])
        };
        if s.aperture == 0.0 {
            return (fixed, per_one);
        }
        let [a0, a1, a2, a3] = self.aperture;
        let k = a0 * a[0] + a1 * a[1];
        (fixed * k + (a2 * a[2] + a3 * a[3]) * s.grid, per_one * k)
    }
}

/// `Σ aᵢ bᵢ` over the shorter of the two (missing terms count as 0).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl CostModel {
    /// The fitted model of an arithmetic (`host-sim costfit` fits these to
    /// QEMU counts and reports the fit).
    pub const fn of(a: Arithmetic) -> CostModel {
        match a {
            Arithmetic::Fast => FAST_COST,
            Arithmetic::Wide => WIDE_COST,
        }
    }

    /// Predicted M3 instructions a pixel.
    pub fn predict(&self, f: &Features) -> f64 {
        self.predict_terms(&f.to_array())
    }

    /// Predicted M3 instructions a pixel from the terms themselves, in
    /// [`Features::to_array`]'s order (missing terms count as 0).
    pub fn predict_terms(&self, terms: &[f64]) -> f64 {
        dot(&self.coef, terms)
    }
}

/// The fast arithmetic's cost model (M3 instructions a pixel), fitted by
/// `host-sim costfit` to QEMU counts of the calibration scenes
/// (`docs/cost-calibration.json`; `tests/planner.rs` refits it).
pub const FAST_COST: CostModel = CostModel {
    coef: [
        89.1, 24.2, 5.2, 9.9, -0.9, 13.4, 6.3, 2.5, 20.4, 0.0, 20.5, 37.8, 20.4, 274.2, 32.8, 21.1, 144.7,
        -313.6, 99.5, 225.7, -70.6, -45.3, -154.8, 17.8, 13.3, -31.1,
    ],
    samples: SampleCost {
        grid: [588.450, 197.181, 0.772, 53.608, 6.175],
        aperture: [1.985, 0.583, 82.156, 66.374],
    },
};

/// The wide (I32F32) arithmetic's cost model (M3 instructions a pixel),
/// fitted with [`FAST_COST`].
pub const WIDE_COST: CostModel = CostModel {
    coef: [
        825.4, 340.5, 48.6, -27.9, -74.8, 121.7, 1403.9, 158.1, 324.8, 380.0, 1379.3, 230.1, -7.6, 108.2,
        956.4, -59.1, 801.6, 0.0, 0.0, 455.5, -121.9, 0.0, -0.4, 0.0, 0.0, -278.3,
    ],
    samples: SampleCost {
        grid: [280.017, 1573.431, 0.996, 0.000, 66.700],
        aperture: [0.480, 0.877, 0.000, 0.000],
    },
};

/// A world point in the camera frame, f64 metres.
fn cam_point(scene: &Scene, p: crate::WorldPoint) -> [f64; 3] {
    scene.camera.extrinsics.world_to_camera(p).value.to_f64()
}

/// A world direction in the camera frame (`R d`), f64.
fn cam_direction(scene: &Scene, d: [crate::Norm; 3]) -> [f64; 3] {
    scene.camera.extrinsics.rotation().map(|row| {
        (0..3)
            .map(|k| row.get(k).zip(d.get(k)).map_or(0.0, |(a, b)| a.f64() * b.f64()))
            .sum::<f64>()
    })
}

/// The weak-perspective bound (pixels) over the camera-frame box around the
/// scene's primitives, and the box's mean depth; `None` if a primitive is
/// unbounded or the box reaches the lens plane.
// Out of line: planning runs once a frame; keeping it small saves flash.
#[inline(never)]
fn weak_perspective_over_scene(scene: &Scene) -> Option<(f64, Len)> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut grow = |p: [f64; 3]| {
        for k in 0..3 {
            if let (Some(l), Some(h), Some(v)) = (lo.get_mut(k), hi.get_mut(k), p.get(k)) {
                *l = l.min(*v);
                *h = h.max(*v);
            }
        }
    };
    let cam_pt = |p: crate::WorldPoint| cam_point(scene, p);
    let cam_dir = |d: [crate::Norm; 3]| cam_direction(scene, d);
    for prim in &scene.primitives {
        match prim.shape {
            Shape::Plane { .. } => return None,
            Shape::Sphere { centre, radius } => {
                let (c, r) = (cam_pt(centre), radius.f64());
                grow([c[0] - r, c[1] - r, c[2] - r]);
                grow([c[0] + r, c[1] + r, c[2] + r]);
            }
            Shape::Disc {
                centre,
                normal,
                radius,
            } => {
                // Extent of a disc along axis k: r·sqrt(1 − n_k²).
                let (c, n, r) = (cam_pt(centre), cam_dir(normal), radius.f64());
                let e = n.map(|nk| r * libm::sqrt((1.0 - nk * nk).max(0.0)));
                grow([c[0] - e[0], c[1] - e[1], c[2] - e[2]]);
                grow([c[0] + e[0], c[1] + e[1], c[2] + e[2]]);
            }
            Shape::Rectangle {
                centre,
                u_axis,
                v_axis,
                half,
            } => {
                let (c, u, v) = (cam_pt(centre), cam_dir(u_axis), cam_dir(v_axis));
                let (a, b) = (half[0].f64(), half[1].f64());
                for (su, sv) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
                    grow([
                        c[0] + su * a * u[0] + sv * b * v[0],
                        c[1] + su * a * u[1] + sv * b * v[1],
                        c[2] + su * a * u[2] + sv * b * v[2],
                    ]);
                }
            }
        }
    }
    if scene.primitives.is_empty() || lo[2] <= 0.0 {
        return None;
    }
    let min = CameraPoint::from_f64(lo).ok()?;
    let max = CameraPoint::from_f64(hi).ok()?;
    let z_bar: Len = crate::num::from_f64((lo[2] + hi[2]) / 2.0)?;
    let bound = weak_perspective_bound(&scene.camera.intrinsics, DepthBox { min, max }, z_bar).ok()?;
    if bound.saturated {
        return None;
    }
    Some((bound.value.f64(), z_bar))
}

#[cfg(test)]
mod tests {
    use super::MeanCells;
    use proptest::prelude::*;

    /// Cells for a camera `dist` above the plane, the light `h` above it
    /// with its foot `foot` from the camera's.
    fn cells(dist: f64, foot: f64, h: f64, d: f64, row: (f64, f64, f64, f64)) -> MeanCells {
        let l = libm::sqrt(foot * foot + (h - dist) * (h - dist));
        MeanCells::new((dist, foot, h, l), d, row)
    }

    #[test]
    fn the_standard_scene_s_cells_stop_early() {
        // The standard scene's: the camera 1.2 m up, the light 3 m up with
        // its foot 2.24 m off; `closed_mean_err`'s row bounds for f = 200
        // px, k1 0.15, k2 0.05 to the corner (u = 0.2465) and the floor's
        // normal 14.9° off the camera's y axis (|n_x| 0, |n_y| 0.966); `D`
        // scales every cell alike.
        let c = cells(1.2, 2.236, 3.0, 1.0, (5.63e-3, 1.53e-5, 2.08e-4, 5.37e-6));
        let (full, early) = (c.worst(false), c.worst(true));
        assert_eq!(full.0.to_bits(), early.0.to_bits());
        assert!(early.1 < full.1, "{early:?} {full:?}");
    }

    proptest! {
        /// Stopping early gives the largest cell's bound to the bit.
        #[test]
        fn the_tail_bound_stops_only_where_no_cell_left_is_larger(
            dist in -3.0f64..3.0,
            foot in -3.0f64..3.0,
            h in -3.0f64..3.0,
            d in -6.0f64..6.0,
            row in (-6.0f64..0.0, -9.0f64..-3.0, -6.0f64..0.0, -9.0f64..-3.0),
            no_tilt in any::<bool>(),
        ) {
            let e = |x: f64| libm::pow(10.0, x);
            let n1 = if no_tilt { 0.0 } else { e(row.2) };
            let c = cells(e(dist), e(foot), e(h), e(d), (e(row.0), e(row.1), n1, e(row.3)));
            let (full, early) = (c.worst(false), c.worst(true));
            prop_assert_eq!(full.0.to_bits(), early.0.to_bits(), "{:?}: {:?} {:?}", c, full, early);
            prop_assert!(early.1 <= full.1);
        }
    }
}
