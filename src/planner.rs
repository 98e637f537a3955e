//! The planner: given a scene and an error budget, picks the cheapest way to
//! render it that meets the budget, and says what it predicts.
//!
//! - **Ray model.** A telecentric (orthographic) camera is rendered
//!   orthographically. A perspective camera is rendered with parallel
//!   (weak-perspective) rays when every primitive is bounded and the §2 error
//!   bound over the camera-frame box around them, at `Z̄` = the box's mean
//!   depth, is within half the geometric budget; otherwise in perspective.
//! - **Distortion table.** None when `k1 = k2 = 0`. Otherwise the smallest
//!   power-of-two size (2 to 1024 entries) whose predicted error (linear
//!   interpolation `|k2| h²/4`, plus the entries' rounding), in pixels at the
//!   widest corner, is within half the geometric budget. The entries' format
//!   is the finest i32 format that holds `g` over the range
//!   ([`crate::distortion::Distortion::entry_frac_bits`]).
//! - **Formats.** Per-pixel values are I32F32; the planner predicts their
//!   arithmetic error in LSB and checks it against the LSB budget.
//!
//! Planning runs once per scene, like construction, and uses f64.

use crate::projection::{weak_perspective_bound, DepthBox};
use crate::render::{Options, RenderModel};
use crate::scene::{Scene, Shape};
use crate::{CameraPoint, Len, Model};

/// What the renderer may get wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Largest geometric error, pixels.
    pub max_geom_err_px: f64,
    /// Largest error in pixel value, LSB, over smooth pixels.
    pub max_lsb: f64,
}

impl Default for Budget {
    /// 1/256 px and 1 LSB.
    fn default() -> Self {
        Budget {
            max_geom_err_px: 1.0 / 256.0,
            max_lsb: 1.0,
        }
    }
}

/// The planner's choice and its predictions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    /// What the renderer is told.
    pub options: Options,
    /// Predicted error of the pixel → undistorted mapping, pixels.
    pub predicted_geom_err_px: f64,
    /// The §2 bound of the weak-perspective approximation over the scene's
    /// bounding box, pixels (`None` if the scene is unbounded or reaches
    /// behind the camera).
    pub weak_perspective_err_px: Option<f64>,
    /// Predicted arithmetic error of the radiometric chain, LSB (before the
    /// final rounding, which both core and reference apply).
    pub predicted_arith_lsb: f64,
    /// True if every prediction is within the budget.
    pub meets_budget: bool,
}

/// Relative error of the per-pixel radiometric chain: some 40 roundings at
/// 2⁻³² of quantities below 2⁸, bounded generously by 2⁻²⁰.
const ARITH_REL: f64 = 1.0 / (1u64 << 20) as f64;

/// Plans `scene` within `budget`.
pub fn plan(scene: &Scene, budget: &Budget) -> Plan {
    let cam = &scene.camera;
    let intr = &cam.intrinsics;
    let half = budget.max_geom_err_px / 2.0;
    let wp = weak_perspective_over_scene(scene);
    let model = match cam.model {
        Model::Orthographic { scale } => RenderModel::Orthographic { scale },
        Model::WeakPerspective { mean_depth } => RenderModel::WeakPerspective { mean_depth },
        Model::Perspective => match wp {
            Some((err, z_bar)) if err <= half => RenderModel::WeakPerspective { mean_depth: z_bar },
            _ => RenderModel::Perspective,
        },
    };
    let (fx, fy) = intr.focal_px();
    let f_px = fx.to_num::<f64>().max(fy.to_num::<f64>());
    // Distortion table size.
    let (geom, entries) = if scene.distortion.is_none() {
        (f_px * libm::ldexp(1.0, -31), 0)
    } else {
        let (w, h) = intr.size();
        let (ox, oy) = intr.principal_point();
        let mut u_corner: f64 = 0.0;
        for (i, j) in [
            (0.0, 0.0),
            (w as f64 - 1.0, 0.0),
            (0.0, h as f64 - 1.0),
            (w as f64 - 1.0, h as f64 - 1.0),
        ] {
            let xd = (ox.to_num::<f64>() - i) / fx.to_num::<f64>();
            let yd = (oy.to_num::<f64>() - j) / fy.to_num::<f64>();
            u_corner = u_corner.max(xd * xd + yd * yd);
        }
        let u_max = match scene.distortion.fold_u() {
            Some(f) => u_corner.min(f.to_num::<f64>()),
            None => u_corner,
        };
        let r_max = libm::sqrt(u_max);
        let frac = scene
            .distortion
            .entry_frac_bits(crate::scene::Q::saturating_from_num(u_max));
        let rounding = f_px * r_max * libm::ldexp(1.0, -(frac as i32 + 1)) + f_px * libm::ldexp(1.0, -31);
        let mut entries = 2;
        loop {
            let geom = f_px * r_max * scene.distortion.lut_interp_error(u_max, entries) + rounding;
            if geom <= half || entries >= crate::distortion::MAX_LUT {
                break (geom, entries);
            }
            entries *= 2;
        }
    };
    let dn_max = (0..scene.format.channels())
        .map(|c| scene.format.dn_max(c))
        .max()
        .unwrap_or(255) as f64;
    let arith = dn_max * ARITH_REL;
    let wp_used =
        matches!(model, RenderModel::WeakPerspective { .. }) && matches!(cam.model, Model::Perspective);
    let meets =
        geom <= half && arith + 0.5 <= budget.max_lsb && (!wp_used || wp.is_some_and(|(e, _)| e <= half));
    Plan {
        options: Options::new(model, entries),
        predicted_geom_err_px: geom,
        weak_perspective_err_px: wp.map(|(e, _)| e),
        predicted_arith_lsb: arith,
        meets_budget: meets,
    }
}

/// The weak-perspective bound (pixels) over the camera-frame box around the
/// scene's primitives, and the box's mean depth; `None` if a primitive is
/// unbounded or the box reaches the lens plane.
fn weak_perspective_over_scene(scene: &Scene) -> Option<(f64, Len)> {
    let ext = &scene.camera.extrinsics;
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
    let cam_pt = |p: crate::WorldPoint| ext.world_to_camera(p).value.to_f64();
    let cam_dir = |d: [crate::Norm; 3]| {
        let r = ext.rotation();
        r.map(|row| {
            (0..3)
                .map(|k| {
                    row.get(k)
                        .zip(d.get(k))
                        .map_or(0.0, |(a, b)| a.to_num::<f64>() * b.to_num::<f64>())
                })
                .sum::<f64>()
        })
    };
    for prim in &scene.primitives {
        match prim.shape {
            Shape::Plane { .. } => return None,
            Shape::Sphere { centre, radius } => {
                let (c, r) = (cam_pt(centre), radius.to_num::<f64>());
                grow([c[0] - r, c[1] - r, c[2] - r]);
                grow([c[0] + r, c[1] + r, c[2] + r]);
            }
            Shape::Disc {
                centre,
                normal,
                radius,
            } => {
                // Extent of a disc along axis k: r·sqrt(1 − n_k²).
                let (c, n, r) = (cam_pt(centre), cam_dir(normal), radius.to_num::<f64>());
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
                let (a, b) = (half[0].to_num::<f64>(), half[1].to_num::<f64>());
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
    let z_bar = Len::from_num((lo[2] + hi[2]) / 2.0);
    let bound = weak_perspective_bound(&scene.camera.intrinsics, DepthBox { min, max }, z_bar).ok()?;
    if bound.saturated {
        return None;
    }
    Some((bound.value.to_num::<f64>(), z_bar))
}
