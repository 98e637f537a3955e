//! The demo camera: projections and lens figures, core vs reference.

use crate::reference::{extrinsics::Pose, intrinsics::Sensor, lens::ThinLens, projection};
use hilcam::geom::lens::{Aperture, Distance, LensConfig};
use hilcam::{Camera, Extrinsics, IntrinsicsConfig, Model, WorldPoint};
use std::fmt::Write;

/// The demo camera's parameters (SI units).
pub struct DemoSetup {
    /// Sensor.
    pub intrinsics: IntrinsicsConfig,
    /// Lens (F-number form).
    pub lens: LensConfig,
    /// Eye, target, up.
    pub look_at: ([f64; 3], [f64; 3], [f64; 3]),
}

/// 640×480, f = 8 mm, 4.8 µm pixels, F/2.8 focused at 2 m, b̃ = one pixel,
/// looking from (0.3, 1.2, −2.5) m at (0, 0.2, 1) m.
pub fn setup() -> DemoSetup {
    DemoSetup {
        intrinsics: IntrinsicsConfig {
            focal_length: 8e-3,
            pitch: (4.8e-6, 4.8e-6),
            size: (640, 480),
            principal_point: None,
        },
        lens: LensConfig {
            aperture: Aperture::FNumber(2.8),
            focus_distance: 2.0,
            tolerable_blur: 4.8e-6,
        },
        look_at: ([0.3, 1.2, -2.5], [0.0, 0.2, 1.0], [0.0, 1.0, 0.0]),
    }
}

/// Largest errors seen by the demo.
#[derive(Debug, Default, Clone, Copy)]
pub struct DemoErrors {
    /// Largest projected-pixel distance, core vs reference, px.
    pub max_px: f64,
    /// Largest relative lens-quantity error.
    pub max_lens_rel: f64,
    /// Points compared.
    pub points: usize,
}

/// Runs the demo and returns the report text and the largest errors.
pub fn run() -> Result<(String, DemoErrors), String> {
    let s = setup();
    let (eye, target, up) = s.look_at;
    let pose = Extrinsics::look_at(eye, target, up).map_err(|e| e.to_string())?;
    let ic = s.intrinsics;
    let models = [
        ("perspective", Model::Perspective, projection::Model::Perspective),
        (
            "weak-persp Z̄=3.6m",
            Model::weak_perspective(3.6).map_err(|e| e.to_string())?,
            projection::Model::WeakPerspective(3.6),
        ),
        (
            "orthographic m=1e-3",
            Model::orthographic(1e-3).map_err(|e| e.to_string())?,
            projection::Model::Orthographic(1e-3),
        ),
    ];
    let rpose = Pose::look_at(eye, target, up);
    let sensor = Sensor::centred(ic.focal_length, ic.pitch.0, ic.pitch.1, 640, 480);

    // A 7×5 grid of 10 cm checkerboard corners on the plane z = 1 m, one point
    // behind the camera and one far outside the field of view.
    let mut points: Vec<[f64; 3]> = Vec::new();
    for j in 0..5 {
        for i in 0..7 {
            points.push([-0.3 + 0.1 * i as f64, 0.0 + 0.1 * j as f64, 1.0]);
        }
    }
    points.push([0.0, 0.5, -4.0]);
    points.push([40.0, 0.2, -2.4]);

    let mut out = String::new();
    let mut errs = DemoErrors::default();
    let _ = writeln!(
        out,
        "demo camera: 640x480, f = 8 mm, pitch 4.8 um, F/2.8 focused at 2 m; eye {eye:?} -> target {target:?}\n"
    );
    for (name, model, rmodel) in models {
        let cam = Camera::new(&ic, &s.lens, pose, model).map_err(|e| e.to_string())?;
        let _ = writeln!(out, "{name}:");
        let _ = writeln!(
            out,
            "  {:>22}  {:>22}  {:>22}  {:>10}",
            "world point (m)", "core (px)", "reference (px)", "|err| px"
        );
        for p in &points {
            let wp = WorldPoint::from_f64(*p).map_err(|e| e.to_string())?;
            let core = cam.project(wp);
            // The reference sees exactly the point the core was given.
            let pc = rpose.world_to_camera(wp.to_f64());
            let rf =
                projection::project(rmodel, ic.focal_length, pc).map(|(x, y)| sensor.image_to_pixel(x, y));
            let pstr = format!("({:.2}, {:.2}, {:.2})", p[0], p[1], p[2]);
            match (core, rf) {
                (Ok(c), Some(r)) => {
                    let [cx, cy] = c.value.to_f64();
                    if c.saturated {
                        let _ = writeln!(
                            out,
                            "  {pstr:>22}  {:>22}  {:>22}  {:>10}",
                            "saturated (flagged)",
                            format!("({:.4}, {:.4})", r.0, r.1),
                            "-"
                        );
                    } else {
                        let e = (cx - r.0).hypot(cy - r.1);
                        errs.max_px = errs.max_px.max(e);
                        errs.points += 1;
                        let _ = writeln!(
                            out,
                            "  {pstr:>22}  {:>22}  {:>22}  {e:>10.2e}",
                            format!("({cx:.4}, {cy:.4})"),
                            format!("({:.4}, {:.4})", r.0, r.1)
                        );
                    }
                }
                (Err(_), None) => {
                    let _ = writeln!(
                        out,
                        "  {pstr:>22}  {:>22}  {:>22}  {:>10}",
                        "not visible", "not visible", "-"
                    );
                }
                (c, r) => {
                    return Err(format!(
                        "core and reference disagree on visibility at {p:?}: {c:?} vs {r:?}"
                    ))
                }
            }
        }
        let _ = writeln!(out);
    }

    lens_table(&s, pose, &sensor, &mut out, &mut errs)?;
    let _ = writeln!(
        out,
        "\nsummary: {} projected points, max |core - reference| = {:.3e} px (target 1/256 = 3.9e-3); \
         max lens relative error = {:.3e} (target 1e-4)",
        errs.points, errs.max_px, errs.max_lens_rel
    );
    Ok((out, errs))
}

