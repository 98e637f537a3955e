//! A calibrated lens as OpenCV states it (camera-model.md §3, §5;
//! docs/scenes.md "Your own lens"): the model maps an *undistorted*
//! normalized point to the *distorted* one where the lens images it —
//! OpenCV's direction, the opposite of this crate's radial
//! [`crate::geom::distortion::Distortion`].
//!
//! - [`Calibrated::OpenCv`]: OpenCV's standard model. With `u = x² + y²`,
//!   `R = (1 + k1 u + k2 u² + k3 u³) / (1 + k4 u + k5 u² + k6 u³)`:
//!   `x_d = x R + 2 p1 x y + p2 (u + 2x²) + s1 u + s2 u²`,
//!   `y_d = y R + p1 (u + 2y²) + 2 p2 x y + s3 u + s4 u²`.
//! - [`Calibrated::Fisheye`]: Kannala–Brandt as `cv2.fisheye` has it:
//!   `θ = atan r`, `θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`,
//!   `x_d = (θ_d / r) x`.
//!
//! Both are written in OpenCV's axes (x right, y down). This crate's
//! normalized coordinates point the other way on both axes (`x̂ = −x`,
//! `ŷ = −y`: camera-model.md §1), so a point is negated on the way in and
//! out; the Jacobian's determinant, the relative illumination's area factor
//! `J` (§5), is the same in both.
//!
//! The renderer needs the inverse at every sample. [`Model::undistort`]
//! solves it by Newton's method from the distorted point itself (the
//! fisheye's in one dimension, `θ` from `θ_d`), in the renderer's
//! [`Scalar`]; a step below `2⁻²¹ (1 + |x| + |y|)` ends it (the next one
//! would be below its square). Valid field: where the model is monotonic —
//! OpenCV's up to the first radius where `d(r R)/dr` or the denominator
//! reaches 0 (scanned at construction), the fisheye's up to the first `θ`
//! where `dθ_d/dθ` does — and the renderer's reach (`|x̂|, |ŷ| ≤ 16`). A
//! sample outside it, or whose solve does not converge, or where the
//! Jacobian's determinant is not positive, is outside the lens field:
//! flagged, as past a radial lens's fold.

use crate::geom::error::{Error, Field};
use crate::num::scalar::Scalar;
use crate::num::{from_f64, FixedF64, Norm};
use fixed::types::I32F32 as Q;

/// Largest `|coefficient|` accepted (OpenCV's calibrations of real lenses
/// stay far below; rational models' `k4`–`k6` reach the hundreds).
pub const COEFF_MAX: f64 = 1.0e4;
/// Most Newton steps a sample takes before it is declared outside the field.
pub const NEWTON_STEPS: u32 = 16;
/// The valid field's largest undistorted radius, the renderer's reach in
/// slope (`render::MAX_SLOPE`): `|x̂|, |ŷ| ≤ 16` within it.
pub const REACH: f64 = 16.0;

/// A calibrated lens model (coefficients as OpenCV orders them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Calibrated {
    /// OpenCV's standard model.
    OpenCv {
        /// `k1 … k6` (rational radial; `k4 … k6` the denominator's).
        k: [Norm; 6],
        /// `p1, p2` (tangential).
        p: [Norm; 2],
        /// `s1 … s4` (thin prism).
        s: [Norm; 4],
        /// `u = r²` of the valid field's edge (undistorted).
        u_valid: Norm,
    },
    /// OpenCV's fisheye (Kannala–Brandt) model.
    Fisheye {
        /// `k1 … k4`.
        k: [Norm; 4],
        /// `θ` of the valid field's edge, radians.
        theta_valid: Norm,
        /// `θ_d` there (the distorted radius).
        theta_d_valid: Norm,
    },
}

/// OpenCV's radial ratio `R(u)` and its derivative in `u`, f64.
fn radial(k: &[f64; 6], u: f64) -> (f64, f64, f64) {
    let n = 1.0 + u * (k[0] + u * (k[1] + u * k[2]));
    let d = 1.0 + u * (k[3] + u * (k[4] + u * k[5]));
    let dn = k[0] + u * (2.0 * k[1] + 3.0 * k[2] * u);
    let dd = k[3] + u * (2.0 * k[4] + 3.0 * k[5] * u);
    (n, d, (dn * d - n * dd) / (d * d))
}

