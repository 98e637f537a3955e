//! Reference defocus (camera-model.md §8), written from the contract and
//! docs/sensor.md: a sample is lit through the aperture disc, each ray from
//! an aperture point through the sample's point on the plane in focus;
//! the aperture's points are the Vogel spiral.

/// Aperture points of the converged estimate the defocus error is
/// measured against.
pub const CONVERGED: u16 = 1024;

/// The `m`-point Vogel spiral on the unit disc: point `k` at radius
/// `√((k + ½)/m)` and angle `k π (3 − √5)`.
pub fn spiral(m: u16) -> Vec<(f64, f64)> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let m = f64::from(m);
    (0..m as usize)
        .map(|k| {
            let k = k as f64;
            let r = ((k + 0.5) / m).sqrt();
            (r * (k * golden).cos(), r * (k * golden).sin())
        })
        .collect()
}

/// The blur-circle diameter `β = d |1/Z − 1/Z̃|` of a point at depth `z`
/// (normalized units; times `f/s` for pixels).
pub fn blur(diameter: f64, focus: f64, z: f64) -> f64 {
    diameter * (1.0 / z - 1.0 / focus).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spiral_covers_the_disc_like_the_disc() {
        for m in [16u16, 64, 256, 1024] {
            let p = spiral(m);
            let n = f64::from(m);
            // Second moment r²: the disc's 1/2 exactly; x², y²: 1/4.
            let r2 = p.iter().map(|(x, y)| x * x + y * y).sum::<f64>() / n;
            let x2 = p.iter().map(|(x, _)| x * x).sum::<f64>() / n;
            assert!((r2 - 0.5).abs() < 1e-12, "{m}: {r2}");
            assert!((x2 - 0.25).abs() < 0.25 * 0.1, "{m}: {x2}");
            assert!(p.iter().all(|(x, y)| x * x + y * y < 1.0));
        }
    }
}
