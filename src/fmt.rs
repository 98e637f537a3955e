//! `defmt::Format` for the public types (feature `defmt`).
//!
//! Fixed-point fields are logged as their raw bits; the format (and so the
//! scale) of each is given in [`crate::num`].

use crate::geom::frame::{CameraDir, CameraPoint, ImagePoint, NormPoint, PixelPoint, Ray, WorldPoint};
use crate::geom::lens::{DepthOfField, Distance};
use crate::geom::projection::Model;
use crate::num::Sat;
use defmt::{write, Format, Formatter};

macro_rules! bits {
    ($t:ty, $fmt:literal, $($field:ident),+) => {
        impl Format for $t {
            fn format(&self, f: Formatter) {
                write!(f, $fmt, $(self.$field.to_bits()),+)
            }
        }
    };
}

bits!(
    WorldPoint,
    "WorldPoint(I24F40 bits {=i64}, {=i64}, {=i64})",
    x,
    y,
    z
);
bits!(
    CameraPoint,
    "CameraPoint(I24F40 bits {=i64}, {=i64}, {=i64})",
    x,
    y,
    z
);
bits!(ImagePoint, "ImagePoint(I24F40 bits {=i64}, {=i64})", x, y);
bits!(NormPoint, "NormPoint(I16F48 bits {=i64}, {=i64})", x, y);
bits!(PixelPoint, "PixelPoint(I16F16 bits {=i32}, {=i32})", x, y);
bits!(
    CameraDir,
    "CameraDir(I16F48 bits {=i64}, {=i64}, {=i64})",
    x,
    y,
    z
);

impl Format for Ray {
    fn format(&self, f: Formatter) {
        write!(f, "Ray {{ origin: {}, dir: {} }}", self.origin, self.dir)
    }
}

impl<T: Format> Format for Sat<T> {
    fn format(&self, f: Formatter) {
        write!(
            f,
            "Sat {{ value: {}, saturated: {=bool} }}",
            self.value, self.saturated
        )
    }
}

impl Format for Distance {
    fn format(&self, f: Formatter) {
        match self {
            Distance::Finite(d) => write!(f, "Finite(I24F40 bits {=i64})", d.to_bits()),
            Distance::Infinite => write!(f, "Infinite"),
        }
    }
}

impl Format for DepthOfField {
    fn format(&self, f: Formatter) {
        write!(
            f,
            "DepthOfField {{ near: I24F40 bits {=i64}, far: {}, total: {} }}",
            self.near.to_bits(),
            self.far,
            self.total
        )
    }
}

impl Format for Model {
    fn format(&self, f: Formatter) {
        match self {
            Model::Perspective => write!(f, "Perspective"),
            Model::WeakPerspective { mean_depth } => {
                write!(f, "WeakPerspective(I24F40 bits {=i64})", mean_depth.to_bits())
            }
            Model::Orthographic { scale } => write!(f, "Orthographic(I16F48 bits {=i64})", scale.to_bits()),
        }
    }
}
