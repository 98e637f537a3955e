//! f64 reference models, one module per stage of the core.

pub mod defocus;
pub mod distortion;
pub mod extrinsics;
pub mod intrinsics;
pub mod lens;
pub mod noise;
pub mod projection;
pub mod render;
pub mod sampling;
pub mod shading;
pub mod shadows;
pub mod vignetting;

/// A 3-vector.
pub type V3 = [f64; 3];

/// `a·b`.
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn unit(a: V3) -> V3 {
    // hypot: no overflow for vectors as long as f64 holds.
    let n = a[0].hypot(a[1]).hypot(a[2]);
    [a[0] / n, a[1] / n, a[2] / n]
}
