//! Reference projection models and rays (camera-model.md §2).

use super::intrinsics::Sensor;
use super::V3;

/// Projection model in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    /// `x = f X/Z`.
    Perspective,
    /// `x = f X/Z̄`.
    WeakPerspective(f64),
    /// `x = m X`.
    Orthographic(f64),
}

/// Camera-frame point → image plane (metres); `None` when `Z ≤ 0`.
pub fn project(model: Model, f: f64, p: V3) -> Option<(f64, f64)> {
    let [x, y, z] = p;
    if z <= 0.0 {
        return None;
    }
    Some(match model {
        Model::Perspective => (f * x / z, f * y / z),
        Model::WeakPerspective(zb) => (f * x / zb, f * y / zb),
        Model::Orthographic(m) => (m * x, m * y),
    })
}

/// The ray through pixel `(xi, yi)`: `(origin, direction)` in the camera
/// frame.
pub fn ray(model: Model, s: &Sensor, xi: f64, yi: f64) -> (V3, V3) {
    match model {
        Model::Perspective => {
            let (xn, yn) = s.pixel_to_normalized(xi, yi);
            ([0.0; 3], [xn, yn, 1.0])
        }
        Model::WeakPerspective(zb) => {
            let (xn, yn) = s.pixel_to_normalized(xi, yi);
            ([xn * zb, yn * zb, 0.0], [0.0, 0.0, 1.0])
        }
        Model::Orthographic(m) => {
            let (x, y) = s.pixel_to_image(xi, yi);
            ([x / m, y / m, 0.0], [0.0, 0.0, 1.0])
        }
    }
}

/// Weak-perspective error of one point on the image plane, metres: the
/// distance between the perspective and the weak-perspective image, taken
/// per axis, larger of the two.
pub fn weak_perspective_error(f: f64, p: V3, zb: f64) -> f64 {
    let (px, py) = (f * p[0] / p[2], f * p[1] / p[2]);
    let (wx, wy) = (f * p[0] / zb, f * p[1] / zb);
    (px - wx).abs().max((py - wy).abs())
}

/// The largest weak-perspective error over a camera-frame box, pixels, by
/// sampling an `n × n × n` grid of the box (corners included). Independent
/// of the core's corner argument.
pub fn weak_perspective_bound_sampled(s: &Sensor, min: V3, max: V3, zb: f64, n: usize) -> f64 {
    let mut worst: f64 = 0.0;
    let lerp = |a: f64, b: f64, i: usize| a + (b - a) * i as f64 / (n - 1) as f64;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let p = [
                    lerp(min[0], max[0], i),
                    lerp(min[1], max[1], j),
                    lerp(min[2], max[2], k),
                ];
                let (px, py) = (s.f * p[0] / p[2], s.f * p[1] / p[2]);
                let (wx, wy) = (s.f * p[0] / zb, s.f * p[1] / zb);
                worst = worst.max(((px - wx) / s.sx).abs()).max(((py - wy) / s.sy).abs());
            }
        }
    }
    worst
}