/// The fisheye's `θ_d(θ)` and its derivative, f64.
fn fisheye_f64(k: &[f64; 4], t: f64) -> (f64, f64) {
    let t2 = t * t;
    let p = t * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
    let dp = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
    (p, dp)
}

/// The first `x` in `(0, end]` where `bad(x)` holds, scanned in 4 096
/// steps and refined by bisection to 2⁻⁴⁰ of `end`; `end` if none.
fn first_bad(end: f64, bad: impl Fn(f64) -> bool) -> f64 {
    const STEPS: u32 = 4096;
    let mut prev = 0.0;
    for i in 1..=STEPS {
        let x = end * f64::from(i) / f64::from(STEPS);
        if bad(x) {
            let (mut lo, mut hi) = (prev, x);
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if bad(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return lo;
        }
        prev = x;
    }
    end
}

fn norm(v: f64) -> Result<Norm, Error> {
    if !v.is_finite() {
        return Err(Error::NotFinite(Field::Calibrated));
    }
    if libm::fabs(v) > COEFF_MAX {
        return Err(Error::OutOfRange(Field::Calibrated));
    }
    from_f64::<Norm>(v).ok_or(Error::OutOfRange(Field::Calibrated))
}

impl Calibrated {
    /// OpenCV's standard model from `[k1, k2, p1, p2, k3, k4, k5, k6, s1,
    /// s2, s3, s4]` (OpenCV's order; a shorter calibration's missing terms
    /// are 0), each finite and within ±[`COEFF_MAX`].
    pub fn opencv(c: [f64; 12]) -> Result<Calibrated, Error> {
        let [k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4] = c;
        let k = [k1, k2, k3, k4, k5, k6].map(norm);
        let p = [p1, p2].map(norm);
        let s = [s1, s2, s3, s4].map(norm);
        let k = [k[0]?, k[1]?, k[2]?, k[3]?, k[4]?, k[5]?];
        let (p, s) = ([p[0]?, p[1]?], [s[0]?, s[1]?, s[2]?, s[3]?]);
        // The field from the stored (rounded) coefficients.
        let kf = k.map(|v| v.f64());
        // d(r R)/dr = R + 2u R' ≤ 0, or the denominator ≤ 0: the lens folds.
        let r = first_bad(REACH, |r| {
            let u = r * r;
            let (n, d, dr) = radial(&kf, u);
            d <= 0.0 || n / d + 2.0 * u * dr <= 0.0
        });
        let u_valid = from_f64::<Norm>(r * r).unwrap_or(Norm::MAX);
        Ok(Calibrated::OpenCv { k, p, s, u_valid })
    }

    /// OpenCV's fisheye model from `[k1, k2, k3, k4]`.
    pub fn fisheye(c: [f64; 4]) -> Result<Calibrated, Error> {
        let k = c.map(norm);
        let k = [k[0]?, k[1]?, k[2]?, k[3]?];
        let kf = k.map(|v| v.f64());
        let reach = libm::atan(REACH);
        let t = first_bad(reach, |t| fisheye_f64(&kf, t).1 <= 0.0);
        let theta_d = fisheye_f64(&kf, t).0;
        Ok(Calibrated::Fisheye {
            k,
            theta_valid: from_f64::<Norm>(t).unwrap_or(Norm::MAX),
            theta_d_valid: from_f64::<Norm>(theta_d).unwrap_or(Norm::MAX),
        })
    }

    /// The model's constants in the renderer's scalar `S` (once a frame).
    pub fn to<S: Scalar>(&self) -> Model<S> {
        let s = |v: Norm| S::from_q(Q::saturating_from_num(v));
        match *self {
            Calibrated::OpenCv {
                k,
                p,
                s: prism,
                u_valid,
            } => Model::OpenCv {
                k: k.map(s),
                p: p.map(s),
                s: prism.map(s),
                u_valid: s(u_valid),
            },
            Calibrated::Fisheye {
                k,
                theta_valid,
                theta_d_valid,
            } => Model::Fisheye {
                k: k.map(s),
                theta_valid: s(theta_valid),
                theta_d_valid: s(theta_d_valid),
            },
        }
    }

    /// The distorted point (this crate's normalized coordinates) of the
    /// undistorted `(x̂, ŷ)`, f64: the model as written, for ground truth
    /// and tests; `None` outside the valid field.
    pub fn distort_f64(&self, (x, y): (f64, f64)) -> Option<(f64, f64)> {
        let (x, y) = (-x, -y);
        let u = x * x + y * y;
        match self {
            Calibrated::OpenCv { k, p, s, u_valid } => {
                if u > u_valid.f64() {
                    return None;
                }
                let kf = k.map(|v| v.f64());
                let ([p1, p2], [s1, s2, s3, s4]) = (p.map(|v| v.f64()), s.map(|v| v.f64()));
                let (n, d, _) = radial(&kf, u);
                let r = n / d;
                let xd = x * r + 2.0 * p1 * x * y + p2 * (u + 2.0 * x * x) + s1 * u + s2 * u * u;
                let yd = y * r + p1 * (u + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * u + s4 * u * u;
                Some((-xd, -yd))
            }
            Calibrated::Fisheye { k, theta_valid, .. } => {
                let r = libm::sqrt(u);
                let t = libm::atan(r);
                if t > theta_valid.f64() {
                    return None;
                }
                if r == 0.0 {
                    return Some((-x, -y));
                }
                let (td, _) = fisheye_f64(&k.map(|v| v.f64()), t);
                Some((-x * td / r, -y * td / r))
            }
        }
    }
}

/// What a calibrated lens makes of a distorted field `|x̂_d| ≤ X`,
/// `|ŷ_d| ≤ Y` ([`Calibrated::extent`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    /// Largest `|x̂|`, `|ŷ|` (undistorted slopes), with 1/64 to spare.
    pub slopes: (f64, f64),
    /// Largest `|x̂|/|x̂_d|`-like gain `r_u / r_d` (at least 1).
    pub gain: f64,
    /// Largest `|J − 1|`.
    pub area_dev: f64,
    /// Largest [`Calibrated::solve_bound`], normalized units.
    pub solve_err: f64,
}

impl Calibrated {
    /// The undistorted field of the distorted box `|x̂_d| ≤ X`, `|ŷ_d| ≤
    /// Y`, by the renderer's own solve (I32F32) on its border (256 points
    /// a side, where a monotonic lens takes its extremes) and a 33×33 grid
    /// inside; points outside the valid field are left out (they render
    /// flagged). f64, once a plan.
    pub fn extent(&self, (bx, by): (f64, f64)) -> Extent {
        let m = self.to::<Q>();
        let mut e = Extent {
            slopes: (0.0, 0.0),
            gain: 1.0,
            area_dev: 0.0,
            solve_err: 0.0,
        };
        let mut visit = |xd: f64, yd: f64| {
            let (Some(qx), Some(qy)) = (from_f64::<Q>(xd), from_f64::<Q>(yd)) else {
                return;
            };
            let Some((x, y, j)) = m.undistort(qx, qy) else {
                return;
            };
            let (x, y, j) = (x.f64(), y.f64(), j.f64());
            e.slopes = (e.slopes.0.max(libm::fabs(x)), e.slopes.1.max(libm::fabs(y)));
            let (rd, ru) = (libm::sqrt(xd * xd + yd * yd), libm::sqrt(x * x + y * y));
            if rd > 1e-9 {
                e.gain = e.gain.max(ru / rd);
            }
            e.area_dev = e.area_dev.max(libm::fabs(j - 1.0));
            e.solve_err = e.solve_err.max(self.solve_bound((x, y)));
        };
        const SIDE: i32 = 256;
        for i in -SIDE..=SIDE {
            let t = f64::from(i) / f64::from(SIDE);
            for (xd, yd) in [(t * bx, by), (t * bx, -by), (bx, t * by), (-bx, t * by)] {
                visit(xd, yd);
            }
        }
        const GRID: i32 = 16;
        for i in -GRID..=GRID {
            for j in -GRID..=GRID {
                visit(
                    bx * f64::from(i) / f64::from(GRID),
                    by * f64::from(j) / f64::from(GRID),
                );
            }
        }
        let spare = 1.0 + 1.0 / 64.0;
        e.slopes = (e.slopes.0 * spare, e.slopes.1 * spare);
        e.gain *= spare;
        e.area_dev *= spare;
        e.solve_err *= spare;
        e
    }

    /// A bound on how far the renderer's solve (I32F32) lands from the
    /// exact undistorted point `(x̂, ŷ)`, normalized units: the model's
    /// evaluation rounds by at most 2⁻²⁷ of the sum of its terms'
    /// magnitudes (32 roundings of 2⁻³²), and the solve turns that into a
    /// point error through the inverse's gain — `max(1, J)` for OpenCV's
    /// model, `(1 + r²) / θ_d'(θ)` for the fisheye's `θ` and `tan θ` (which
    /// dominates towards 90°: at θ = 85° it is a few 10⁻⁶ of a unit, 10⁻³ px
    /// at `f` = 300 px; measured about half of it).
    pub fn solve_bound(&self, (x, y): (f64, f64)) -> f64 {
        let eps = libm::ldexp(1.0, -27);
        let u = x * x + y * y;
        let r = libm::sqrt(u);
        match self {
            Calibrated::OpenCv { k, p, s, .. } => {
                let (k, p, s) = (
                    k.map(|v| libm::fabs(v.f64())),
                    p.map(|v| libm::fabs(v.f64())),
                    s.map(|v| libm::fabs(v.f64())),
                );
                let terms = 1.0
                    + (k[0] + k[3]) * u
                    + (k[1] + k[4]) * u * u
                    + (k[2] + k[5]) * u * u * u
                    + 3.0 * (p[0] + p[1]) * (1.0 + u)
                    + (s[0] + s[2]) * u
                    + (s[1] + s[3]) * u * u;
                // J from the forward map's Jacobian (central differences).
                let h = 1e-6 * (1.0 + r);
                let f = |a: f64, b: f64| self.distort_f64((a, b));
                let det = match (f(x + h, y), f(x - h, y), f(x, y + h), f(x, y - h)) {
                    (Some(a), Some(b), Some(c), Some(d)) => {
                        let (ax, ay) = ((a.0 - b.0) / (2.0 * h), (a.1 - b.1) / (2.0 * h));
                        let (bx, by) = ((c.0 - d.0) / (2.0 * h), (c.1 - d.1) / (2.0 * h));
                        ax * by - bx * ay
                    }
                    _ => 0.0,
                };
                let gain = if det > 0.0 {
                    (1.0 / det).max(1.0)
                } else {
                    1.0 / eps
                };
                eps * (1.0 + r) * terms * gain
            }
            Calibrated::Fisheye { k, .. } => {
                let t = libm::atan(r);
                let kf = k.map(|v| v.f64());
                let t2 = t * t;
                let terms = t
                    * (1.0
                        + t2 * (libm::fabs(kf[0])
                            + t2 * (libm::fabs(kf[1]) + t2 * (libm::fabs(kf[2]) + t2 * libm::fabs(kf[3])))));
                let dp = fisheye_f64(&kf, t).1;
                let gain = if dp > 0.0 { (1.0 + u) / dp } else { 1.0 / eps };
                eps * (1.0 + terms) * gain
            }
        }
    }
}

/// A [`Calibrated`] model's constants in the renderer's scalar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model<S> {
    /// [`Calibrated::OpenCv`].
    OpenCv {
        /// `k1 … k6`.
        k: [S; 6],
        /// `p1, p2`.
        p: [S; 2],
        /// `s1 … s4`.
        s: [S; 4],
        /// `u` of the valid field's edge.
        u_valid: S,
    },
    /// [`Calibrated::Fisheye`].
    Fisheye {
        /// `k1 … k4`.
        k: [S; 4],
        /// `θ` of the valid field's edge.
        theta_valid: S,
        /// `θ_d` there.
        theta_d_valid: S,
    },
}

