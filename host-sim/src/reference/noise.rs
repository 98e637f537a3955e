//! Reference sensor noise (camera-model.md §9), from the contract and the
//! generator docs/sensor.md documents: EMVA 1288's linear model, the
//! SplitMix64 finaliser keyed by (seed, frame id, pixel, channel), and the
//! normal deviate as the inverse of the normal distribution at the hash's
//! uniform, computed in f64 (Acklam's quantile refined by a Halley step on
//! `erfc`), not from the core's table.

/// A scene's noise parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseModel {
    /// Saturation capacity, e⁻ at full scale.
    pub saturation: f64,
    /// Dark noise, e⁻ rms.
    pub dark_noise: f64,
    /// Dark offset, DN of the first channel.
    pub dark_offset: f64,
    /// Seed.
    pub seed: u64,
}

fn splitmix_final(x: u64) -> u64 {
    let mut z = x;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl NoiseModel {
    /// The standard normal deviate of channel `c` of pixel `p` in frame
    /// `frame`: `±√2 erfc⁻¹(t)` of the hash `h` (docs/sensor.md), `t = v /
    /// 2⁶³` with `v` its low 63 bits with the lowest set, the sign its top
    /// bit.
    pub fn deviate(&self, frame: u32, p: u64, c: u64) -> f64 {
        let key = splitmix_final(self.seed.wrapping_add(splitmix_final(u64::from(frame) + 1)));
        let h = splitmix_final(key ^ (p << 4 | c << 2));
        let z = abs_deviate(uniform_of(h));
        if h >> 63 == 1 {
            -z
        } else {
            z
        }
    }

    /// The recorded DN of a channel whose noise-free value is `mu` DN
    /// (`dn_max` its full scale, `dn_max0` the first channel's).
    pub fn record(&self, mu: f64, dn_max: u32, dn_max0: u32, z: f64) -> u32 {
        let k_sys = f64::from(dn_max) / self.saturation;
        let mu = mu.max(0.0);
        let mu_e = mu / k_sys;
        let n = z * (mu_e + self.dark_noise * self.dark_noise).sqrt();
        let dark = self.dark_offset * f64::from(dn_max) / f64::from(dn_max0);
        let v = (k_sys * (mu_e + n) + dark + 0.5).floor();
        v.clamp(0.0, f64::from(dn_max)) as u32
    }
}

/// The uniform `t` in `[2⁻⁶³, 1)` of a hash `h`: its low 63 bits with the
/// lowest set, over 2⁶³.
pub fn uniform_of(h: u64) -> f64 {
    ((h & (u64::MAX >> 1)) | 1) as f64 / 2f64.powi(63)
}

/// `|z|` with `P(|Z| > |z|) = t` for a standard normal `Z`: `√2 erfc⁻¹(t)`
/// `= −Φ⁻¹(t/2)`, for `t` in `(0, 1]`. Acklam's rational approximation
/// (relative error 1.15·10⁻⁹), then one Halley step on `Φ` (written with
/// `erfc`), to within a few units of f64's last place.
pub fn abs_deviate(t: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e+01,
        2.209460984245205e+02,
        -2.759285104469687e+02,
        1.38357751867269e+02,
        -3.066479806614716e+01,
        2.506628277459239e+00,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e+01,
        1.615858368580409e+02,
        -1.556989798598866e+02,
        6.680131188771972e+01,
        -1.328068155288572e+01,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-03,
        -3.223964580411365e-01,
        -2.400758277161838e+00,
        -2.549732539343734e+00,
        4.374664141464968e+00,
        2.938163982698783e+00,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-03,
        3.224671290700398e-01,
        2.445134137142996e+00,
        3.754408661907416e+00,
    ];
    // Φ⁻¹(p), p = t/2 in (0, ½]: the lower tail, then the centre.
    let p = t / 2.0;
    let horner = |c: &[f64], x: f64| c.iter().fold(0.0, |acc, k| acc * x + k);
    let x = if p < 0.02425 {
        let q = (-2.0 * p.ln()).sqrt();
        horner(&C, q) / (horner(&D, q) * q + 1.0)
    } else {
        let q = p - 0.5;
        let r = q * q;
        horner(&A, r) * q / (horner(&B, r) * r + 1.0)
    };
    // Halley: e = Φ(x) − p, u = e / φ(x).
    let e = 0.5 * libm::erfc(-x / std::f64::consts::SQRT_2) - p;
    let u = e * (2.0 * std::f64::consts::PI).sqrt() * (x * x / 2.0).exp();
    -(x - u / (1.0 + x * u / 2.0))
}

/// The core's table for `|z|` (`hilcam::render::sensor::noise::HALF_NORMAL`), as
/// docs/sensor.md defines it: for octave `e` (0 … 62: `t` in `[2^−(e+1),
/// 2^−e)`, `t = m 2^−(e+1)`) and half `j` (`m` in `[1 + j/2, 1 + (j+1)/2)`),
/// the cubic in `s = 2(m − 1) − j` through [`abs_deviate`] at the four
/// Chebyshev nodes `s_k = (1 + cos(π(2k + 1)/8))/2`, its coefficients (of
/// `1, s, s², s³`) rounded to multiples of 2⁻²⁷.
pub fn half_normal_table() -> Vec<[i32; 4]> {
    let mut table = Vec::new();
    for e in 0..63 {
        for j in 0..2 {
            let nodes: Vec<f64> = (0..4)
                .map(|k| (1.0 + (std::f64::consts::PI * (2 * k + 1) as f64 / 8.0).cos()) / 2.0)
                .collect();
            let values: Vec<f64> = nodes
                .iter()
                .map(|s| {
                    let m = 1.0 + (j as f64 + s) / 2.0;
                    abs_deviate(m * 2f64.powi(-(e + 1)))
                })
                .collect();
            // Newton's divided differences, then the powers of s.
            let mut dd = values.clone();
            for level in 1..4 {
                for k in (level..4).rev() {
                    dd[k] = (dd[k] - dd[k - 1]) / (nodes[k] - nodes[k - level]);
                }
            }
            let mut poly = [0.0f64; 4];
            for k in (0..4).rev() {
                // poly = poly · (s − nodes[k]) + dd[k]
                let mut next = [0.0f64; 4];
                for i in 0..4 {
                    if i + 1 < 4 {
                        next[i + 1] += poly[i];
                    }
                    next[i] -= poly[i] * nodes[k];
                }
                next[0] += dd[k];
                poly = next;
            }
            table.push(poly.map(|c| (c * 2f64.powi(27)).round() as i32));
        }
    }
    table
}
