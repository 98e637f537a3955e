//! Radial distortion (camera-model.md §3).
//!
//! The lens images a ray at the *distorted* normalized position
//! `(x̂_d, ŷ_d)`; the pinhole position is `x̂ = x̂_d g(r_d²)` with
//! `g(u) = 1 + k1 u + k2 u²`, `u = r_d² = x̂_d² + ŷ_d²` (`k1 > 0` is barrel).
//!
//! - The renderer needs `pixel → undistorted`, which has no iteration: a
//!   [`Lut`] of `g` indexed by `u`, linearly interpolated. `g` is a quadratic
//!   in `u`, so interpolation is exact when `k2 = 0` and otherwise off by at
//!   most `|k2| h² / 4` for a step `h` in `u`.
//! - Projecting points needs the inverse, [`Distortion::distort`]: bisection
//!   on the monotonic branch `[0, r_fold]`, which converges by construction or
//!   reports [`OutsideLensField`].
//! - Past the fold radius (`1 + 3 k1 u + 5 k2 u² = 0`) the lens folds the
//!   image over: such pixels are outside the lens field.

use crate::geom::error::{Error, Field};
use crate::geom::frame::NormPoint;
use crate::num::scalar::Scalar;
use crate::num::{quotient, FixedF64, Norm, Sat, Wide};
use core::ops::{Add as _, Mul as _};
use fixed::types::{I32F0, I32F32};

/// Supported distortion coefficients: `|k1| ≤ 10`, `|k2| ≤ 100`.
pub const K_RANGE: (f64, f64) = (10.0, 100.0);
/// Most entries a [`Lut`] holds.
pub const MAX_LUT: usize = 1024;

/// A normalized point lies outside the lens field: beyond the fold radius,
/// no distorted position images it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutsideLensField;

/// Validated radial distortion coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Distortion {
    k1: Norm,
    k2: Norm,
    /// `u = r_d²` of the fold, if the lens folds at all.
    fold_u: Option<Norm>,
}

impl Distortion {
    /// No distortion.
    pub const NONE: Distortion = Distortion {
        k1: Norm::ZERO,
        k2: Norm::ZERO,
        fold_u: None,
    };

    /// From `k1`, `k2` (dimensionless, normalized coordinates), each finite
    /// and within [`K_RANGE`].
    pub fn new(k1: f64, k2: f64) -> Result<Self, Error> {
        for (k, max) in [(k1, K_RANGE.0), (k2, K_RANGE.1)] {
            if !k.is_finite() {
                return Err(Error::NotFinite(Field::Distortion));
            }
            if k.abs() > max {
                return Err(Error::OutOfRange(Field::Distortion));
            }
        }
        // Within K_RANGE: the checked conversions cannot fail (and keep a
        // panic path out of the core).
        let k1f = crate::num::from_f64::<Norm>(k1).ok_or(Error::OutOfRange(Field::Distortion))?;
        let k2f = crate::num::from_f64::<Norm>(k2).ok_or(Error::OutOfRange(Field::Distortion))?;
        // The fold from the stored (rounded) coefficients, so that every user
        // of this value agrees with the LUT built from them.
        let (a, b) = (3.0 * k1f.f64(), 5.0 * k2f.f64());
        let fold = smallest_positive_root(b, a, 1.0);
        Ok(Distortion {
            k1: k1f,
            k2: k2f,
            fold_u: fold.map(|u| crate::num::from_f64::<Norm>(u).unwrap_or(Norm::MAX)),
        })
    }

    /// True when `k1 = k2 = 0`: the stage can be left out.
    pub fn is_none(&self) -> bool {
        self.k1 == Norm::ZERO && self.k2 == Norm::ZERO
    }

    /// `(k1, k2)` as stored.
    pub fn coefficients(&self) -> (Norm, Norm) {
        (self.k1, self.k2)
    }

