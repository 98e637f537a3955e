//! Intrinsics: focal length, pixel pitch, principal point and sensor size;
//! the maps image plane ↔ pixel and normalized ↔ pixel (camera-model.md §1).

use crate::geom::error::{in_range, to_fixed, Error, Field};
use crate::geom::frame::{ImagePoint, NormPoint, PixelPoint};
use crate::num::{quotient, Angle, Gain, Len, Norm, Pitch, Px, Sat, Wide};
use core::ops::{Mul as _, Sub as _};

/// Supported focal lengths, metres: 0.1 mm to 10 m.
pub const FOCAL_LENGTH_RANGE: (f64, f64) = (1e-4, 10.0);
/// Supported pixel pitches, metres: 0.1 µm to 1 mm.
pub const PITCH_RANGE: (f64, f64) = (1e-7, 1e-3);
/// Largest supported sensor side, pixels.
pub const MAX_SENSOR_SIDE: u16 = 16384;
/// Supported principal point coordinates, pixels.
pub const PRINCIPAL_RANGE: (f64, f64) = (-16384.0, 32767.0);

/// What an [`Intrinsics`] is built from (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntrinsicsConfig {
    /// Focal length `f`, metres, in [`FOCAL_LENGTH_RANGE`].
    pub focal_length: f64,
    /// Pixel pitch `(s_x, s_y)`, metres per pixel, each in [`PITCH_RANGE`].
    pub pitch: (f64, f64),
    /// Sensor size `(W, H)` in pixels, each in `1..=`[`MAX_SENSOR_SIDE`].
    pub size: (u16, u16),
    /// Principal point `(o_x, o_y)` in pixels; `None` for the sensor centre
    /// `((W−1)/2, (H−1)/2)`.
    pub principal_point: Option<(f64, f64)>,
}

/// Validated intrinsics, with the scale factors the per-point maps need
/// precomputed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Intrinsics {
    f: Len,
    sx: Pitch,
    sy: Pitch,
    ox: Px,
    oy: Px,
    width: u16,
    height: u16,
    /// Pixels per metre on the sensor, `1/s_x`, `1/s_y`.
    inv_sx: Gain,
    inv_sy: Gain,
    /// Focal length in pixels, `f/s_x`, `f/s_y`.
    fx: Gain,
    fy: Gain,
    /// `W s_x / 2f` and `H s_y / 2f` as f64 bits (computed from the given
    /// values): the half-angles of view are their `atan`, taken when asked,
    /// so that a renderer links no `atan`.
    tan_half_fov: (u64, u64),
}

impl Intrinsics {
    /// Validates and builds. Errors name the offending field.
    pub fn new(c: &IntrinsicsConfig) -> Result<Self, Error> {
        let f = in_range(
            c.focal_length,
            FOCAL_LENGTH_RANGE.0,
            FOCAL_LENGTH_RANGE.1,
            Field::FocalLength,
        )?;
        let sx = in_range(c.pitch.0, PITCH_RANGE.0, PITCH_RANGE.1, Field::PitchX)?;
        let sy = in_range(c.pitch.1, PITCH_RANGE.0, PITCH_RANGE.1, Field::PitchY)?;
        let (w, h) = c.size;
        if w == 0 {
            return Err(Error::NotPositive(Field::Width));
        }
        if h == 0 {
            return Err(Error::NotPositive(Field::Height));
        }
        if w > MAX_SENSOR_SIDE {
            return Err(Error::OutOfRange(Field::Width));
        }
        if h > MAX_SENSOR_SIDE {
            return Err(Error::OutOfRange(Field::Height));
        }
        let (ox, oy) = c
            .principal_point
            .unwrap_or(((f64::from(w) - 1.0) / 2.0, (f64::from(h) - 1.0) / 2.0));
        let check_pp = |v: f64, field| -> Result<Px, Error> {
            if !v.is_finite() {
                Err(Error::NotFinite(field))
            } else if v < PRINCIPAL_RANGE.0 || v > PRINCIPAL_RANGE.1 {
                Err(Error::OutOfRange(field))
            } else {
                to_fixed(v, field)
            }
        };
        Ok(Intrinsics {
            f: to_fixed(f, Field::FocalLength)?,
            sx: to_fixed(sx, Field::PitchX)?,
            sy: to_fixed(sy, Field::PitchY)?,
            ox: check_pp(ox, Field::PrincipalX)?,
            oy: check_pp(oy, Field::PrincipalY)?,
            width: w,
            height: h,
            inv_sx: to_fixed(1.0 / sx, Field::PitchX)?,
            inv_sy: to_fixed(1.0 / sy, Field::PitchY)?,
            fx: to_fixed(f / sx, Field::FocalLength)?,
            fy: to_fixed(f / sy, Field::FocalLength)?,
            tan_half_fov: (
                (f64::from(w) * sx / (2.0 * f)).to_bits(),
                (f64::from(h) * sy / (2.0 * f)).to_bits(),
            ),
        })
    }

    /// Focal length `f`, metres.
    pub fn focal_length(&self) -> Len {
        self.f
    }
    /// Pixel pitch `(s_x, s_y)`, metres.
    pub fn pitch(&self) -> (Pitch, Pitch) {
        (self.sx, self.sy)
    }
    /// Principal point `(o_x, o_y)`, pixels.
    pub fn principal_point(&self) -> (Px, Px) {
        (self.ox, self.oy)
    }
    /// Sensor size `(W, H)`, pixels.
    pub fn size(&self) -> (u16, u16) {
        (self.width, self.height)
    }
    /// True if the principal point is the sensor's centre across,
    /// `o_x = (W − 1)/2` exactly: column `W − 1 − i` then sees the mirror
    /// image of column `i`'s slopes (the fast loop mirrors a line's rays).
    pub fn is_centred_x(&self) -> bool {
        i64::from(self.ox.to_bits()) * 2 == (i64::from(self.width) - 1) << Px::FRAC_NBITS
    }
    /// Focal length in pixels `(f/s_x, f/s_y)`.
    pub fn focal_px(&self) -> (Gain, Gain) {
        (self.fx, self.fy)
    }

