//! Thin lens: lens law, F-number, blur circle and depth of field
//! (camera-model.md §4).
//!
//! Distances with a hat (`Ẑ`, `ẑ`) are measured from the lens; plain `Z`, `z`
//! (Newtonian) from the foci. All lengths are [`Len`] metres.

use crate::geom::error::{in_range, to_fixed, Error, Field, NoRealImage};
use crate::geom::intrinsics::FOCAL_LENGTH_RANGE;
use crate::num::{quotient, Angle, Gain, Len, Sat, Wide};
use core::ops::{Add as _, Mul as _, Sub as _};

/// Supported F-numbers `N = f/d`.
pub const F_NUMBER_RANGE: (f64, f64) = (0.5, 256.0);
/// Supported focus distances `Z̃`, metres (and `Z̃ > f`).
pub const FOCUS_RANGE: (f64, f64) = (1e-4, 1e6);
/// Supported tolerable blur diameters `b̃`, metres.
pub const BLUR_RANGE: (f64, f64) = (1e-7, 1e-2);

/// How the aperture is given.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum Aperture {
    /// Effective diameter `d`, metres.
    Diameter(f64),
    /// F-number `N = f/d`.
    FNumber(f64),
}

/// What a [`Lens`] is built from, besides the focal length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensConfig {
    /// The aperture, such that `N = f/d` lies in [`F_NUMBER_RANGE`].
    pub aperture: Aperture,
    /// Focus distance `Z̃` (lens side), metres, in [`FOCUS_RANGE`], `> f`.
    pub focus_distance: f64,
    /// Tolerable blur-circle diameter `b̃`, metres, in [`BLUR_RANGE`].
    pub tolerable_blur: f64,
}

/// A distance that may be infinite (the far limit of the depth of field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distance {
    /// A finite distance, metres.
    Finite(Len),
    /// Infinitely far.
    Infinite,
}

/// Depth of field for the lens's focus distance and tolerable blur.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthOfField {
    /// Near plane `Ẑ_n`, metres.
    pub near: Len,
    /// Far plane `Ẑ_f`: infinite when focused at or past the hyperfocal
    /// distance.
    pub far: Distance,
    /// `Ẑ_f − Ẑ_n`.
    pub total: Distance,
}

/// A validated thin lens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lens {
    f: Len,
    d: Len,
    focus: Len,
    blur: Len,
    sensor: Len,
    tan_half_angle: u64,
}

impl Lens {
    /// Validates and builds, for focal length `f` (metres, in
    /// [`FOCAL_LENGTH_RANGE`]).
    pub fn new(focal_length: f64, c: &LensConfig) -> Result<Self, Error> {
        let f = in_range(
            focal_length,
            FOCAL_LENGTH_RANGE.0,
            FOCAL_LENGTH_RANGE.1,
            Field::FocalLength,
        )?;
        let d = match c.aperture {
            Aperture::Diameter(d) => {
                let d = crate::geom::error::positive(d, Field::Aperture)?;
                let n = f / d;
                if n < F_NUMBER_RANGE.0 || n > F_NUMBER_RANGE.1 {
                    return Err(Error::OutOfRange(Field::Aperture));
                }
                d
            }
            Aperture::FNumber(n) => f / in_range(n, F_NUMBER_RANGE.0, F_NUMBER_RANGE.1, Field::FNumber)?,
        };
        let z = in_range(
            c.focus_distance,
            FOCUS_RANGE.0,
            FOCUS_RANGE.1,
            Field::FocusDistance,
        )?;
        let b = in_range(c.tolerable_blur, BLUR_RANGE.0, BLUR_RANGE.1, Field::TolerableBlur)?;
        let fx: Len = to_fixed(f, Field::FocalLength)?;
        let zx: Len = to_fixed(z, Field::FocusDistance)?;
        if zx <= fx {
            return Err(Error::FocusInsideFocalLength);
        }
        let mut lens = Lens {
            f: fx,
            d: to_fixed(d, Field::Aperture)?,
            focus: zx,
            blur: to_fixed(b, Field::TolerableBlur)?,
            sensor: Len::ZERO,
            tan_half_angle: (d / (2.0 * f)).to_bits(),
        };
        // ẑ' = f Z̃ / (Z̃ − f): must be representable.
        lens.sensor = match lens.image_distance(zx) {
            Ok(s) if !s.saturated => s.value,
            _ => return Err(Error::FocusInsideFocalLength),
        };
        Ok(lens)
    }

    /// Focal length `f`.
    pub fn focal_length(&self) -> Len {
        self.f
    }
    /// Effective aperture diameter `d`.
    pub fn diameter(&self) -> Len {
        self.d
    }
    /// Focus distance `Z̃`.
    pub fn focus_distance(&self) -> Len {
        self.focus
    }
    /// Tolerable blur-circle diameter `b̃`.
    pub fn tolerable_blur(&self) -> Len {
        self.blur
    }

    /// F-number `N = f/d` (error ≤ 2⁻³³).
    pub fn f_number(&self) -> Sat<Gain> {
        quotient(Wide::of(self.f), Wide::of(self.d))
    }

    /// The notes' "field of view" `w = atan(d / 2f)`: the half-angle the
    /// aperture subtends at the focus, radians, of the values the lens was
    /// built from (`atan` taken when asked, so that a renderer links none).
    pub fn aperture_half_angle(&self) -> Angle {
        crate::geom::intrinsics::half_angle(self.tan_half_angle)
    }

    /// Sensor position when focused at `Z̃`: `ẑ' = f Z̃ / (Z̃ − f)`.
    pub fn sensor_distance(&self) -> Len {
        self.sensor
    }