    /// The fold radius `r_d` (normalized), if the lens folds.
    pub fn fold_radius(&self) -> Option<Norm> {
        self.fold_u.map(|u| {
            let r = I32F32::from_num(u).checked_sqrt().unwrap_or(I32F32::MAX);
            Norm::saturating_from_num(r)
        })
    }

    /// `u = r_d²` at the fold, if any.
    pub fn fold_u(&self) -> Option<Norm> {
        self.fold_u
    }

    /// `g(u) = 1 + k1 u + k2 u²` in wide arithmetic.
    fn g_wide(&self, u: Wide) -> Wide {
        Wide::int(1)
            .add(Wide::of(self.k1).mul(u))
            .add(Wide::of(self.k2).mul(u).mul(u))
    }

    /// Distorted → undistorted by the polynomial (per point; the renderer uses
    /// the [`Lut`]). [`OutsideLensField`] beyond the fold radius.
    pub fn undistort(&self, p: NormPoint) -> Result<Sat<NormPoint>, OutsideLensField> {
        let (x, y) = (Wide::of(p.x), Wide::of(p.y));
        let u = x.mul(x).add(y.mul(y));
        if let Some(f) = self.fold_u {
            if u.compare(Wide::of(f)) == core::cmp::Ordering::Greater {
                return Err(OutsideLensField);
            }
        }
        let g = self.g_wide(u);
        Ok(x.mul(g)
            .narrow::<Norm>()
            .zip(y.mul(g).narrow::<Norm>())
            .map(|(x, y)| NormPoint { x, y }))
    }