/// The lens figures (F-number, angles, distances, depth of field, blur),
/// core against reference, as a table into `out`; the largest relative
/// error into `errs`.
fn lens_table(
    s: &DemoSetup,
    pose: Extrinsics,
    sensor: &Sensor,
    out: &mut String,
    errs: &mut DemoErrors,
) -> Result<(), String> {
    let cam = Camera::new(&s.intrinsics, &s.lens, pose, Model::Perspective).map_err(|e| e.to_string())?;
    let lens = cam.lens();
    let rl = ThinLens {
        f: s.intrinsics.focal_length,
        d: s.intrinsics.focal_length / 2.8,
        focus: 2.0,
        blur: 4.8e-6,
    };
    let dof = lens.depth_of_field();
    let far = match dof.value.far {
        Distance::Finite(v) => Some(v.to_num::<f64>()),
        Distance::Infinite => None,
    };
    let (hx, hy) = cam.intrinsics().half_angles_of_view();
    let (rhx, rhy) = sensor.half_angles_of_view();
    let mut rows: Vec<(&str, f64, Option<f64>)> = vec![
        ("F-number N", lens.f_number().value.to_num(), Some(rl.f_number())),
        (
            "aperture half-angle w (rad)",
            lens.aperture_half_angle().to_num(),
            Some(rl.aperture_half_angle()),
        ),
        ("half-angle of view x (rad)", hx.to_num(), Some(rhx)),
        ("half-angle of view y (rad)", hy.to_num(), Some(rhy)),
        (
            "sensor distance z' (m)",
            lens.sensor_distance().to_num(),
            Some(rl.sensor_distance()),
        ),
        (
            "hyperfocal distance (m)",
            lens.hyperfocal_distance().value.to_num(),
            Some(rl.hyperfocal_distance()),
        ),
        ("DOF near (m)", dof.value.near.to_num(), Some(rl.near())),
    ];
    let far_row = far.zip(rl.far());
    if let Some((c, r)) = far_row {
        rows.push(("DOF far (m)", c, Some(r)));
    }
    for z in [0.5, 1.0, 4.0, 50.0] {
        let zl = hilcam::Len::from_num(z);
        let name: &'static str = Box::leak(format!("blur at {z} m (m)").into_boxed_str());
        let c = lens
            .blur_diameter(zl)
            .map(|b| b.value.to_num::<f64>())
            .unwrap_or(f64::NAN);
        rows.push((name, c, rl.blur_diameter(z)));
        let name: &'static str = Box::leak(format!("image distance at {z} m (m)").into_boxed_str());
        let c = lens
            .image_distance(zl)
            .map(|b| b.value.to_num::<f64>())
            .unwrap_or(f64::NAN);
        rows.push((name, c, rl.image_distance(z)));
    }
    let _ = writeln!(out, "lens:");
    let _ = writeln!(
        out,
        "  {:>32}  {:>18}  {:>18}  {:>10}",
        "quantity", "core", "reference", "rel err"
    );
    for (name, c, r) in rows {
        let r = r.unwrap_or(f64::NAN);
        let rel = if r != 0.0 {
            ((c - r) / r).abs()
        } else {
            (c - r).abs()
        };
        errs.max_lens_rel = errs.max_lens_rel.max(rel);
        let _ = writeln!(out, "  {name:>32}  {c:>18.10e}  {r:>18.10e}  {rel:>10.2e}");
    }
    Ok(())
}
