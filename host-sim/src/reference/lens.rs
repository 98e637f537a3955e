//! Reference thin lens (camera-model.md §4), formulas as the contract writes
//! them.

/// A thin lens in f64 (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// Focal length.
    pub f: f64,
    /// Effective aperture diameter.
    pub d: f64,
    /// Focus distance `Z̃`.
    pub focus: f64,
    /// Tolerable blur `b̃`.
    pub blur: f64,
}

impl ThinLens {
    /// `N = f / d`.
    pub fn f_number(&self) -> f64 {
        self.f / self.d
    }

    /// `w = atan(d / 2f)`.
    pub fn aperture_half_angle(&self) -> f64 {
        (self.d / (2.0 * self.f)).atan()
    }

    /// From `1/f = 1/ẑ + 1/Ẑ`; `None` when `Ẑ ≤ f`.
    pub fn image_distance(&self, z_obj: f64) -> Option<f64> {
        (z_obj > self.f).then(|| 1.0 / (1.0 / self.f - 1.0 / z_obj))
    }

    /// Newtonian: `z = f² / Z`; `None` when `Z ≤ 0`.
    pub fn image_distance_newtonian(&self, z: f64) -> Option<f64> {
        (z > 0.0).then(|| self.f * self.f / z)
    }

    /// `ẑ' = f Z̃ / (Z̃ − f)`.
    pub fn sensor_distance(&self) -> f64 {
        self.f * self.focus / (self.focus - self.f)
    }

    /// `b(Ẑ) = d |ẑ' − ẑ(Ẑ)| / ẑ'`.
    pub fn blur_diameter(&self, z_obj: f64) -> Option<f64> {
        let zs = self.sensor_distance();
        self.image_distance(z_obj).map(|zi| self.d * (zs - zi).abs() / zs)
    }

    /// `d f / b̃`.
    pub fn hyperfocal_distance(&self) -> f64 {
        self.d * self.f / self.blur
    }

    /// `Ẑ_n = Z̃ f (d + b̃) / (d f + b̃ Z̃)`.
    pub fn near(&self) -> f64 {
        let (f, d, z, b) = (self.f, self.d, self.focus, self.blur);
        z * f * (d + b) / (d * f + b * z)
    }

    /// `Ẑ_f = Z̃ f (d − b̃) / (d f − b̃ Z̃)`; `None` (infinite) when the
    /// denominator is ≤ 0.
    pub fn far(&self) -> Option<f64> {
        let (f, d, z, b) = (self.f, self.d, self.focus, self.blur);
        let den = d * f - b * z;
        (den > 0.0).then(|| z * f * (d - b) / den)
    }
}