    /// Undistorted → distorted: solves `r_u = r_d g(r_d²)` on the monotonic
    /// branch by bisection (60 halvings of a bracket, so the result is within
    /// 2⁻⁴⁸ of the root), and scales the point by `r_d / r_u`.
    ///
    /// [`OutsideLensField`] when `r_u` lies beyond the image of the fold
    /// radius (no distorted position maps there on the monotonic branch).
    pub fn distort(&self, p: NormPoint) -> Result<Sat<NormPoint>, OutsideLensField> {
        let (x, y) = (Wide::of(p.x), Wide::of(p.y));
        let ru2 = x.mul(x).add(y.mul(y));
        if ru2.is_zero() {
            return Ok(Sat::exact(p));
        }
        let ru = ru2.sqrt().unwrap_or(Wide::ZERO);
        let h = |rd: Wide| rd.mul(self.g_wide(rd.mul(rd)));
        // Upper end of the bracket: the fold, or, without a fold, a radius
        // where h(r) ≥ r_u (h grows without bound then, since g > 0 has no
        // root and is a polynomial of positive leading behaviour).
        let mut hi = match self.fold_u {
            Some(f) => Wide::of(f).sqrt().unwrap_or(Wide::ZERO),
            None => {
                let mut r = ru.max_of(Wide::int(1));
                let mut n = 0;
                while h(r).compare(ru) == core::cmp::Ordering::Less {
                    r = r.mul(Wide::int(2));
                    n += 1;
                    if n > 64 {
                        return Err(OutsideLensField);
                    }
                }
                r
            }
        };
        if h(hi).compare(ru) == core::cmp::Ordering::Less {
            return Err(OutsideLensField);
        }
        let mut lo = Wide::ZERO;
        let half = Wide::of(Norm::from_bits(1 << 47)); // 0.5
        for _ in 0..60 {
            let mid = lo.add(hi).mul(half);
            if h(mid).compare(ru) == core::cmp::Ordering::Less {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let rd = lo.add(hi).mul(half);
        let px = quotient::<Norm>(x.mul(rd), ru);
        let py = quotient::<Norm>(y.mul(rd), ru);
        Ok(px.zip(py).map(|(x, y)| NormPoint { x, y }))
    }

    /// Builds the renderer's table over `u ∈ [0, u_max]` with `entries`
    /// entries (2 to [`MAX_LUT`]).
    ///
    /// The entry format is chosen for the camera: i32 with the most
    /// fractional bits (at most 30) that still hold the largest `|g|` over
    /// the range — I2F30 for `|g| < 2`, I4F28 below 8, I8F24 below 128. A
    /// `g` beyond even I16F16 (|g| ≥ 32 768, a lens far outside any real one)
    /// is flagged saturated, and the renderer refuses the frame.
    pub fn lut(&self, u_max: I32F32, entries: usize) -> Sat<Lut> {
        self.lut_in(u_max, entries)
    }

    /// [`Distortion::lut`] in a table of capacity `N` (`4 N` bytes): at
    /// most `N` entries (2 to `N`; a caller that needs more checks first).
    pub fn lut_in<const N: usize>(&self, u_max: I32F32, entries: usize) -> Sat<Lut<N>> {
        let mut value = Lut::empty();
        let saturated = self.fill_lut(u_max, entries, &mut value);
        Sat { value, saturated }
    }

    /// [`Distortion::lut_in`] into `lut` (a table where it will be used:
    /// no copy of its `4 N` bytes on the stack); whether an entry
    /// saturated.
    pub fn fill_lut<const N: usize>(&self, u_max: I32F32, entries: usize, lut: &mut Lut<N>) -> bool {
        let n = entries.clamp(2, N.max(2));
        let u_max = if u_max > I32F32::ZERO {
            u_max
        } else {
            I32F32::DELTA
        };
        let uw = Wide::of(u_max);
        let frac = self.entry_frac_bits(u_max);
        let mut saturated = false;
        lut.table.clear();
        let step = quotient::<Norm>(uw, Wide::int(n as i64 - 1)).value;
        for i in 0..n {
            let u = Wide::of(step).mul(Wide::int(i as i64));
            let g = self.g_wide(u).mul(Wide::int(1i64 << frac)).narrow::<I32F0>();
            saturated |= g.saturated;
            // Beyond the capacity (N < 2) the push fails: the table is
            // then shorter than 2 and gives g = 1 (callers check first).
            let _ = lut.table.push(g.value.to_bits());
        }
        lut.u_max = u_max;
        lut.scale = quotient::<I32F32>(Wide::int(n as i64 - 1), uw).value;
        lut.shift = 32 - frac;
        saturated
    }

    /// Fractional bits of the table entries for `u ∈ [0, u_max]`: the most
    /// (at most 30, at least 16) with which an i32 holds the largest `|g|`
    /// there.
    pub fn entry_frac_bits(&self, u_max: I32F32) -> u32 {
        let uw = Wide::of(u_max);
        // |g| is largest at an end of the range or at the vertex of the
        // quadratic, −k1 / (2 k2), if that lies inside.
        let mut g_max = self.g_wide(Wide::ZERO).abs().max_of(self.g_wide(uw).abs());
        if self.k2 != Norm::ZERO {
            if let Some(v) = (-Wide::of(self.k1)).checked_div(Wide::of(self.k2).mul(Wide::int(2))) {
                if v.signum() > 0 && v.compare(uw) == core::cmp::Ordering::Less {
                    g_max = g_max.max_of(self.g_wide(v).abs());
                }
            }
        }
        let mut frac = 30u32;
        while frac > 16 && g_max.compare(Wide::int(1i64 << (31 - frac))) != core::cmp::Ordering::Less {
            frac -= 1;
        }
        frac
    }

    /// The largest error of linear interpolation in `g` for a table of
    /// `entries` over `[0, u_max]`: `|k2| h² / 4`, `h = u_max / (entries − 1)`.
    pub fn lut_interp_error(&self, u_max: f64, entries: usize) -> f64 {
        let h = u_max / (entries.max(2) - 1) as f64;
        self.k2.f64().abs() * h * h / 4.0
    }
}

/// The smallest positive root of `a u² + b u + c`, if any (c > 0 here).
fn smallest_positive_root(a: f64, b: f64, c: f64) -> Option<f64> {
    if a == 0.0 {
        return if b < 0.0 { Some(-c / b) } else { None };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let s = libm::sqrt(disc);
    // Numerically stable pair of roots.
    let q = -0.5 * (b + if b >= 0.0 { s } else { -s });
    let r1 = q / a;
    let r2 = if q != 0.0 { c / q } else { f64::INFINITY };
    [r1, r2]
        .into_iter()
        .filter(|r| *r > 0.0 && r.is_finite())
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.min(r))))
}

