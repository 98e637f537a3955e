//! The candidate search: every ray model, arithmetic and distortion
//! evaluation the scene allows, predicted and compared against the budget.

use super::closed_mean::{closed_mean_err, closed_mean_factor};
use super::cost::{shadow_cost, CostModel, Features, Samples, Shares};
use super::error_model::{
    defocus, edge_fraction, noise_draw_lsb, noise_moved, table_entries, table_geom_err, ErrorModel,
};
use super::geometry::{weak_perspective_over_scene, Geometry};
use super::{Budget, Candidate, Defocus, Plan, Unfit, MAX_CANDIDATES, WEAK_MARGIN};
use crate::num::FixedF64;
use crate::render::{Arithmetic, ClosedMean, DistortionEval, Options, RenderModel};
use crate::scene::Scene;
use crate::{Len, Model};

pub(super) fn ray_model_and_bound(scene: &Scene, budget: &Budget) -> (RenderModel, Option<(f64, Len)>) {
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

/// Whether a frame prepares `scene` with `opts`. Out of line: the frame is
/// not on the stack while [`plan`] runs.
#[inline(never)]
pub(super) fn prepares<const T: usize>(
    scene: &Scene,
    opts: &crate::render::Options,
) -> Result<(), crate::render::RenderError> {
    crate::render::Frame::<crate::scene::Q, T>::empty().prepare(scene, opts)
}

/// Whether the fast arithmetic renders `scene` with ray model `model`,
/// `aperture` points and the sample grid: the formats' own rule
/// (`render::fast::fits`), not a prediction of it.
fn fast_fits(
    scene: &Scene,
    model: RenderModel,
    aperture: u16,
    (samples, adaptive): (u8, bool),
) -> Result<(), Unfit> {
    #[cfg(feature = "mix32")]
    {
        let mut opts = crate::render::Options::new(model, 2).with_arithmetic(Arithmetic::Fast);
        opts.distortion_eval = DistortionEval::Polynomial;
        (opts.samples, opts.adaptive, opts.aperture) = (samples, adaptive, aperture);
        crate::render::fast::fits(scene, &opts)
    }
    #[cfg(not(feature = "mix32"))]
    {
        let _ = (scene, model, aperture, samples, adaptive);
        Err(Unfit::NotBuilt)
    }
}

/// [`plan`] with the fast arithmetic's aperture `shares`.
#[inline(never)]
pub(super) fn plan_with(scene: &Scene, budget: &Budget, shares: Shares) -> Plan {
    let cam = &scene.camera;
    let half = budget.max_geom_err_px / 2.0;
    let (first, wp) = ray_model_and_bound(scene, budget);
    let both =
        matches!(first, RenderModel::WeakPerspective { .. }) && matches!(cam.model, Model::Perspective);
    let edge_budget = scene.sampling.map_or(0.5, |s| s.edge_error_px.f64());
    let (asked, adaptive) = crate::render::sensor::sampling::of_scene(scene);
    let mut cands: heapless::Vec<Candidate, MAX_CANDIDATES> = heapless::Vec::new();
    // Each model's sample terms and defocus (a geometry at a time: it is
    // large, and the M0's planning stack small).
    let mut per_model: heapless::Vec<(RenderModel, Samples, Defocus, u8), 2> = heapless::Vec::new();
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
        // Through the aperture, a grid fine enough to resolve the least
        // blur within the spread budget (an edge's measured blur within
        // 2 % of its blur circle), where the scene asks for area
        // integration at all.
        let samples = if df.points > 0 && asked > 1 {
            let blur = crate::render::sensor::sampling::grid_for_blur(
                df.least_blur_px,
                crate::render::sensor::defocus::SPREAD_BUDGET,
            );
            asked.max(blur)
        } else {
            asked
        };
        let terms = Samples::of(scene, &g, (samples, adaptive), (df.points, df.blur_px));
        let _ = per_model.push((model, terms, df, samples));
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
        relative_illumination: true,
        mean_lsb: 0.0,
        edge_differing: 1.0,
        shadow_tests: 0.0,
        shadow_exact: 0.0,
        shadow_m3: 0.0,
    });
    let model = c.model;
    let (terms, df, samples) = per_model
        .iter()
        .find(|m| m.0 == model)
        .map_or((Samples::ONE, Defocus::NONE, asked), |m| {
            (m.1.with(c.arithmetic, shares), m.2, m.3)
        });
    let wp_used =
        matches!(model, RenderModel::WeakPerspective { .. }) && matches!(cam.model, Model::Perspective);
    let meets = c.meets(budget) && (!wp_used || wp.is_some_and(|(e, _)| e <= half));
    let mut options = Options::new(model, c.lut_entries.max(2));
    options.closed_mean = c.closed_mean;
    options.relative_illumination = c.relative_illumination;
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
pub(super) fn model_candidates(
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
        if scene.distortion.is_none() && scene.calibrated().is_none() {
            let _ = evals.push((None, 0));
        } else {
            let _ = evals.push((Some(DistortionEval::Polynomial), 0));
            // (Only the wide arithmetic reads a table; a calibrated lens
            // is solved per sample.)
            let entries = (arithmetic == Arithmetic::Wide && scene.calibrated().is_none())
                .then(|| table_entries(scene, g, half));
            if let Some(entries) = entries.filter(|e| *e <= budget.max_table_entries) {
                let _ = evals.push((Some(DistortionEval::Linear), entries));
            }
        }
        // What the distortion evaluation does not change, once.
        let fits = match arithmetic {
            Arithmetic::Fast => fast_fits(scene, model, df.points, (samples, adaptive)),
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
        // The distortion's area factor (camera-model.md §5) left out where
        // what that moves a value, at most `|J − 1| DN_max`, keeps the LSB
        // budget and a tenth of the edge budget: a value moved by `δ` LSB
        // rounds the other way in up to `δ` of the pixels (of which the
        // edge pixels count).
        let omit = g.area_dev * g.dn_max;
        let relative_illumination =
            omit > 0.0 && (lsb + omit + 0.5 > budget.max_lsb || omit > 0.1 * budget.max_edge_differing);
        let (lsb, flips) = if relative_illumination {
            (lsb, 0.0)
        } else {
            (lsb + omit, omit)
        };
        for (distortion, entries) in evals {
            let geom = match distortion {
                Some(DistortionEval::Linear) | Some(DistortionEval::Nearest) => {
                    table_geom_err(scene, g, entries)
                }
                _ => g.direct_geom_err(arithmetic, scene),
            };
            let cost_model = CostModel::of(arithmetic);
            let fast = arithmetic == Arithmetic::Fast;
            let shadows = shadow_cost(g, fast);
            let one =
                cost_model.predict(&Features::of(scene, g, distortion, fast, closed, closed_mean)) + shadows;
            let cost = cost_model.samples.cost(one, &terms.with(arithmetic, shares));
            let per_one = if cfg!(feature = "shadows") && shadows > 0.0 {
                cost_model.samples.factor(cost, &terms.with(arithmetic, shares))
            } else {
                0.0
            };
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
                relative_illumination,
                mean_lsb,
                edge_differing: (edge_looks * geom + cells(arithmetic, geom) + flips).min(1.0),
                shadow_tests: if cfg!(feature = "shadows") && g.shadows {
                    g.shadow_tests
                } else {
                    0.0
                },
                shadow_exact: if cfg!(feature = "shadows") && g.shadows {
                    if fast {
                        g.shadow_exact
                    } else {
                        g.shadow_tests
                    }
                } else {
                    0.0
                },
                shadow_m3: if cfg!(feature = "shadows") {
                    shadows * per_one
                } else {
                    0.0
                },
            });
        }
    }
}