/// `1/n` as I32F32 bits, rounded (the series' factors).
const fn inv(n: i64) -> Q {
    Q::from_bits(((1i64 << 32) + n / 2) / n)
}

/// `sin θ`, `cos θ` for `0 ≤ θ < π/2`: of `θ`, or above `π/4` of
/// `π/2 − θ` swapped, so that the smaller of the two (the one `tan θ`
/// divides by near the horizon) keeps its relative precision.
#[inline]
fn sin_cos<S: Scalar>(t: S) -> (S, S) {
    // π/2 and π/4 in I32F32 bits.
    const HALF_PI: Q = Q::from_bits(6_746_518_852);
    const QUARTER_PI: Q = Q::from_bits(3_373_259_426);
    if t > S::from_q(QUARTER_PI) {
        let (s, c) = sin_cos_series(S::from_q(HALF_PI).sub(t));
        (c, s)
    } else {
        sin_cos_series(t)
    }
}

/// `sin θ`, `cos θ` by their Taylor series to `θ¹⁵` and `θ¹⁶` (truncation
/// below 10⁻¹² for `θ ≤ π/4`), in Horner form.
#[inline]
fn sin_cos_series<S: Scalar>(t: S) -> (S, S) {
    let t2 = t.mul(t);
    // sin = θ (1 − θ²/(2·3) (1 − θ²/(4·5) (1 − …))).
    let mut s = S::ONE;
    for n in [210, 156, 110, 72, 42, 20, 6] {
        s = S::ONE.sub(t2.mul(S::from_q(inv(n))).mul(s));
    }
    let mut c = S::ONE;
    for n in [240, 182, 132, 90, 56, 30, 12, 2] {
        c = S::ONE.sub(t2.mul(S::from_q(inv(n))).mul(c));
    }
    (t.mul(s), c)
}

