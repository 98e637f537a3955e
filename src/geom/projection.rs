//! Projection models: scene point → image plane, and pixel → ray
//! (camera-model.md §2).
//!
//! | model | image point | ray through a pixel |
//! |---|---|---|
//! | perspective | `x = f X/Z` | from `O`, direction `(x̂, ŷ, 1)` |
//! | weak perspective | `x = f X/Z̄` | from `(x̂ Z̄, ŷ Z̄, 0)`, direction `(0, 0, 1)` |
//! | orthographic | `x = m X` | from `(x/m, y/m, 0)`, direction `(0, 0, 1)` |
//!
//! Under every model a point with `Z ≤ 0` (at or behind the lens plane) is
//! [`NotVisible`]: a result, never a division by zero.

use crate::geom::error::{in_range, to_fixed, Error, Field, NotVisible};
use crate::geom::frame::{CameraDir, CameraPoint, ImagePoint, PixelPoint, Ray};
use crate::geom::intrinsics::Intrinsics;
use crate::num::{quotient, Gain, Len, Norm, Sat, Wide};
use core::ops::{Mul as _, Sub as _};

/// Supported weak-perspective mean depths `Z̄`, metres.
pub const MEAN_DEPTH_RANGE: (f64, f64) = (1e-3, 1e6);
/// Supported orthographic scales `m` (image metres per scene metre).
pub const ORTHO_SCALE_RANGE: (f64, f64) = (1e-6, 1e2);

/// How the camera maps scene points to the image plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// Pinhole perspective.
    Perspective,
    /// Perspective with every point at the mean depth `Z̄` (metres).
    WeakPerspective {
        /// `Z̄`, metres.
        mean_depth: Len,
    },
    /// Parallel projection with scale `m` (telecentric lens).
    Orthographic {
        /// `m`, image metres per scene metre (I16F48: a 10⁻⁶ scale keeps
        /// 4·10⁻⁹ relative).
        scale: Norm,
    },
}

impl Model {
    /// Weak perspective with mean depth `Z̄` in [`MEAN_DEPTH_RANGE`] metres.
    pub fn weak_perspective(mean_depth: f64) -> Result<Model, Error> {
        let z = in_range(
            mean_depth,
            MEAN_DEPTH_RANGE.0,
            MEAN_DEPTH_RANGE.1,
            Field::MeanDepth,
        )?;
        Ok(Model::WeakPerspective {
            mean_depth: to_fixed(z, Field::MeanDepth)?,
        })
    }

    /// Orthographic with scale `m` in [`ORTHO_SCALE_RANGE`].
    pub fn orthographic(scale: f64) -> Result<Model, Error> {
        let m = in_range(
            scale,
            ORTHO_SCALE_RANGE.0,
            ORTHO_SCALE_RANGE.1,
            Field::OrthographicScale,
        )?;
        Ok(Model::Orthographic {
            scale: to_fixed(m, Field::OrthographicScale)?,
        })
    }

    /// Camera-frame point → image plane (metres).
    ///
    /// Error ≤ 1 pm (one rounding into [`Len`]); saturates when `|x|` exceeds
    /// 8.4·10⁶ m, which only a point within 10⁻¹² of the lens plane reaches.
    pub fn project(&self, f: Len, p: CameraPoint) -> Result<Sat<ImagePoint>, NotVisible> {
        let [x, y] = self.project_wide(f, [Wide::of(p.x), Wide::of(p.y), Wide::of(p.z)])?;
        Ok(x.narrow().zip(y.narrow()).map(|(x, y)| ImagePoint { x, y }))
    }

    /// Camera-frame point → image plane, not narrowed (for fused chains).
    pub(crate) fn project_wide(&self, f: Len, p: [Wide; 3]) -> Result<[Wide; 2], NotVisible> {
        let [x, y, z] = p;
        if z.signum() <= 0 {
            return Err(NotVisible::BehindCamera);
        }
        let (k, depth) = match *self {
            Model::Perspective => (Wide::of(f), z),
            Model::WeakPerspective { mean_depth } => (Wide::of(f), Wide::of(mean_depth)),
            Model::Orthographic { scale } => return Ok([x.mul(Wide::of(scale)), y.mul(Wide::of(scale))]),
        };
        // depth > 0 here (checked above, or a validated Z̄), so div succeeds.
        match (x.mul(k).checked_div(depth), y.mul(k).checked_div(depth)) {
            (Some(u), Some(v)) => Ok([u, v]),
            _ => Err(NotVisible::BehindCamera),
        }
    }

