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

/// A calibrated lens as OpenCV states it (docs/scenes.md "Your own lens"),
/// undistorted → distorted in OpenCV's axes (x right, y down; the
/// contract's normalized coordinates are their negatives).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lens {
    /// OpenCV's standard model `[k1, k2, p1, p2, k3, k4, k5, k6, s1, s2,
    /// s3, s4]`.
    OpenCv([f64; 12]),
    /// OpenCV's fisheye model `[k1, k2, k3, k4]`.
    Fisheye([f64; 4]),
}

/// The valid field's largest undistorted radius (the renderer's reach).
const REACH: f64 = 16.0;

impl Lens {
    /// OpenCV's mapping in its own axes: `cv2.projectPoints` /
    /// `cv2.fisheye.projectPoints` of a point at `(x, y, 1)`.
    pub fn forward_cv(&self, x: f64, y: f64) -> (f64, f64) {
        let u = x * x + y * y;
        match *self {
            Lens::OpenCv([k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4]) => {
                let radial = (1.0 + k1 * u + k2 * u * u + k3 * u * u * u)
                    / (1.0 + k4 * u + k5 * u * u + k6 * u * u * u);
                (
                    x * radial + 2.0 * p1 * x * y + p2 * (u + 2.0 * x * x) + s1 * u + s2 * u * u,
                    y * radial + p1 * (u + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * u + s4 * u * u,
                )
            }
            Lens::Fisheye(k) => {
                let r = u.sqrt();
                if r == 0.0 {
                    return (x, y);
                }
                let t = r.atan();
                let td = theta_d(&k, t);
                (x * td / r, y * td / r)
            }
        }
    }

    /// The forward map's Jacobian determinant `det ∂(x_d, y_d)/∂(x, y)` by
    /// central differences.
    fn forward_det(&self, x: f64, y: f64) -> f64 {
        let h = 1e-6 * (1.0 + x.abs().max(y.abs()));
        let (a, c) = {
            let (p, q) = (self.forward_cv(x + h, y), self.forward_cv(x - h, y));
            ((p.0 - q.0) / (2.0 * h), (p.1 - q.1) / (2.0 * h))
        };
        let (b, d) = {
            let (p, q) = (self.forward_cv(x, y + h), self.forward_cv(x, y - h));
            ((p.0 - q.0) / (2.0 * h), (p.1 - q.1) / (2.0 * h))
        };
        a * d - b * c
    }

    /// The valid field's edge: the first undistorted radius where the
    /// radial map `r ↦ r R(r²)` (OpenCV) or `θ ↦ θ_d` (fisheye) stops
    /// increasing, or the reach; scanned at 10⁻⁵ and refined by bisection.
    pub fn valid_radius(&self) -> f64 {
        let bad = |r: f64| match *self {
            Lens::OpenCv(c) => {
                let q = |r: f64| {
                    let u = r * r;
                    (
                        1.0 + c[0] * u + c[1] * u * u + c[4] * u * u * u,
                        1.0 + c[5] * u + c[6] * u * u + c[7] * u * u * u,
                    )
                };
                let (n, d) = q(r);
                let h = 1e-7;
                let (n2, d2) = q(r + h);
                d <= 0.0 || (r + h) * n2 / d2 - r * n / d <= 0.0
            }
            Lens::Fisheye(k) => {
                let t = r.atan();
                let h = 1e-7;
                theta_d(&k, t + h) - theta_d(&k, t) <= 0.0
            }
        };
        let mut r = 0.0;
        while r < REACH {
            let next = (r + 1e-5).min(REACH);
            if bad(next) {
                let (mut lo, mut hi) = (r, next);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if bad(mid) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return lo;
            }
            r = next;
        }
        REACH
    }

    /// Distorted → undistorted (the contract's axes) and the area factor
    /// `J = 1 / det ∂(x_d, y_d)/∂(x, y)` there; `None` outside the valid
    /// field (`r_max` from [`Lens::valid_radius`]). OpenCV's model by
    /// Newton's method on a finite-difference Jacobian to 10⁻¹⁴; the
    /// fisheye's `θ` by bisection.
    pub fn undistort(&self, xd: f64, yd: f64, r_max: f64) -> Option<(f64, f64, f64)> {
        let (tx, ty) = (-xd, -yd);
        let (x, y) = match *self {
            Lens::OpenCv(_) => {
                // Damped Newton: a step is halved until it lowers the
                // residual inside the valid field.
                let residual = |x: f64, y: f64| {
                    let (fx, fy) = self.forward_cv(x, y);
                    ((tx - fx).hypot(ty - fy), fx, fy)
                };
                // From the radial part's own inverse (tangential and prism
                // terms left out: `r R(r²) = r_d` by bisection on the valid
                // field, where it increases), then the full model.
                let rd = tx.hypot(ty);
                let Lens::OpenCv(c) = *self else { return None };
                let radial = |r: f64| {
                    let u = r * r;
                    r * (1.0 + c[0] * u + c[1] * u * u + c[4] * u * u * u)
                        / (1.0 + c[5] * u + c[6] * u * u + c[7] * u * u * u)
                };
                let (mut lo, mut hi) = (0.0, r_max);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if radial(mid) < rd {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let scale = if rd > 0.0 { 0.5 * (lo + hi) / rd } else { 1.0 };
                let (mut x, mut y) = (tx * scale, ty * scale);
                let mut done = false;
                for _ in 0..400 {
                    let (res, fx, fy) = residual(x, y);
                    if res < 1e-14 {
                        done = true;
                        break;
                    }
                    let (ex, ey) = (tx - fx, ty - fy);
                    // Central differences.
                    let h = 1e-6 * (1.0 + x.abs().max(y.abs()));
                    let ((px, py), (mx, my)) = (self.forward_cv(x + h, y), self.forward_cv(x - h, y));
                    let ((qx, qy), (nx, ny)) = (self.forward_cv(x, y + h), self.forward_cv(x, y - h));
                    let (a, c) = ((px - mx) / (2.0 * h), (py - my) / (2.0 * h));
                    let (b, d) = ((qx - nx) / (2.0 * h), (qy - ny) / (2.0 * h));
                    let det = a * d - b * c;
                    if det.is_nan() || det <= 0.0 {
                        return None;
                    }
                    let (sx, sy) = ((d * ex - b * ey) / det, (a * ey - c * ex) / det);
                    let mut t = 1.0;
                    loop {
                        let (nx, ny) = (x + t * sx, y + t * sy);
                        if nx.hypot(ny) <= r_max && residual(nx, ny).0 < res {
                            (x, y) = (nx, ny);
                            break;
                        }
                        t *= 0.5;
                        if t < 1e-12 {
                            // No step lowers it: as close as f64 gets.
                            done = res < 1e-12;
                            break;
                        }
                    }
                    if t < 1e-12 {
                        break;
                    }
                }
                if !done || x.hypot(y) > r_max {
                    return None;
                }
                (x, y)
            }
            Lens::Fisheye(k) => {
                let td = tx.hypot(ty);
                let t_max = r_max.atan();
                if td > theta_d(&k, t_max) {
                    return None;
                }
                if td == 0.0 {
                    (tx, ty)
                } else {
                    let (mut lo, mut hi) = (0.0, t_max);
                    for _ in 0..200 {
                        let mid = 0.5 * (lo + hi);
                        if theta_d(&k, mid) < td {
                            lo = mid;
                        } else {
                            hi = mid;
                        }
                    }
                    let ru = (0.5 * (lo + hi)).tan();
                    (tx * ru / td, ty * ru / td)
                }
            }
        };
        let det = self.forward_det(x, y);
        (det > 0.0).then(|| (-x, -y, 1.0 / det))
    }
}

/// The fisheye's `θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`.
fn theta_d(k: &[f64; 4], t: f64) -> f64 {
    let t2 = t * t;
    t * (1.0 + k[0] * t2 + k[1] * t2 * t2 + k[2] * t2 * t2 * t2 + k[3] * t2 * t2 * t2 * t2)
}