    /// The sensor's half-angles of view, `atan(W s_x / 2f)` and
    /// `atan(H s_y / 2f)`, radians, of the values the camera was built
    /// from (`atan` taken when asked).
    pub fn half_angles_of_view(&self) -> (Angle, Angle) {
        let (x, y) = self.tan_half_fov;
        (half_angle(x), half_angle(y))
    }

    /// Image plane → pixel: `x_im = o_x − x/s_x`, `y_im = o_y − y/s_y`.
    ///
    /// Error ≤ 2⁻¹⁷ px (the rounding into [`Px`]) while the result is within
    /// ±32 768 px; beyond, it saturates and says so.
    pub fn image_to_pixel(&self, p: ImagePoint) -> Sat<PixelPoint> {
        self.image_to_pixel_wide([Wide::of(p.x), Wide::of(p.y)])
    }

    /// Image plane → pixel from a wide image point (for fused chains).
    pub(crate) fn image_to_pixel_wide(&self, p: [Wide; 2]) -> Sat<PixelPoint> {
        let x = Wide::of(self.ox).sub(p[0].mul(Wide::of(self.inv_sx)));
        let y = Wide::of(self.oy).sub(p[1].mul(Wide::of(self.inv_sy)));
        x.narrow::<Px>()
            .zip(y.narrow::<Px>())
            .map(|(x, y)| PixelPoint { x, y })
    }

    /// Pixel → image plane: `x = −(x_im − o_x) s_x`, `y = −(y_im − o_y) s_y`.
    ///
    /// Error ≤ 0.5 pm for every pixel position (|result| < 33 m never
    /// saturates [`Len`]).
    pub fn pixel_to_image(&self, p: PixelPoint) -> Sat<ImagePoint> {
        let x = Wide::of(self.ox).sub(Wide::of(p.x)).mul(Wide::of(self.sx));
        let y = Wide::of(self.oy).sub(Wide::of(p.y)).mul(Wide::of(self.sy));
        x.narrow::<Len>()
            .zip(y.narrow::<Len>())
            .map(|(x, y)| ImagePoint { x, y })
    }

    /// Normalized → pixel: `x_im = o_x − (f/s_x) x̂`.
    ///
    /// Error ≤ 2⁻¹⁷ px while the result is within ±32 768 px; beyond, it
    /// saturates and says so.
    pub fn normalized_to_pixel(&self, p: NormPoint) -> Sat<PixelPoint> {
        let x = Wide::of(self.ox).sub(Wide::of(p.x).mul(Wide::of(self.fx)));
        let y = Wide::of(self.oy).sub(Wide::of(p.y).mul(Wide::of(self.fy)));
        x.narrow::<Px>()
            .zip(y.narrow::<Px>())
            .map(|(x, y)| PixelPoint { x, y })
    }

    /// Pixel → normalized: `x̂ = (o_x − x_im) / (f/s_x)`.
    ///
    /// Error ≤ 2⁻⁴⁸; saturates only when `|x̂|` exceeds 32 768 (a focal
    /// length under 1 px).
    pub fn pixel_to_normalized(&self, p: PixelPoint) -> Sat<NormPoint> {
        let x = quotient::<Norm>(Wide::of(self.ox).sub(Wide::of(p.x)), Wide::of(self.fx));
        let y = quotient::<Norm>(Wide::of(self.oy).sub(Wide::of(p.y)), Wide::of(self.fy));
        x.zip(y).map(|(x, y)| NormPoint { x, y })
    }

    /// Pixel → normalized, not narrowed (for fused chains). `None` only if a
    /// focal length in pixels were zero, which construction rules out.
    pub(crate) fn pixel_to_normalized_wide(&self, p: PixelPoint) -> Option<[Wide; 2]> {
        let x = Wide::of(self.ox)
            .sub(Wide::of(p.x))
            .checked_div(Wide::of(self.fx))?;
        let y = Wide::of(self.oy)
            .sub(Wide::of(p.y))
            .checked_div(Wide::of(self.fy))?;
        Some([x, y])
    }

    /// Image plane → normalized: `x̂ = x/f`.
    pub fn image_to_normalized(&self, p: ImagePoint) -> Sat<NormPoint> {
        let f = Wide::of(self.f);
        quotient::<Norm>(Wide::of(p.x), f)
            .zip(quotient::<Norm>(Wide::of(p.y), f))
            .map(|(x, y)| NormPoint { x, y })
    }

    /// Normalized → image plane: `x = f x̂`.
    pub fn normalized_to_image(&self, p: NormPoint) -> Sat<ImagePoint> {
        let f = Wide::of(self.f);
        Wide::of(p.x)
            .mul(f)
            .narrow::<Len>()
            .zip(Wide::of(p.y).mul(f).narrow::<Len>())
            .map(|(x, y)| ImagePoint { x, y })
    }
}

/// `atan` of a positive, finite tangent given as f64 bits, as an [`Angle`]
/// (in (0, π/2): always representable).
pub(crate) fn half_angle(tan_bits: u64) -> Angle {
    crate::num::from_f64::<Angle>(libm::atan(f64::from_bits(tan_bits))).unwrap_or(Angle::ZERO)
}
