//! Reference intrinsics: `x = −(x_im − o_x) s_x`, `y = −(y_im − o_y) s_y`
//! (camera-model.md §1).

/// Sensor and focal length in f64 (SI units, pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// Focal length, metres.
    pub f: f64,
    /// Pixel pitch, metres.
    pub sx: f64,
    /// Pixel pitch, metres.
    pub sy: f64,
    /// Principal point, pixels.
    pub ox: f64,
    /// Principal point, pixels.
    pub oy: f64,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

impl Sensor {
    /// With the principal point at the sensor centre `((W−1)/2, (H−1)/2)`.
    pub fn centred(f: f64, sx: f64, sy: f64, width: u32, height: u32) -> Sensor {
        Sensor {
            f,
            sx,
            sy,
            ox: (width as f64 - 1.0) / 2.0,
            oy: (height as f64 - 1.0) / 2.0,
            width,
            height,
        }
    }

    /// Image plane (metres) → pixel.
    pub fn image_to_pixel(&self, x: f64, y: f64) -> (f64, f64) {
        (self.ox - x / self.sx, self.oy - y / self.sy)
    }

    /// Pixel → image plane (metres).
    pub fn pixel_to_image(&self, xi: f64, yi: f64) -> (f64, f64) {
        (-(xi - self.ox) * self.sx, -(yi - self.oy) * self.sy)
    }

    /// Pixel → normalized (`x̂ = x / f`).
    pub fn pixel_to_normalized(&self, xi: f64, yi: f64) -> (f64, f64) {
        let (x, y) = self.pixel_to_image(xi, yi);
        (x / self.f, y / self.f)
    }

    /// Normalized → pixel.
    pub fn normalized_to_pixel(&self, xn: f64, yn: f64) -> (f64, f64) {
        self.image_to_pixel(xn * self.f, yn * self.f)
    }

    /// The sensor's half-angles of view, radians.
    pub fn half_angles_of_view(&self) -> (f64, f64) {
        (
            (self.width as f64 * self.sx / (2.0 * self.f)).atan(),
            (self.height as f64 * self.sy / (2.0 * self.f)).atan(),
        )
    }
}
