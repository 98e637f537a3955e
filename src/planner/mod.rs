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
//! - **Relative illumination.** With distortion, irradiance is times its
//!   area factor `J` (camera-model.md §5); left out where `|J − 1| DN_max`
//!   over the field, added to the LSB error, keeps the budget and stays
//!   within a tenth of the edge budget (a value moved by `δ` LSB rounds the
//!   other way in up to `δ` of the pixels; added to `edge_differing`)
//!   ([`Candidate::relative_illumination`]).
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

use crate::render::{Arithmetic, ClosedMean, DistortionEval, Options, RenderModel};
use crate::scene::Scene;
use crate::Len;

mod closed_mean;
mod cost;
pub(crate) mod error_model;
mod geometry;
mod search;
mod survey;
#[cfg(test)]
mod tests;

use cost::{fast_shares, Shares};
use search::{plan_with, prepares};

pub use crate::render::Unfit;
pub use cost::APERTURE_STRIDE;
pub use cost::{CostModel, Features, SampleCost, Samples, COST_TERMS, FAST_COST, SHADOW_COST, WIDE_COST};
pub use error_model::{Boundary, ErrorModel};

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
    /// Whether the distortion's area factor is rendered
    /// ([`crate::render::Options::relative_illumination`]): left out where
    /// `|J − 1| DN_max` keeps the LSB budget and a tenth of the edge budget
    /// (it is then in `lsb` and `edge_differing`).
    pub relative_illumination: bool,
    /// What the mean alone moves a value by at most, LSB (0 without it):
    /// its bound on the sum and, with noise, on `σ z` (`noise_moved`).
    pub mean_lsb: f64,
    /// Predicted fraction of all pixels that are edge pixels whose value
    /// differs from the reference's: a look (sample, corner, centre) moved
    /// by `e` off the reference's sees the other side of an edge when the
    /// edge passes between the two, a strip `|e·n̂| ≤ geom_err_px` wide on
    /// one side of the look. The expected count over where edges fall, not a
    /// bound: edge length per pixel area (`edge_fraction`'s estimate) ×
    /// `geom_err_px` × looks per pixel area (`n²`, with the adaptive rule
    /// `+ 5`: a corner decides for four pixels, the centre for one); a
    /// checkered plane's cells integrated over the field instead, with the
    /// arithmetic's error in the texture coordinate
    /// (`Geometry::cells_differing`).
    pub edge_differing: f64,
    /// Shadow tests a sample takes on average (each surface's share of the
    /// sensor times the occluders it is tested against under each light;
    /// 0 where the planner proves none is needed), and the M3
    /// instructions a pixel they add to the cost ([`SHADOW_COST`]).
    pub shadow_tests: f64,
    /// Of those, the tests that take the exact test (all of them in the
    /// wide arithmetic; in the fast one, those its pre-test leaves).
    pub shadow_exact: f64,
    /// The shadow tests' share of `m3_instructions_per_pixel`.
    pub shadow_m3: f64,
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
    /// The least blur of content outside the depth of field, pixels (at
    /// least the tolerable blur `b̃`): what the sample grid must resolve
    /// ([`crate::render::sensor::sampling::grid_for_blur`]).
    pub least_blur_px: f64,
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
        least_blur_px: 0.0,
        outside_dof: false,
        points: 0,
        err_px: 0.0,
    };
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