/// Where OpenCV's model's Newton solve starts: the undistorted point of
/// `(x_d, y_d)` by its radial part alone, `r R(r²) = r_d` on `[0,
/// r_valid]` (where it increases), by Newton's method kept in a bracket
/// (bisecting where a step would leave it) — a lens whose `r R` all but
/// flattens between the axis and the point sends a plain Newton step far
/// off.
#[inline(always)]
fn radial_start<S: Scalar>(k: &[S; 6], u_valid: S, tx: S, ty: S) -> (S, S) {
    let rd = match tx.mul(tx).add(ty.mul(ty)).sqrt() {
        Some(r) if r > S::from_fixed_bits(1, 20) => r,
        _ => return (tx, ty),
    };
    let (mut lo, mut hi) = (S::ZERO, u_valid.sqrt().unwrap_or(S::ZERO));
    let mut r = if rd < hi { rd } else { hi };
    for _ in 0..2 * NEWTON_STEPS {
        let u = r.mul(r);
        let n = S::ONE.add(u.mul(k[0].add(u.mul(k[1].add(u.mul(k[2]))))));
        let d = S::ONE.add(u.mul(k[3].add(u.mul(k[4].add(u.mul(k[5]))))));
        let Some(q) = n.div(d) else { break };
        let f = r.mul(q);
        if f < rd {
            lo = r;
        } else {
            hi = r;
        }
        // d(r R)/dr = R + 2u R', R' = (N' − R D')/D.
        let dn = k[0].add(u.mul(k[1].add(k[1]).add(S::from_int(3).mul(k[2]).mul(u))));
        let dd = k[3].add(u.mul(k[4].add(k[4]).add(S::from_int(3).mul(k[5]).mul(u))));
        let slope = dn.sub(q.mul(dd)).div(d).map(|dq| q.add(u.add(u).mul(dq)));
        let newton = slope
            .filter(|s| *s > S::ZERO)
            .and_then(|s| rd.sub(f).div(s))
            .map(|st| r.add(st));
        let next = match newton {
            Some(v) if v >= lo && v <= hi => v,
            _ => lo.add(hi).mul(S::HALF),
        };
        let step = next.sub(r);
        r = next;
        if Model::<S>::small(step.abs(), r) {
            break;
        }
    }
    let scale = r.div(rd).unwrap_or(S::ONE);
    (tx.mul(scale), ty.mul(scale))
}

