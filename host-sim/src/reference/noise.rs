//! Reference sensor noise (camera-model.md §9), from the contract and the
//! generator docs/sensor.md documents: EMVA 1288's linear model, the
//! SplitMix64 finaliser keyed by (seed, frame id, pixel, channel), and the
//! sum of twelve 16-bit uniforms as the normal deviate.

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
    /// `frame`.
    pub fn deviate(&self, frame: u32, p: u64, c: u64) -> f64 {
        let key = splitmix_final(self.seed.wrapping_add(splitmix_final(u64::from(frame) + 1)));
        let mut sum = 0u64;
        for k in 0..3 {
            let h = splitmix_final(key ^ (p << 4 | c << 2 | k));
            sum += (0..4).map(|w| (h >> (16 * w)) & 0xffff).sum::<u64>();
        }
        (sum as f64 - 393_210.0) / 65_536.0
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
