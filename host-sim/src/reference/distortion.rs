//! Reference radial distortion (camera-model.md §3): the polynomial itself,
//! its fold, and the inverse by bisection on the monotonic branch.

/// `k1`, `k2` in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Radial {
    /// `k1` (positive: barrel).
    pub k1: f64,
    /// `k2`.
    pub k2: f64,
}

impl Radial {
    /// `g(u) = 1 + k1 u + k2 u²`.
    pub fn g(&self, u: f64) -> f64 {
        1.0 + self.k1 * u + self.k2 * u * u
    }

    /// The first `u = r_d² > 0` where `d r_u / d r_d = 1 + 3 k1 u + 5 k2 u²`
    /// reaches zero, if any.
    pub fn fold_u(&self) -> Option<f64> {
        let (a, b) = (5.0 * self.k2, 3.0 * self.k1);
        let mut roots = Vec::new();
        if a == 0.0 {
            if b != 0.0 {
                roots.push(-1.0 / b);
            }
        } else {
            let disc = b * b - 4.0 * a;
            if disc >= 0.0 {
                roots.push((-b - disc.sqrt()) / (2.0 * a));
                roots.push((-b + disc.sqrt()) / (2.0 * a));
            }
        }
        roots
            .into_iter()
            .filter(|u| *u > 0.0)
            .fold(None, |m, u| Some(m.map_or(u, |m: f64| m.min(u))))
    }

    /// The relative illumination at distorted `(x̂_d, ŷ_d)` (camera-model.md
    /// §5): `J = det ∂(x̂, ŷ)/∂(x̂_d, ŷ_d)`, the undistorted area a unit of
    /// distorted area receives the flux of. From the mapping's partial
    /// derivatives, `∂x̂/∂x̂_d = g + 2 x̂_d² g'`, `∂x̂/∂ŷ_d = ∂ŷ/∂x̂_d =
    /// 2 x̂_d ŷ_d g'`, `∂ŷ/∂ŷ_d = g + 2 ŷ_d² g'` (`g' = dg/du`).
    pub fn area_factor(&self, xd: f64, yd: f64) -> f64 {
        let u = xd * xd + yd * yd;
        let (g, dg) = (self.g(u), self.k1 + 2.0 * self.k2 * u);
        let (a, b, d) = (g + 2.0 * xd * xd * dg, 2.0 * xd * yd * dg, g + 2.0 * yd * yd * dg);
        a * d - b * b
    }

    /// Distorted → undistorted; `None` beyond the fold.
    pub fn undistort(&self, xd: f64, yd: f64) -> Option<(f64, f64)> {
        let u = xd * xd + yd * yd;
        if self.fold_u().is_some_and(|f| u > f) {
            return None;
        }
        let g = self.g(u);
        Some((xd * g, yd * g))
    }

    /// Undistorted → distorted by bisection of `r_u = r_d g(r_d²)` on
    /// `[0, r_fold]` (or a doubling bracket without a fold); `None` when
    /// `r_u` is beyond the fold's image.
    pub fn distort(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let ru = (x * x + y * y).sqrt();
        if ru == 0.0 {
            return Some((0.0, 0.0));
        }
        let h = |r: f64| r * self.g(r * r);
        let mut hi = match self.fold_u() {
            Some(f) => f.sqrt(),
            None => {
                let mut r = ru.max(1.0);
                while h(r) < ru {
                    r *= 2.0;
                    if !r.is_finite() {
                        return None;
                    }
                }
                r
            }
        };
        if h(hi) < ru {
            return None;
        }
        let mut lo = 0.0;
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if h(mid) < ru {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let rd = 0.5 * (lo + hi);
        Some((x * rd / ru, y * rd / ru))
    }
}