    /// Gaussian lens law: the image distance `ẑ = f Ẑ / (Ẑ − f)` of an object
    /// at `Ẑ`. The law is symmetric, so applied to an image distance it gives
    /// the object distance back.
    ///
    /// `Ẑ ≤ f` forms no real image. The error is the rounding of `f` (≤ 0.46
    /// pm) amplified by `f/(Ẑ − f)`, plus 0.5 pm for the result: ≤ 10⁻⁴
    /// relative while `Ẑ − f ≥ 5 nm`. Saturates when `ẑ` exceeds 8.4·10⁶ m.
    pub fn image_distance(&self, z_obj: Len) -> Result<Sat<Len>, NoRealImage> {
        if z_obj <= self.f {
            return Err(NoRealImage::InsideFocalLength);
        }
        let f = Wide::of(self.f);
        let z = Wide::of(z_obj);
        Ok(quotient(f.mul(z), z.sub(f)))
    }

    /// Newtonian lens law: `z = f² / Z`, with `Z = Ẑ − f` and `z = ẑ − f`
    /// measured from the foci. `Z ≤ 0` forms no real image.
    ///
    /// Error ≤ 0.5 pm absolute plus 10⁻⁸ relative (the rounding of `f`): so
    /// ≤ 10⁻⁴ relative for `z ≥ 10 nm`. A far object's `z` is picometres and
    /// keeps only the absolute bound.
    pub fn image_distance_newtonian(&self, z_obj: Len) -> Result<Sat<Len>, NoRealImage> {
        if z_obj <= Len::ZERO {
            return Err(NoRealImage::InsideFocalLength);
        }
        let f = Wide::of(self.f);
        Ok(quotient(f.mul(f), Wide::of(z_obj)))
    }

    /// Blur-circle diameter of a point at `Ẑ`: `b = d |ẑ' − ẑ| / ẑ'`.
    ///
    /// Computed as the algebraically equal `d f |Ẑ − Z̃| / (Z̃ (Ẑ − f))`, which
    /// has no cancellation between the nearly equal `ẑ'` and `ẑ`. The error is
    /// the rounding of the parameters and of the result into [`Len`]:
    /// ≤ 0.5 pm absolute plus 5·10⁻⁶ relative, so ≤ 10⁻⁴ relative for
    /// `b ≥ 10 nm` (a hundredth of the smallest supported pixel).
    pub fn blur_diameter(&self, z_obj: Len) -> Result<Sat<Len>, NoRealImage> {
        if z_obj <= self.f {
            return Err(NoRealImage::InsideFocalLength);
        }
        let (d, f, zt, z) = (
            Wide::of(self.d),
            Wide::of(self.f),
            Wide::of(self.focus),
            Wide::of(z_obj),
        );
        let num = d.mul(f).mul(z.sub(zt).abs());
        let den = zt.mul(z.sub(f));
        Ok(quotient(num, den))
    }

    /// Hyperfocal distance `H = d f / b̃`: focused at or past it, the far
    /// plane of the depth of field is at infinity.
    pub fn hyperfocal_distance(&self) -> Sat<Len> {
        quotient(Wide::of(self.d).mul(Wide::of(self.f)), Wide::of(self.blur))
    }

    /// Depth of field for `Z̃` and `b̃`:
    /// `Ẑ_n = Z̃ f (d + b̃) / (d f + b̃ Z̃)`,
    /// `Ẑ_f = Z̃ f (d − b̃) / (d f − b̃ Z̃)`, infinite when `d f − b̃ Z̃ ≤ 0`.
    ///
    /// The total is computed as `2 Z̃ f b̃ d (Z̃ − f) / ((d f)² − (b̃ Z̃)²)`,
    /// free of the cancellation between two nearly equal planes.
    ///
    /// Errors come from the parameters' rounding (≤ 5·10⁻⁶ relative, from
    /// `b̃`) and the result's (0.45 pm): the near plane and the total are within
    /// 10⁻⁴ relative (the total once it is ≥ 10 nm); the far plane is
    /// ill-conditioned just short of the hyperfocal distance `H`, in any
    /// arithmetic, and its error grows as `H/(H − Z̃)`: within 10⁻⁴ for
    /// `Z̃ ≤ 0.95 H`. A finite far plane beyond 8.4·10⁶ m saturates.
    pub fn depth_of_field(&self) -> Sat<DepthOfField> {
        let (d, f, zt, b) = (
            Wide::of(self.d),
            Wide::of(self.f),
            Wide::of(self.focus),
            Wide::of(self.blur),
        );
        let df = d.mul(f);
        let bz = b.mul(zt);
        let near = quotient::<Len>(zt.mul(f).mul(d.add(b)), df.add(bz));
        let den_far = df.sub(bz);
        if den_far.signum() <= 0 {
            return near.map(|n| DepthOfField {
                near: n,
                far: Distance::Infinite,
                total: Distance::Infinite,
            });
        }
        let far = quotient::<Len>(zt.mul(f).mul(d.sub(b)), den_far);
        // Ẑ_f − Ẑ_n without the cancellation of two nearly equal planes:
        // 2 Z̃ f b̃ d (Z̃ − f) / ((d f)² − (b̃ Z̃)²).
        let total = quotient::<Len>(
            Wide::int(2).mul(zt).mul(f).mul(b).mul(d).mul(zt.sub(f)),
            df.add(bz).mul(den_far),
        );
        Sat {
            value: DepthOfField {
                near: near.value,
                far: Distance::Finite(far.value),
                total: Distance::Finite(total.value),
            },
            saturated: near.saturated || far.saturated || total.saturated,
        }
    }
}
