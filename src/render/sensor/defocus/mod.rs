//! Defocus (camera-model.md §8): the aperture pattern and the planner's
//! rule for its size.
//!
//! A sample of undistorted slopes `(x̂, ŷ)` is lit through the aperture
//! disc (diameter `d`, centred on the lens): the ray from aperture point
//! `A = (a_x, a_y, 0)` through `F = Z̃ (x̂, ŷ, 1)` on the plane in focus,
//! i.e. origin `A`, direction `(x̂ − a_x/Z̃, ŷ − a_y/Z̃, 1)`. The sample's
//! radiance is the mean over the pattern's `m` points; `cos⁴α` is the chief
//! ray's.
//!
//! **Pattern** (docs/sensor.md): the Vogel (sunflower) spiral — point `k` of
//! `m` at radius `(d/2) √((k + ½)/m)` and angle `k γ`, `γ = π (3 − √5)` —
//! for `m` ∈ {16, 64, 256}. Its points cover the disc evenly (equal areas
//! per point) and its second moment is the disc's, so an edge's spread is
//! the disc's for every `m`. One table of the `m = 256` spiral on the unit
//! disc (i16, units of 2⁻¹⁵: within 1.5·10⁻⁵ of the radius) serves all
//! three: the first `m` points scaled by `√(256/m)`, a shift. The
//! reference computes the spiral from the formula.
//!
//! **Rule** (the planner's): the aperture is sampled when content in view
//! lies outside the depth of field (`b(Ẑ) > b̃`, §4) — a frame whose
//! content all lies within it pays nothing — with the smallest `m` whose
//! placement error ([`placement`]) times the largest blur in view, pixels,
//! is within the edge budget and whose spread error ([`spread`]) is within
//! `SPREAD_BUDGET`.

mod table;

pub use table::SPIRAL;

/// The aperture pattern sizes, smallest first.
pub(crate) const SIZES: [u16; 3] = [16, 64, 256];

/// Most aperture points (the table's length).
pub(crate) const MAX_POINTS: usize = 256;

/// The pattern's placement error as a fraction of the blur diameter, for
/// [`SIZES`]: over edge directions every 0.5°, the largest distance, along
/// the edge normal, between the edge-spread staircase of the pattern's
/// points and the uniform disc's edge-spread function at the same level
/// (measured by `tests::placement_is_measured`).
const PLACEMENT: [f64; 3] = [0.1524, 0.0604, 0.0243];

/// The pattern's spread error for [`SIZES`]: over edge directions every
/// 0.5°, the largest `|σ_θ / σ − 1|`, `σ_θ` the RMS of the points'
/// projections on the direction and `σ = r/2` the disc's — an edge spread
/// measured as `4σ_θ` is off the blur circle by this fraction (measured by
/// `tests::spread_is_measured`).
const SPREAD: [f64; 3] = [0.0491, 0.0117, 0.0030];

/// The largest spread error the planner accepts: an edge's measured spread
/// within 2 % of its blur circle.
pub(crate) const SPREAD_BUDGET: f64 = 0.02;

/// The spread error of the `m`-point pattern (1 for a size not in
/// `SIZES`).
pub fn spread(m: u16) -> f64 {
    of_size(SPREAD, m)
}

/// The placement error of the `m`-point pattern, as a fraction of the blur
/// diameter (1 for a size not in `SIZES`).
pub fn placement(m: u16) -> f64 {
    of_size(PLACEMENT, m)
}

/// `table`'s entry for the pattern size `m` (1 for a size not in [`SIZES`]).
fn of_size(table: [f64; 3], m: u16) -> f64 {
    SIZES
        .iter()
        .zip(table)
        .find(|(s, _)| **s == m)
        .map_or(1.0, |(_, p)| p)
}

/// The smallest pattern whose placement error for a blur of `blur_px`
/// pixels is within `budget_px` and whose spread error is within
/// [`SPREAD_BUDGET`] (the largest if none is).
pub(crate) fn points_for(blur_px: f64, budget_px: f64) -> u16 {
    SIZES
        .into_iter()
        .find(|m| placement(*m) * blur_px <= budget_px && spread(*m) <= SPREAD_BUDGET)
        .unwrap_or(MAX_POINTS as u16)
}

