//! Typed errors of the constructors and of the per-point functions.

use core::fmt;

/// The parameter a construction error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Field {
    /// Focal length `f`.
    FocalLength,
    /// Pixel pitch `s_x`.
    PitchX,
    /// Pixel pitch `s_y`.
    PitchY,
    /// Sensor width in pixels.
    Width,
    /// Sensor height in pixels.
    Height,
    /// Principal point `o_x`.
    PrincipalX,
    /// Principal point `o_y`.
    PrincipalY,
    /// Rotation matrix `R`.
    Rotation,
    /// Translation `T` (the centre of projection in world coordinates).
    Translation,
    /// Yaw, pitch or roll angle.
    Angle,
    /// Look-at target point.
    Target,
    /// Look-at up vector.
    Up,
    /// Aperture diameter `d`.
    Aperture,
    /// F-number `N`.
    FNumber,
    /// Focus distance `Z̃`.
    FocusDistance,
    /// Tolerable blur-circle diameter `b̃`.
    TolerableBlur,
    /// Weak-perspective mean depth `Z̄`.
    MeanDepth,
    /// Orthographic scale `m`.
    OrthographicScale,
    /// A point's coordinates.
    Point,
    /// Radial distortion coefficients `k1`, `k2`.
    Distortion,
    /// A calibrated lens's coefficients (OpenCV's models).
    Calibrated,
}

impl Field {
    /// The parameter's name as the scene format and the docs spell it.
    pub const fn name(self) -> &'static str {
        match self {
            Field::FocalLength => "focal_length",
            Field::PitchX => "pitch_x",
            Field::PitchY => "pitch_y",
            Field::Width => "width",
            Field::Height => "height",
            Field::PrincipalX => "principal_x",
            Field::PrincipalY => "principal_y",
            Field::Rotation => "rotation",
            Field::Translation => "translation",
            Field::Angle => "angle",
            Field::Target => "target",
            Field::Up => "up",
            Field::Aperture => "aperture",
            Field::FNumber => "f_number",
            Field::FocusDistance => "focus_distance",
            Field::TolerableBlur => "tolerable_blur",
            Field::MeanDepth => "mean_depth",
            Field::OrthographicScale => "orthographic_scale",
            Field::Point => "point",
            Field::Distortion => "distortion",
            Field::Calibrated => "calibration",
        }
    }
}

/// Why a camera, lens or point could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The value is NaN or infinite.
    NotFinite(Field),
    /// The value must be strictly positive.
    NotPositive(Field),
    /// The value is finite and positive but outside the supported range
    /// (documented on the constructor).
    OutOfRange(Field),
    /// `R` is not orthonormal within [`ROTATION_TOLERANCE`].
    NotOrthonormal,
    /// `R` is orthonormal but has determinant −1 (a reflection).
    Reflection,
    /// Look-at with the target at the eye, or the up vector along the view.
    Degenerate(Field),
    /// Focus distance `Z̃ ≤ f`: the lens cannot focus there.
    FocusInsideFocalLength,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.field().name())?;
        self.why(f)
    }
}

impl core::error::Error for Error {}

/// How far `R Rᵀ` may be from the identity, entry by entry (and `det R` from
/// 1), for `R` to be accepted as a rotation.
pub const ROTATION_TOLERANCE: f64 = 1e-6;

impl Error {
    /// What is wrong, without the field's name.
    pub fn why(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NotFinite(_) => write!(f, "not a finite number"),
            Error::NotPositive(_) => write!(f, "must be greater than zero"),
            Error::OutOfRange(_) => write!(f, "outside the supported range"),
            Error::NotOrthonormal => {
                write!(f, "not orthonormal within the tolerance {:e}", ROTATION_TOLERANCE)
            }
            Error::Reflection => write!(f, "determinant is -1 (a reflection)"),
            Error::Degenerate(_) => write!(f, "degenerate look-at geometry"),
            Error::FocusInsideFocalLength => write!(f, "must exceed the focal length"),
        }
    }
}

impl Error {
    /// The parameter the error is about.
    pub const fn field(&self) -> Field {
        match self {
            Error::NotFinite(x) | Error::NotPositive(x) | Error::OutOfRange(x) | Error::Degenerate(x) => *x,
            Error::NotOrthonormal | Error::Reflection => Field::Rotation,
            Error::FocusInsideFocalLength => Field::FocusDistance,
        }
    }
}

/// A scene point that a projection cannot image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NotVisible {
    /// The point is at or behind the lens plane (`Z ≤ 0`).
    BehindCamera,
}

/// A distance at which the lens forms no real image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoRealImage {
    /// The object is at or inside the focal length (`Ẑ ≤ f`, or `Z ≤ 0`).
    InsideFocalLength,
}

/// Checks a construction parameter: finite, and strictly positive.
pub(crate) fn positive(x: f64, field: Field) -> Result<f64, Error> {
    if !x.is_finite() {
        Err(Error::NotFinite(field))
    } else if x <= 0.0 {
        Err(Error::NotPositive(field))
    } else {
        Ok(x)
    }
}

/// Checks a construction parameter: finite, positive, and within `[lo, hi]`.
pub(crate) fn in_range(x: f64, lo: f64, hi: f64, field: Field) -> Result<f64, Error> {
    let x = positive(x, field)?;
    if x < lo || x > hi {
        Err(Error::OutOfRange(field))
    } else {
        Ok(x)
    }
}

/// Checks a finite value and converts it to a storage format.
pub(crate) fn to_fixed<T>(x: f64, field: Field) -> Result<T, Error>
where
    T: fixed::traits::Fixed,
    T::Bits: TryFrom<i64>,
{
    if !x.is_finite() {
        return Err(Error::NotFinite(field));
    }
    crate::num::from_f64(x).ok_or(Error::OutOfRange(field))
}