    /// The ray through a pixel position (camera frame).
    ///
    /// Perspective directions have `z = 1` and slopes `x̂, ŷ` (error ≤ 2⁻⁴⁸);
    /// parallel rays have direction `(0, 0, 1)` and origins on `z = 0`,
    /// rounded to 0.45 pm. In pixels that rounding is `f/(s Z̄)`·0.45 pm for
    /// weak perspective (≤ 5·10⁻⁶ px when `Z̄ > f`) and `m/s`·0.45 pm for
    /// orthographic (≤ 5·10⁻⁴ px over the supported `m` and `s`).
    pub fn ray(&self, cam: &Intrinsics, p: PixelPoint) -> Sat<Ray> {
        let parallel = CameraDir {
            x: Norm::ZERO,
            y: Norm::ZERO,
            z: Norm::ONE,
        };
        match *self {
            Model::Perspective => cam.pixel_to_normalized(p).map(|n| Ray {
                origin: CameraPoint::default(),
                dir: CameraDir {
                    x: n.x,
                    y: n.y,
                    z: Norm::ONE,
                },
            }),
            Model::WeakPerspective { mean_depth } => {
                let zb = Wide::of(mean_depth);
                let origin = match cam.pixel_to_normalized_wide(p) {
                    Some([x, y]) => x
                        .mul(zb)
                        .narrow::<Len>()
                        .zip(y.mul(zb).narrow::<Len>())
                        .map(|(x, y)| CameraPoint { x, y, z: Len::ZERO }),
                    None => Sat {
                        value: CameraPoint::default(),
                        saturated: true,
                    },
                };
                origin.map(|origin| Ray {
                    origin,
                    dir: parallel,
                })
            }
            Model::Orthographic { scale } => {
                let ip = cam.pixel_to_image(p);
                let m = Wide::of(scale);
                let x = quotient::<Len>(Wide::of(ip.value.x), m);
                let y = quotient::<Len>(Wide::of(ip.value.y), m);
                let origin = x.zip(y).map(|(x, y)| CameraPoint { x, y, z: Len::ZERO });
                Sat {
                    value: Ray {
                        origin: origin.value,
                        dir: parallel,
                    },
                    saturated: ip.saturated || origin.saturated,
                }
            }
        }
    }
}

/// Weak-perspective error of one point on the image plane (metres):
/// `f |X| |Z̄ − Z| / (Z Z̄)` for `x`, likewise for `y`; returns the larger.
pub fn weak_perspective_error(f: Len, p: CameraPoint, mean_depth: Len) -> Result<Sat<Len>, NotVisible> {
    if p.z <= Len::ZERO {
        return Err(NotVisible::BehindCamera);
    }
    let xy = Wide::of(p.x).abs().max_of(Wide::of(p.y).abs());
    let dz = Wide::of(mean_depth).sub(Wide::of(p.z)).abs();
    let num = Wide::of(f).mul(xy).mul(dz);
    let den = Wide::of(p.z).mul(Wide::of(mean_depth));
    Ok(quotient(num, den))
}

/// An axis-aligned box in the camera frame, bounding a scene's content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthBox {
    /// The corner with the smallest coordinates.
    pub min: CameraPoint,
    /// The corner with the largest coordinates.
    pub max: CameraPoint,
}

/// The largest weak-perspective error over a box, in pixels:
/// `max(e_x / s_x, e_y / s_y)` with `e = f |X| |Z̄ − Z| / (Z Z̄)`.
///
/// `|Z̄ − Z|/Z = |Z̄/Z − 1|` is monotonic on each side of `Z̄`, so the maximum
/// lies at a corner of the box; the bound is exact, not an estimate. The box
/// must lie in front of the camera (`min.z > 0`).
pub fn weak_perspective_bound(
    cam: &Intrinsics,
    b: DepthBox,
    mean_depth: Len,
) -> Result<Sat<Gain>, NotVisible> {
    if b.min.z <= Len::ZERO {
        return Err(NotVisible::BehindCamera);
    }
    let f = Wide::of(cam.focal_length());
    let zb = Wide::of(mean_depth);
    let ax = Wide::of(b.min.x).abs().max_of(Wide::of(b.max.x).abs());
    let ay = Wide::of(b.min.y).abs().max_of(Wide::of(b.max.y).abs());
    // max over the two depth faces of |Z̄ − Z| / (Z Z̄)
    let per_depth = |z: Len| -> Option<Wide> { zb.sub(Wide::of(z)).abs().checked_div(Wide::of(z).mul(zb)) };
    let k = match (per_depth(b.min.z), per_depth(b.max.z)) {
        (Some(a), Some(c)) => a.max_of(c),
        _ => return Err(NotVisible::BehindCamera),
    };
    let (sx, sy) = cam.pitch();
    let ex = f.mul(ax).mul(k).checked_div(Wide::of(sx));
    let ey = f.mul(ay).mul(k).checked_div(Wide::of(sy));
    match (ex, ey) {
        (Some(ex), Some(ey)) => Ok(ex.max_of(ey).narrow()),
        _ => Ok(Sat {
            value: Gain::MAX,
            saturated: true,
        }),
    }
}