/// A table of `g(u)` over `u ∈ [0, u_max]`, for the per-pixel path, of at
/// most `N` entries.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Lut<const N: usize = MAX_LUT> {
    u_max: I32F32,
    /// `(entries − 1) / u_max`.
    scale: I32F32,
    /// Entries are i32 with `32 − shift` fractional bits.
    shift: u32,
    table: heapless::Vec<i32, N>,
}

impl<const N: usize> Lut<N> {
    /// No entries (g = 1 everywhere); [`Distortion::fill_lut`] fills it.
    /// A function, not a constant: a constant's `4 N` bytes would be a
    /// blob in flash.
    pub const fn empty() -> Lut<N> {
        Lut {
            u_max: I32F32::ZERO,
            scale: I32F32::ZERO,
            shift: 0,
            table: heapless::Vec::new(),
        }
    }

    /// Entries in the table.
    pub fn len(&self) -> usize {
        self.table.len()
    }

    /// Never empty (at least 2 entries).
    pub fn is_empty(&self) -> bool {
        self.table.is_empty()
    }

    /// Bytes the table occupies.
    pub fn bytes(&self) -> usize {
        self.table.len() * core::mem::size_of::<i32>()
    }

    /// Fractional bits of the entries (the format chosen for the camera).
    pub fn entry_frac_bits(&self) -> u32 {
        32 - self.shift
    }

    /// The `u` the table covers up to.
    pub fn u_max(&self) -> I32F32 {
        self.u_max
    }

    /// `(entries − 1) / u_max`: table positions per unit of `u`.
    pub fn scale(&self) -> I32F32 {
        self.scale
    }

    /// `g(u)` by linear interpolation, in I32F32; `u` beyond the table is
    /// clamped to its last interval (extrapolated linearly).
    #[inline]
    pub fn g(&self, u: I32F32) -> I32F32 {
        self.linear(u, self.scale)
    }

    /// `g(u)` by linear interpolation, in any [`Scalar`]; `scale` is
    /// [`Lut::scale`] converted to `S` (once per frame, by the caller). `u`
    /// beyond the table is clamped to its last interval (extrapolated
    /// linearly).
    #[inline(always)]
    pub fn linear<S: Scalar>(&self, u: S, scale: S) -> S {
        let pos = u.mul(scale);
        let i = (pos.floor_int().max(0) as usize).min(self.table.len().saturating_sub(2));
        let t = pos.sub(S::from_int(i as i32));
        match (self.table.get(i), self.table.get(i + 1)) {
            (Some(a), Some(b)) => {
                let (a, b): (S, S) = (self.entry(*a), self.entry(*b));
                a.add(b.sub(a).mul(t))
            }
            _ => S::ONE,
        }
    }

    /// `g(u)` from the entry nearest to `u` (no interpolation), in any
    /// [`Scalar`]; `scale` as for [`Lut::linear`].
    #[inline(always)]
    pub fn nearest<S: Scalar>(&self, u: S, scale: S) -> S {
        let pos = u.mul(scale).add(S::HALF);
        let i = (pos.floor_int().max(0) as usize).min(self.table.len().saturating_sub(1));
        self.table.get(i).map_or(S::ONE, |e| self.entry(*e))
    }

    /// One entry in `S` (a shift in fixed point).
    #[inline(always)]
    fn entry<S: Scalar>(&self, bits: i32) -> S {
        S::from_fixed_bits(bits, self.entry_frac_bits())
    }
}
