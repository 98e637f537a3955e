//! Ground truth for calibration tools (`host-sim export`): a scene's camera
//! as an OpenCV `FileStorage` YAML and a ROS `CameraInfo` YAML, and world
//! points with the pixels the emulator images them at, to check the
//! export with.
//!
//! Conventions. OpenCV's camera frame has `x` right and `y` down; the
//! contract's (camera-model.md §1) has `x` left and `y` up, so
//! `X_cv = F X_c` with `F = diag(−1, −1, 1)`: `R_cv = F R`, `t_cv = −R_cv T`.
//! With that, `fx = f/s_x`, `cx = o_x` (pixel centres at integers in both).
//! Distortion: OpenCV maps undistorted → distorted normalized radii,
//! `r_d = r_u (1 + k1 r_u² + k2 r_u⁴ + k3 r_u⁶)` (optionally divided by
//! `1 + k4 r_u² + k5 r_u⁴ + k6 r_u⁶`, its rational model); the contract
//! maps distorted → undistorted, `r_u = r_d (1 + k1 r_d² + k2 r_d⁴)`. The
//! export fits OpenCV's coefficients to the contract's map over every
//! radius the image holds (to its corners, or the lens fold), by least
//! squares in `r_d`, and states the largest residual in pixels.

use crate::reference::distortion::Radial;
use crate::reference::render::{RefModel, RefScene};
use crate::scene_file::Resolved;
use serde::Serialize;

/// Residual above which the rational model is tried, pixels.
pub const PLAIN_ENOUGH_PX: f64 = 0.05;

/// OpenCV's distortion coefficients for a contract camera.
#[derive(Clone, Debug, Serialize)]
pub struct Fit {
    /// `plumb_bob` (k1, k2, p1, p2, k3) or `rational_polynomial` (k1, k2,
    /// p1, p2, k3, k4, k5, k6); the tangential p1 = p2 = 0.
    pub model: &'static str,
    /// In OpenCV's order.
    pub coefficients: Vec<f64>,
    /// Largest `|r_d(fit) − r_d|` over the fitted range, pixels (the larger
    /// of `f/s_x`, `f/s_y` times the normalized residual).
    pub residual_px: f64,
    /// The fitted range of distorted normalized radii, `[0, r_max]`.
    pub r_max: f64,
    /// The plain (plumb_bob) fit's residual, pixels, whichever model was
    /// chosen.
    pub plumb_bob_residual_px: f64,
}