impl<S: Scalar> Model<S> {
    /// Newton's stopping step: `2⁻²¹ (1 + |x| + |y|)`.
    #[inline(always)]
    fn small(step: S, scale: S) -> bool {
        step <= S::from_fixed_bits(1, 21).mul(S::ONE.add(scale))
    }

    /// The undistorted point `(x̂, ŷ)` the lens images at the distorted
    /// `(x̂_d, ŷ_d)` (this crate's normalized coordinates), and the area
    /// factor `J = det ∂(x̂, ŷ)/∂(x̂_d, ŷ_d)` there; `None` outside the
    /// valid field (see the module).
    #[inline(never)]
    pub fn undistort(&self, xd: S, yd: S) -> Option<(S, S, S)> {
        match self {
            Model::OpenCv { k, p, s, u_valid } => opencv_undistort(k, p, s, *u_valid, xd, yd),
            Model::Fisheye {
                k,
                theta_valid,
                theta_d_valid,
            } => fisheye_undistort(k, *theta_valid, *theta_d_valid, xd, yd),
        }
    }
}

/// [`Model::undistort`] of OpenCV's standard model.
#[inline(always)]
fn opencv_undistort<S: Scalar>(
    k: &[S; 6],
    p: &[S; 2],
    s: &[S; 4],
    u_valid: S,
    xd: S,
    yd: S,
) -> Option<(S, S, S)> {
    let (tx, ty) = (xd.neg(), yd.neg());
    let two = S::from_int(2);
    // The model and its Jacobian at (x, y): `None` where the
    // denominator or the Jacobian's determinant is not
    // positive, or beyond the valid field (the fold side).
    let eval = |x: S, y: S| -> Option<(S, S, [S; 4], S)> {
        let u = x.mul(x).add(y.mul(y));
        if u > u_valid {
            return None;
        }
        let n = S::ONE.add(u.mul(k[0].add(u.mul(k[1].add(u.mul(k[2]))))));
        let d = S::ONE.add(u.mul(k[3].add(u.mul(k[4].add(u.mul(k[5]))))));
        if d <= S::ZERO {
            return None;
        }
        let r = n.div(d)?;
        let dn = k[0].add(u.mul(k[1].add(k[1]).add(S::from_int(3).mul(k[2]).mul(u))));
        let dd = k[3].add(u.mul(k[4].add(k[4]).add(S::from_int(3).mul(k[5]).mul(u))));
        // R' = (N' − R D')/D.
        let dr = dn.sub(r.mul(dd)).div(d)?;
        let xy = x.mul(y);
        let sx = s[0].add(two.mul(s[1]).mul(u));
        let sy = s[2].add(two.mul(s[3]).mul(u));
        let fx = x
            .mul(r)
            .add(two.mul(p[0]).mul(xy))
            .add(p[1].mul(u.add(two.mul(x).mul(x))))
            .add(s[0].mul(u))
            .add(s[1].mul(u).mul(u));
        let fy = y
            .mul(r)
            .add(p[0].mul(u.add(two.mul(y).mul(y))))
            .add(two.mul(p[1]).mul(xy))
            .add(s[2].mul(u))
            .add(s[3].mul(u).mul(u));
        let cross = two.mul(xy).mul(dr).add(two.mul(p[0].mul(x).add(p[1].mul(y))));
        let a = r
            .add(two.mul(x).mul(x).mul(dr))
            .add(two.mul(p[0]).mul(y))
            .add(S::from_int(6).mul(p[1]).mul(x))
            .add(two.mul(x).mul(sx));
        let b = cross.add(two.mul(y).mul(sx));
        let c = cross.add(two.mul(x).mul(sy));
        let e = r
            .add(two.mul(y).mul(y).mul(dr))
            .add(S::from_int(6).mul(p[0]).mul(y))
            .add(two.mul(p[1]).mul(x))
            .add(two.mul(y).mul(sy));
        let det = a.mul(e).sub(b.mul(c));
        if det <= S::ZERO {
            return None;
        }
        Some((fx, fy, [a, b, c, e], S::ONE.div(det)?))
    };
    // Newton's method from the radial part's own solve
    // ([`radial_start`]; halved towards the axis while it lies
    // past the fold); a step that lands
    // where the model folds is halved back towards the last
    // good point. The step after a small one ends it: the
    // Jacobian (and `J`) then at the solution within rounding.
    let (mut x, mut y) = radial_start(k, u_valid, tx, ty);
    let (mut gx, mut gy, mut hx, mut hy) = (x, y, S::ZERO, S::ZERO);
    let mut last = false;
    for _ in 0..2 * NEWTON_STEPS {
        let Some((fx, fy, [a, b, c, e], inv_det)) = eval(x, y) else {
            // (A start past the fold: halved towards the axis.)
            (hx, hy) = (hx.mul(S::HALF), hy.mul(S::HALF));
            (x, y, last) = match hx == S::ZERO && hy == S::ZERO {
                true => (x.mul(S::HALF), y.mul(S::HALF), false),
                false => (gx.add(hx), gy.add(hy), false),
            };
            continue;
        };
        if last {
            return Some((x.neg(), y.neg(), inv_det));
        }
        let (ex, ey) = (tx.sub(fx), ty.sub(fy));
        hx = e.mul(ex).sub(b.mul(ey)).mul(inv_det);
        hy = a.mul(ey).sub(c.mul(ex)).mul(inv_det);
        (gx, gy) = (x, y);
        (x, y) = (x.add(hx), y.add(hy));
        last = Model::<S>::small(hx.abs().add(hy.abs()), x.abs().add(y.abs()));
    }
    None
}