/// Whether `m` is a pattern size.
pub fn is_size(m: u16) -> bool {
    SIZES.contains(&m)
}

/// The left shift that takes a [`SPIRAL`] entry (2⁻¹⁵ units, the 256-point
/// spiral) to point `k` of the `m`-point spiral in I32F32 bits: `17 +
/// log2 √(256/m)`.
pub fn shift(m: u16) -> u32 {
    17 + (4 - (m.max(1).trailing_zeros() / 2).min(4))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spiral(m: usize) -> Vec<(f64, f64)> {
        let g = core::f64::consts::PI * (3.0 - libm::sqrt(5.0));
        (0..m)
            .map(|k| {
                let r = libm::sqrt((k as f64 + 0.5) / m as f64);
                (r * libm::cos(k as f64 * g), r * libm::sin(k as f64 * g))
            })
            .collect()
    }

    #[test]
    fn table_is_the_spiral() {
        for (t, (x, y)) in SPIRAL.iter().zip(spiral(256)) {
            let s = libm::ldexp(1.0, 15);
            assert!((f64::from(t[0]) - x * s).abs() <= 1.0 && (f64::from(t[1]) - y * s).abs() <= 1.0);
        }
        // The m-point spiral is the table's first m points, shifted.
        for m in SIZES {
            for (k, (x, _)) in spiral(m as usize).into_iter().enumerate() {
                let q = (i64::from(SPIRAL[k][0]) << shift(m)) as f64 / libm::ldexp(1.0, 32);
                assert!((q - x).abs() <= libm::ldexp(1.0, -13), "m {m} k {k}");
            }
        }
    }

    /// The disc's edge-spread function inverted: the `x` (radius 1) left of
    /// which a fraction `l` of the disc's area lies.
    fn esf_inverse(l: f64) -> f64 {
        let (mut lo, mut hi) = (-1.0f64, 1.0f64);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            let f = 0.5 + (m * libm::sqrt(1.0 - m * m) + libm::asin(m)) / core::f64::consts::PI;
            if f < l {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    }

    #[test]
    fn spread_is_measured() {
        for (m, want) in SIZES.into_iter().zip(SPREAD) {
            let pts = spiral(m as usize);
            let mut worst: f64 = 0.0;
            for t in 0..360 {
                let th = core::f64::consts::PI * f64::from(t) / 360.0;
                let v = pts
                    .iter()
                    .map(|(x, y)| (x * libm::cos(th) + y * libm::sin(th)).powi(2))
                    .sum::<f64>()
                    / f64::from(m);
                worst = worst.max((libm::sqrt(v / 0.25) - 1.0).abs());
            }
            assert!(worst <= want && worst > want - 1e-3, "m {m}: {worst}");
        }
    }

    #[test]
    fn placement_is_measured() {
        for (m, want) in SIZES.into_iter().zip(PLACEMENT) {
            let pts = spiral(m as usize);
            let inv: Vec<f64> = (0..=m)
                .map(|k| esf_inverse(f64::from(k) / f64::from(m)))
                .collect();
            let mut worst: f64 = 0.0;
            for t in 0..360 {
                let th = core::f64::consts::PI * f64::from(t) / 360.0;
                let mut p: Vec<f64> = pts
                    .iter()
                    .map(|(x, y)| x * libm::cos(th) + y * libm::sin(th))
                    .collect();
                p.sort_by(f64::total_cmp);
                for (k, v) in p.iter().enumerate() {
                    worst = worst.max((v - inv[k]).abs()).max((v - inv[k + 1]).abs());
                }
            }
            // Radius 1: the diameter is 2.
            let got = worst / 2.0;
            assert!(got <= want && got > want - 1e-3, "m {m}: {got}");
        }
        assert_eq!(points_for(3.0, 0.5), 64);
        assert_eq!(points_for(8.0, 0.5), 64);
        assert_eq!(points_for(20.0, 0.5), 256);
        assert_eq!(points_for(1e9, 0.5), 256);
    }
}
