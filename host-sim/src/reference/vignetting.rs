//! Reference image irradiance and pixel values (camera-model.md §5).

use std::f64::consts::PI;

/// `cos⁴α = 1 / (1 + x̂² + ŷ²)²` for undistorted normalized `(x̂, ŷ)`.
pub fn cos4(x: f64, y: f64) -> f64 {
    let w = 1.0 + x * x + y * y;
    1.0 / (w * w)
}

/// `E = L π/4 (d/f)² cos⁴α` (pass `cos4 = 1` for a telecentric camera).
pub fn irradiance(radiance: f64, d: f64, f: f64, cos4: f64) -> f64 {
    radiance * PI / 4.0 * (d / f) * (d / f) * cos4
}

/// `DN = min(DN_max, floor(v + 1/2))` of a value `v` in DN.
pub fn round_dn(v: f64, dn_max: u32) -> u32 {
    let v = (v + 0.5).floor();
    if v >= dn_max as f64 {
        dn_max
    } else if v <= 0.0 {
        0
    } else {
        v as u32
    }
}