/// Least squares `min |A x − b|` by Householder QR (`A` is `m × n`,
/// `m ≥ n`, row-major); `None` if `A` is rank-deficient. Written with
/// indices, as the algorithm is.
#[allow(clippy::needless_range_loop)]
fn lstsq(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let (m, n) = (a.len(), a.first()?.len());
    for k in 0..n {
        let norm = (k..m).map(|i| a[i][k] * a[i][k]).sum::<f64>().sqrt();
        if norm == 0.0 {
            return None;
        }
        let alpha = if a[k][k] > 0.0 { -norm } else { norm };
        let mut v: Vec<f64> = (k..m).map(|i| a[i][k]).collect();
        v[0] -= alpha;
        let vv = v.iter().map(|x| x * x).sum::<f64>();
        if vv == 0.0 {
            continue;
        }
        for j in k..n {
            let s = (k..m).map(|i| v[i - k] * a[i][j]).sum::<f64>() * 2.0 / vv;
            for i in k..m {
                a[i][j] -= s * v[i - k];
            }
        }
        let s = (k..m).map(|i| v[i - k] * b[i]).sum::<f64>() * 2.0 / vv;
        for i in k..m {
            b[i] -= s * v[i - k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        if a[k][k].abs() < 1e-300 {
            return None;
        }
        x[k] = (b[k] - (k + 1..n).map(|j| a[k][j] * x[j]).sum::<f64>()) / a[k][k];
    }
    Some(x)
}

/// Fits OpenCV's model to `radial` over distorted radii `[0, r_max]`;
/// `px` converts a normalized radius error to pixels.
pub fn fit(radial: Option<Radial>, r_max: f64, px: f64) -> Fit {
    let Some(rad) = radial.filter(|r| r.k1 != 0.0 || r.k2 != 0.0) else {
        return Fit {
            model: "plumb_bob",
            coefficients: vec![0.0; 5],
            residual_px: 0.0,
            r_max,
            plumb_bob_residual_px: 0.0,
        };
    };
    // Samples in r_d (the fit's residual is an r_d error), denser than
    // any feature of a degree-5 polynomial.
    let n = 4000;
    let samples: Vec<(f64, f64)> = (1..=n)
        .map(|k| {
            let rd = r_max * k as f64 / n as f64;
            (rd, rd * rad.g(rd * rd))
        })
        .collect();
    // Plain: r_d − r_u = r_u (k1 u + k2 u² + k3 u³), u = r_u².
    let plain = lstsq(
        samples
            .iter()
            .map(|&(_, ru)| {
                let u = ru * ru;
                vec![ru * u, ru * u * u, ru * u * u * u]
            })
            .collect(),
        samples.iter().map(|&(rd, ru)| rd - ru).collect(),
    )
    .unwrap_or_else(|| vec![0.0; 3]);
    let plain_at = |ru: f64| {
        let u = ru * ru;
        ru * (1.0 + plain[0] * u + plain[1] * u * u + plain[2] * u * u * u)
    };
    let worst = |f: &dyn Fn(f64) -> f64| {
        samples
            .iter()
            .map(|&(rd, ru)| (f(ru) - rd).abs())
            .fold(0.0, f64::max)
            * px
    };
    let plain_px = worst(&plain_at);
    let plain_fit = Fit {
        model: "plumb_bob",
        coefficients: vec![plain[0], plain[1], 0.0, 0.0, plain[2]],
        residual_px: plain_px,
        r_max,
        plumb_bob_residual_px: plain_px,
    };
    if plain_px <= PLAIN_ENOUGH_PX {
        return plain_fit;
    }
    // Rational: r_d (1 + k4 u + k5 u² + k6 u³) = r_u (1 + k1 u + k2 u² +
    // k3 u³), linear in the six.
    let Some(q) = lstsq(
        samples
            .iter()
            .map(|&(rd, ru)| {
                let u = ru * ru;
                vec![
                    ru * u,
                    ru * u * u,
                    ru * u * u * u,
                    -rd * u,
                    -rd * u * u,
                    -rd * u * u * u,
                ]
            })
            .collect(),
        samples.iter().map(|&(rd, ru)| rd - ru).collect(),
    ) else {
        return plain_fit;
    };
    let rational_at = |ru: f64| {
        let u = ru * ru;
        ru * (1.0 + q[0] * u + q[1] * u * u + q[2] * u * u * u)
            / (1.0 + q[3] * u + q[4] * u * u + q[5] * u * u * u)
    };
    let rational_px = worst(&rational_at);
    if rational_px < plain_px {
        Fit {
            model: "rational_polynomial",
            coefficients: vec![q[0], q[1], 0.0, 0.0, q[2], q[3], q[4], q[5]],
            residual_px: rational_px,
            r_max,
            plumb_bob_residual_px: plain_px,
        }
    } else {
        plain_fit
    }
}

/// A camera exported.
#[derive(Clone, Debug, Serialize)]
pub struct Export {
    /// Scene name.
    pub camera: String,
    /// Size, pixels.
    pub width: u32,
    /// Size, pixels.
    pub height: u32,
    /// `[fx, 0, cx; 0, fy, cy; 0, 0, 1]`, row-major.
    pub camera_matrix: [f64; 9],
    /// OpenCV's distortion.
    pub distortion: Fit,
    /// `R_cv`, row-major.
    pub rotation: [f64; 9],
    /// `t_cv`, metres.
    pub translation: [f64; 3],
    /// World points spread over the whole image at several depths.
    pub world_points: Vec<[f64; 3]>,
    /// Where the emulator images each (the contract's model, f64).
    pub pixels: Vec<[f64; 2]>,
    /// [`RESIDUAL_TOLERANCE_PX`].
    pub residual_tolerance_px: f64,
    /// Whether the refit's residual is within it: if not, OpenCV's model
    /// images this camera less exactly than a calibration test expects.
    pub within_tolerance: bool,
}

/// The export of scene `r`'s camera (perspective only: OpenCV's pinhole
/// model cannot express an orthographic camera).
pub fn export(r: &Resolved) -> Result<Export, String> {
    let rs = RefScene::new(r);
    if !matches!(rs.model, RefModel::Perspective) {
        return Err(format!(
            "camera.model: {:?}: a camera without perspective has no OpenCV or ROS pinhole model",
            r.desc.camera.model
        ));
    }
    let s = rs.sensor;
    let radial = rs.radial();
    // The distorted normalized position of pixel position (xi, yi).
    let norm = |xi: f64, yi: f64| (-(xi - s.ox) * s.sx / s.f, -(yi - s.oy) * s.sy / s.f);
    let (w, h) = (s.width as f64, s.height as f64);
    let fold = radial.and_then(|r| r.fold_u()).map(f64::sqrt);
    let r_max = [(-0.5, -0.5), (w - 0.5, -0.5), (-0.5, h - 0.5), (w - 0.5, h - 0.5)]
        .iter()
        .map(|&(x, y)| {
            let (a, b) = norm(x, y);
            a.hypot(b)
        })
        .fold(0.0, f64::max);
    let r_max = fold.map_or(r_max, |f| r_max.min(f));
    let px = (s.f / s.sx).max(s.f / s.sy);
    // A calibrated lens is OpenCV's own: its coefficients as given.
    let distortion = match r.desc.camera.lens()? {
        Some(lens) => {
            let (model, coefficients) = match (lens, &r.desc.camera.opencv_distortion) {
                (hilcam::scene::data::LensData::Fisheye(k), _) => ("equidistant", k.to_vec()),
                (_, Some(c)) if c.len() <= 5 => ("plumb_bob", c.clone()),
                (_, c) => ("rational_polynomial", c.clone().unwrap_or_default()),
            };
            Fit {
                model,
                coefficients,
                residual_px: 0.0,
                r_max,
                plumb_bob_residual_px: 0.0,
            }
        }
        None => fit(radial, r_max, px),
    };
    let within_tolerance = distortion.residual_px <= RESIDUAL_TOLERANCE_PX;
    let pose = rs.pose();
    let flip = [-1.0, -1.0, 1.0];
    let rcv: Vec<[f64; 3]> = (0..3).map(|i| pose.r[i].map(|v| flip[i] * v)).collect();
    let tcv: [f64; 3] = [0, 1, 2].map(|i| -(0..3).map(|k| rcv[i][k] * pose.t[k]).sum::<f64>());
    // A 21 × 15 grid of pixel positions from corner to corner, each at
    // three depths.
    let (mut world_points, mut pixels) = (Vec::new(), Vec::new());
    for j in 0..15 {
        for i in 0..21 {
            let xi = -0.5 + w * i as f64 / 20.0;
            let yi = -0.5 + h * j as f64 / 14.0;
            let (xd, yd) = norm(xi, yi);
            if fold.is_some_and(|f| xd.hypot(yd) > f) {
                continue;
            }
            let Some((x, y)) = rs.undistorted(xi, yi) else {
                continue;
            };
            for z in [0.5, 2.0, 8.0] {
                world_points.push(pose.camera_to_world([x * z, y * z, z]));
                pixels.push([xi, yi]);
            }
        }
    }
    let fx = s.f / s.sx;
    let fy = s.f / s.sy;
    Ok(Export {
        camera: r.desc.name.clone(),
        width: s.width,
        height: s.height,
        camera_matrix: [fx, 0.0, s.ox, 0.0, fy, s.oy, 0.0, 0.0, 1.0],
        distortion,
        rotation: [
            rcv[0][0], rcv[0][1], rcv[0][2], rcv[1][0], rcv[1][1], rcv[1][2], rcv[2][0], rcv[2][1], rcv[2][2],
        ],
        translation: tcv,
        world_points,
        pixels,
        residual_tolerance_px: RESIDUAL_TOLERANCE_PX,
        within_tolerance,
    })
}

/// The largest refit residual a calibration tool is told is exact enough,
/// pixels; a larger one is flagged ([`Export::within_tolerance`]).
pub const RESIDUAL_TOLERANCE_PX: f64 = 0.05;

/// `x` as a YAML float that YAML 1.1 (PyYAML, OpenCV) and 1.2 both read as
/// a float, to the nearest f64: a point in the mantissa and a signed
/// exponent (`3.3333333333333331e+2`).
pub fn yaml_float(x: f64) -> String {
    let s = format!("{x:e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let m = if m.contains('.') { m.to_string() } else { format!("{m}.0") };
    let e = if e.starts_with('-') { e.to_string() } else { format!("+{e}") };
    format!("{m}e{e}")
}

/// `s` as a YAML double-quoted scalar (JSON's escapes are YAML's): a name
/// with a newline or `: ` stays one value.
pub fn yaml_string(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into())
}

fn list(v: &[f64]) -> String {
    v.iter().map(|&x| yaml_float(x)).collect::<Vec<_>>().join(", ")
}

fn opencv_matrix(name: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    format!(
        "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        list(data)
    )
}

/// OpenCV `FileStorage` YAML: `camera_matrix`, `distortion_coefficients`
/// (5 or 8), `rotation_matrix` and `translation_vector` (world → OpenCV
/// camera), the image size, the model and the fit's residual.
pub fn opencv_yaml(e: &Export) -> String {
    let d = &e.distortion;
    let mut s = String::from("%YAML:1.0\n---\n");
    s += &format!("image_width: {}\nimage_height: {}\n", e.width, e.height);
    s += &opencv_matrix("camera_matrix", 3, 3, &e.camera_matrix);
    s += &opencv_matrix(
        "distortion_coefficients",
        1,
        d.coefficients.len(),
        &d.coefficients,
    );
    s += &opencv_matrix("rotation_matrix", 3, 3, &e.rotation);
    s += &opencv_matrix("translation_vector", 3, 1, &e.translation);
    s += &format!(
        "distortion_model: \"{}\"\nmax_residual_px: {}\n",
        d.model,
        yaml_float(d.residual_px)
    );
    s
}

/// ROS `CameraInfo` YAML (the `camera_calibration_parsers` layout): no
/// rectification, the projection matrix `[K | 0]`.
pub fn ros_yaml(e: &Export) -> String {
    let k = &e.camera_matrix;
    let d = &e.distortion;
    let p = [k[0], 0.0, k[2], 0.0, 0.0, k[4], k[5], 0.0, 0.0, 0.0, 1.0, 0.0];
    let block = |name: &str, rows: usize, cols: usize, data: &[f64]| {
        format!(
            "{name}:\n  rows: {rows}\n  cols: {cols}\n  data: [{}]\n",
            list(data)
        )
    };
    let mut s = format!(
        "image_width: {}\nimage_height: {}\ncamera_name: {}\n",
        e.width,
        e.height,
        yaml_string(&e.camera)
    );
    s += &block("camera_matrix", 3, 3, k);
    s += &format!("distortion_model: {}\n", yaml_string(d.model));
    s += &block(
        "distortion_coefficients",
        1,
        d.coefficients.len(),
        &d.coefficients,
    );
    s += &block(
        "rectification_matrix",
        3,
        3,
        &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
    );
    s += &block("projection_matrix", 3, 4, &p);
    s
}