/// [`Model::undistort`] of the fisheye model.
#[inline(always)]
fn fisheye_undistort<S: Scalar>(
    k: &[S; 4],
    theta_valid: S,
    theta_d_valid: S,
    xd: S,
    yd: S,
) -> Option<(S, S, S)> {
    let rd2 = xd.mul(xd).add(yd.mul(yd));
    let td = rd2.sqrt()?;
    if td > theta_d_valid {
        return None;
    }
    // Newton's method kept within a bracket of the root on
    // [0, θ_valid], where θ_d(θ) increases: a step that would
    // leave it, or a start past the fold (θ_d > θ there), bisects
    // instead.
    let (mut lo, mut hi) = (S::ZERO, theta_valid);
    let mut t = if td < hi { td } else { hi };
    let mut done = false;
    // dθ_d/dθ = 1 + 3 k1 θ² + 5 k2 θ⁴ + 7 k3 θ⁶ + 9 k4 θ⁸.
    let slope = |t: S| {
        let t2 = t.mul(t);
        S::ONE.add(
            t2.mul(
                S::from_int(3).mul(k[0]).add(
                    t2.mul(
                        S::from_int(5)
                            .mul(k[1])
                            .add(t2.mul(S::from_int(7).mul(k[2]).add(t2.mul(S::from_int(9).mul(k[3]))))),
                    ),
                ),
            ),
        )
    };
    for _ in 0..2 * NEWTON_STEPS {
        let t2 = t.mul(t);
        let p = t.mul(S::ONE.add(t2.mul(k[0].add(t2.mul(k[1].add(t2.mul(k[2].add(t2.mul(k[3])))))))));
        if p < td {
            lo = t;
        } else {
            hi = t;
        }
        let dp = slope(t);
        let newton = if dp > S::ZERO {
            td.sub(p).div(dp).map(|s| t.add(s))
        } else {
            None
        };
        let next = match newton {
            Some(n) if n >= lo && n <= hi => n,
            _ => lo.add(hi).mul(S::HALF),
        };
        let step = next.sub(t);
        t = next;
        if Model::<S>::small(step.abs(), t) {
            done = true;
            break;
        }
    }
    if !done || t > theta_valid || t < S::ZERO {
        return None;
    }
    let dp = slope(t);
    if dp <= S::ZERO {
        return None;
    }
    let (sin, cos) = sin_cos(t);
    let ru = sin.div(cos)?;
    // x̂ = x̂_d h, h = r_u/θ_d (→ 1/P'(0) = 1 on the axis).
    let h = if td > S::from_fixed_bits(1, 16) {
        ru.div(td)?
    } else {
        S::ONE
    };
    // J = h · dr_u/dθ_d = h (1 + r_u²) / P'(θ).
    let j = h.mul(S::ONE.add(ru.mul(ru))).div(dp)?;
    Some((xd.mul(h), yd.mul(h), j))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The solve inverts the model as written (f64) to well within 1/256 px
    /// at f = 1 000 px, across the field, for each model.
    #[test]
    fn the_solve_inverts_the_model() {
        let models = [
            Calibrated::opencv([-0.28, 0.07, 1e-3, -5e-4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap(),
            Calibrated::opencv([
                0.9, 0.3, 2e-3, 1e-3, 0.01, 1.2, 0.5, 0.05, 1e-3, -2e-4, 5e-4, 1e-4,
            ])
            .unwrap(),
            Calibrated::fisheye([0.02, -0.01, 0.004, -0.001]).unwrap(),
        ];
        for m in models {
            let model = m.to::<Q>();
            let mut worst: f64 = 0.0;
            let mut seen = 0;
            for i in -20..=20 {
                for j in -15..=15 {
                    let (xd, yd) = (f64::from(i) * 0.04, f64::from(j) * 0.04);
                    let Some((x, y, jac)) = model.undistort(Q::from_num(xd), Q::from_num(yd)) else {
                        continue;
                    };
                    seen += 1;
                    let (x, y) = (x.to_num::<f64>(), y.to_num::<f64>());
                    let (bx, by) = m.distort_f64((x, y)).expect("inside the field");
                    worst = worst.max((bx - xd).abs()).max((by - yd).abs());
                    // J against a central difference of the f64 inverse
                    // through the forward model's Jacobian.
                    let h = 1e-6;
                    let f = |x, y| m.distort_f64((x, y)).unwrap();
                    let (a, c) = {
                        let (p, q) = (f(x + h, y), f(x - h, y));
                        ((p.0 - q.0) / (2.0 * h), (p.1 - q.1) / (2.0 * h))
                    };
                    let (b, d) = {
                        let (p, q) = (f(x, y + h), f(x, y - h));
                        ((p.0 - q.0) / (2.0 * h), (p.1 - q.1) / (2.0 * h))
                    };
                    let want = 1.0 / (a * d - b * c);
                    assert!(
                        (jac.to_num::<f64>() - want).abs() < 1e-5 * want,
                        "{m:?} J {jac} vs {want}"
                    );
                }
            }
            assert!(seen > 900, "{m:?}: {seen} points solved");
            assert!(worst * 1000.0 < 1e-4, "{m:?}: {worst}");
        }
    }

    /// Beyond the fold the solve answers `None`, never a point.
    #[test]
    fn past_the_fold_is_outside() {
        // Strong barrel: R + 2u R' = 1 − 1.5 u … folds at u = 2/3.
        let m = Calibrated::opencv([-0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
        let Calibrated::OpenCv { u_valid, .. } = m else {
            unreachable!()
        };
        assert!((u_valid.f64() - 2.0 / 3.0).abs() < 1e-6, "{u_valid}");
        // The image of the fold: r_d = r (1 − 0.5 r²) at r² = 2/3.
        let rd = (2.0f64 / 3.0).sqrt() * (1.0 - 1.0 / 3.0);
        let model = m.to::<Q>();
        assert!(model.undistort(Q::from_num(rd * 0.99), Q::ZERO).is_some());
        assert!(model.undistort(Q::from_num(rd * 1.01), Q::ZERO).is_none());
        assert!(Calibrated::opencv([f64::NAN; 12]).is_err());
        assert!(Calibrated::fisheye([2e4, 0.0, 0.0, 0.0]).is_err());
    }
}
