//! Coordinate frames as types (camera-model.md §1).
//!
//! A point carries its frame in its type, so a world point cannot be passed
//! where a camera point is expected. Conversions between frames are the
//! methods of [`crate::Extrinsics`] and [`crate::Intrinsics`].

use crate::geom::error::{to_fixed, Error, Field};
use crate::num::{FixedF64, Len, Norm, Px};

macro_rules! point3 {
    ($(#[$m:meta])* $name:ident) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
        pub struct $name {
            /// x, metres.
            pub x: Len,
            /// y, metres.
            pub y: Len,
            /// z, metres.
            pub z: Len,
        }

        impl $name {
            /// From coordinates in metres; each must be finite and within
            /// ±8.4·10⁶ m. Rounds to the nearest representable value.
            pub fn from_f64(p: [f64; 3]) -> Result<Self, Error> {
                Ok(Self {
                    x: to_fixed(p[0], Field::Point)?,
                    y: to_fixed(p[1], Field::Point)?,
                    z: to_fixed(p[2], Field::Point)?,
                })
            }

            /// The coordinates in metres.
            pub fn to_f64(self) -> [f64; 3] {
                [self.x.f64(), self.y.f64(), self.z.f64()]
            }
        }
    };
}

point3!(
    /// A point in the world frame W (metres; any right-handed frame).
    WorldPoint
);
point3!(
    /// A point in the camera frame C (metres): origin at the centre of
    /// projection, `z` along the optic axis towards the scene, `y` up,
    /// `x = y × z` (the camera's left).
    CameraPoint
);

/// A point on the image plane `z = f` (metres), axes parallel to the camera's
/// `x` and `y`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ImagePoint {
    /// x, metres.
    pub x: Len,
    /// y, metres.
    pub y: Len,
}

/// Normalized image coordinates `x̂ = x/f`, `ŷ = y/f` (dimensionless).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct NormPoint {
    /// x̂.
    pub x: Norm,
    /// ŷ.
    pub y: Norm,
}

/// A position in the pixel frame: `x_im` to the right, `y_im` down; integer
/// values are pixel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PixelPoint {
    /// x_im, pixels.
    pub x: Px,
    /// y_im, pixels.
    pub y: Px,
}

impl PixelPoint {
    /// The centre of pixel `(i, j)`.
    pub fn centre(i: u16, j: u16) -> Self {
        PixelPoint {
            x: Px::from_num(i),
            y: Px::from_num(j),
        }
    }

    /// From pixel coordinates; each must be finite and within ±32 768.
    pub fn from_f64(x: f64, y: f64) -> Result<Self, Error> {
        Ok(PixelPoint {
            x: to_fixed(x, Field::Point)?,
            y: to_fixed(y, Field::Point)?,
        })
    }

    /// The coordinates in pixels.
    pub fn to_f64(self) -> [f64; 2] {
        [self.x.f64(), self.y.f64()]
    }
}

/// The direction of a ray in the camera frame, as slopes with `z = 1` for
/// perspective rays (`(x̂, ŷ, 1)`) and `(0, 0, 1)` for the parallel rays of
/// weak perspective and orthographic cameras. Not normalized.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CameraDir {
    /// x component (slope).
    pub x: Norm,
    /// y component (slope).
    pub y: Norm,
    /// z component: 1 for every ray this crate produces.
    pub z: Norm,
}

/// A ray in the camera frame: the points `origin + t·dir`, `t ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Ray {
    /// Where the ray starts (metres).
    pub origin: CameraPoint,
    /// Its direction.
    pub dir: CameraDir,
}
