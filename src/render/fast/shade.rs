//! The fast arithmetic's shading terms: a material's constants per light
//! ([`KCache`]), the Phong lobe's power (`lobe_pf`), the closed plane's
//! terms (`closed_term`) and its mean over rays (`mean_into`), a point
//! light's `cos/r²` (`cube_over`), a directional light's (`directional_w`).

use super::arith::{norm_top, norm_top_even, rsqrt_top, umul, wmul, wmul_px, wsq, Pf, SUM_CAP};
use super::rays::{Ray, NO_Q2};
use super::{each, Closed, ClosedLight};
use crate::target::M0;

/// `kd · E` and `ks · E` (or `· I/U²`) per light and channel for one
/// material, its ambient term and its lobe: a pixel of the material the
/// last one had looks nothing else up.
pub(super) struct KCache {
    pub(super) material: usize,
    /// The ambient term, S15 DN.
    pub(super) ka: [u64; 3],
    pub(super) k: [[Pf; 3]; crate::scene::MAX_LIGHTS],
    /// Per light, `ks` times it, and the largest exponent of those over the
    /// channels (the test that a vanishing lobe's term floors to 0; kept
    /// beside them: as an array of its own, spheres-specular measured
    /// 470.1 against 469.3 M3 instructions a pixel, 461.2 against 456.5 on
    /// the M4F).
    pub(super) ks: [([Pf; 3], i32); crate::scene::MAX_LIGHTS],
    /// The material's Phong exponent, if its lobe is rendered.
    pub(super) lobe: Option<u16>,
    /// Its [`lobe_below`].
    pub(super) below: i32,
    /// The last flat hit's [`Ray::hit`] and material, and its sum
    /// ([`Mix32::shade_flat`]).
    pub(super) flat: (u8, usize),
    pub(super) flat_sum: [u64; 3],
}

impl KCache {
    pub(super) const EMPTY: KCache = KCache {
        material: usize::MAX,
        ka: [0; 3],
        k: [[Pf { m: 0, e: 0 }; 3]; crate::scene::MAX_LIGHTS],
        ks: [([Pf { m: 0, e: 0 }; 3], 0); crate::scene::MAX_LIGHTS],
        lobe: None,
        below: 0,
        flat: (0, usize::MAX),
        flat_sum: [0; 3],
    };
}

/// The least `x` (S30) whose Phong lobe `(x 2⁻³⁰)^s` may exceed 2⁻⁶⁴
/// (`s ≥ 1`; for `s = 0`, whose lobe is 1 everywhere, `i32::MIN`): one
/// above the largest `x` whose power with every product rounded up
/// ([`Pf::mul_up`]) is at most 2⁻⁶⁴, by bisection. Once a material a frame,
/// in integers (f64's `exp2` cost the M3's firmware 5.8 KB of flash).
pub(super) fn lobe_below(s: u16) -> i32 {
    if s == 0 {
        return i32::MIN;
    }
    // 2^-64 as a normalized Pf: (2^31, -95). Normalized mantissas order by
    // (e, m) as their values do.
    let bound = Pf::new32(1, -64);
    // up(lo) ≤ 2^-64 < up(hi) (x = 2^30 is 1).
    let (mut lo, mut hi) = (0u32, 1u32 << 30);
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        let up = power(Pf::new32(mid, -30), s, Pf::mul_up);
        if (up.e, up.m) <= (bound.e, bound.m) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo as i32 + 1
}

/// `base^s` (`s ≥ 1`) by squaring, each product `mul`'s: [`lobe_pf`]'s
/// (rounded down) and [`lobe_below`]'s (rounded up).
#[inline(always)]
pub(super) fn power(mut base: Pf, s: u16, mul: impl Fn(Pf, Pf) -> Pf) -> Pf {
    let mut acc = Pf::new32(1, 0);
    let mut n = s;
    loop {
        if n & 1 == 1 {
            acc = mul(acc, base);
        }
        n >>= 1;
        if n == 0 {
            return acc;
        }
        base = mul(base, base);
    }
}

/// The Phong lobe `max(0, x)^s` for `x` in S30 (clamped to 1), as a [`Pf`]
/// by squaring (each product ≤ 2⁻³¹ relative); `0⁰ = 1`, as in the
/// reference.
#[inline]
pub(super) fn lobe_pf(x: i32, s: u16) -> Pf {
    if s == 0 {
        return Pf::new32(1, 0);
    }
    if x <= 0 {
        return Pf::default();
    }
    power(Pf::new32(x.min(1 << 30) as u32, -30), s, |a, b| a * b)
}

/// `w = n·d` (S24) of ray `r` for a plane of normal `n` (S30), as
/// [`Ray::plane_t`] takes it. On the Cortex-M0, where a product is four
/// 16-bit ones, a product by a zero component (a floor or a wall seen by a
/// camera without roll: `n_x = 0`) is left out — the same sum.
#[inline(always)]
pub(super) fn closed_w(n: [i32; 3], r: &Ray) -> i32 {
    let nx = if M0 && n[0] == 0 { 0 } else { wmul_px(n[0], r.x) };
    ((nx + wmul_px(n[1], r.y) + ((n[2] as i64) << 26)) >> 32) as i32
}

/// Adds point light `l`'s term `kd I h (|w| / |q|)³` to `sum` for ray `r`
/// on the [`Closed`] plane (`w = n·d`, S24). With `keep` (the frame's only
/// light, a plane with `n_x = 0` whose rays are mirrored: `w`, `q_y` and
/// `q_z` are even in `x̂`, and `q_x`'s two products odd and even), `|q|²`
/// is taken from the ray if its unmirrored self kept it there, and with
/// `store` (an unmirrored ray) its mirror's is kept: on the Cortex-M0,
/// where each product is four 16-bit ones, the mirror makes none.
#[inline(always)]
pub(super) fn closed_term<const C: usize>(
    n: usize,
    c: &Closed,
    l: &ClosedLight,
    r: &mut Ray,
    w: i32,
    (keep, store): (bool, bool),
    sum: &mut [u64; 3],
) {
    // q = w P_L − dist d, exact in S50 U (|q| = |w| r ≤ 363 U: |w| ≤ |d| <
    // 23, |P_L| and |dist| ≤ 8 U), then S22 U.
    let q22 = |v: i64| (v >> 28) as i32;
    // |q|², S44 U² (< 2^62).
    let q2 = if keep && r.oy != NO_Q2 {
        ((r.oy as u32 as u64) << 32) | r.ox as u32 as u64
    } else {
        let (wx, dx) = (wmul_px(w, l.p26[0]), wmul_px(c.ndist, r.x));
        let qx = q22(wx + dx);
        // The mirror's: x̂ negated, so q_x's second product (exact).
        let mx = if store { q22(wx - dx) } else { 0 };
        let qy = q22(wmul_px(w, l.p26[1]) + wmul_px(c.ndist, r.y));
        let qz = q22(wmul_px(w, l.p26[2]) + c.ndist50);
        let yz = wsq(qy) + wsq(qz);
        if store {
            let m = wsq(mx) + yz;
            (r.ox, r.oy) = (m as u32 as i32, (m >> 32) as i32);
        }
        wsq(qx) + yz
    };
    if q2 == 0 {
        return;
    }
    let s3 = cube_over(w.unsigned_abs(), q2);
    each::<C>(n, |ch| {
        if let (Some(x), Some(k)) = (sum.get_mut(ch), l.k.get(ch)) {
            *x = (*x + s3.times(*k)).min(SUM_CAP);
        }
    });
}

/// The sum (S15 DN) of a ray between two whose sums are `a` and `b` on
/// the [`Closed`] plane, in a chunk that sees it alone
/// ([`Mix32::closed_run`]): their mean, rounded down. (The term `kd I h /
/// r³` is smooth along a row; the planner bounds the error,
/// `planner::closed_mean_err`.)
#[inline(always)]
pub(super) fn mean(a: u64, b: u64) -> u64 {
    (a + b) >> 1
}

/// [`mean`] of two rays' sums channel by channel, also into `m` (the ray
/// between's slot), for the word (channels past `C` 0). Written out per
/// channel: a loop over them zeroed the sum through a library call.
#[inline(always)]
pub(super) fn mean_into<const C: usize>(n: usize, a: &[u64; C], b: &[u64; C], m: &mut [u64; C]) -> [u64; 3] {
    let mut sum = [0u64; 3];
    each::<C>(n, |ch| {
        if let (Some(s), Some(a), Some(m), Some(b)) = (sum.get_mut(ch), a.get(ch), m.get_mut(ch), b.get(ch)) {
            *s = mean(*a, *b);
            *m = *s;
        }
    });
    sum
}

/// `(a / |q|)³` for `a` in S24 (`|w|`) and `|q|²` in S44 U² (non-zero):
/// [`Closed`]'s `(1/r)³` in U⁻³, as `m 2^e` with `m` in `[2²⁹, 2³²)`
/// (not normalized: [`Cube::times`] takes it as it is).
#[derive(Clone, Copy, Debug)]
pub(super) struct Cube {
    pub(super) m: u32,
    pub(super) e: i32,
}

/// [`Cube`] of `a / √q2`: `1/|q| = y 2^(z/2 − 40)` ([`rsqrt_norm`]), so
/// `s = a y 2^(z/2 − 64)`; `a y` normalized once (`m` in `[2³¹, 2³²)`),
/// then `m²` and `m³` as the high words of two products. Relative error:
/// `1/√` 2⁻¹⁹ (three times), the truncations below 2⁻²⁸ together.
#[inline(always)]
pub(super) fn cube_over(a: u32, q2: u64) -> Cube {
    // (`q2 ≠ 0`, normalized in words: the standard scene 1.4 M3
    // instructions a pixel fewer, 1.1 on the M0. In `rsqrt_norm` for every
    // caller, spheres-specular measured 3.6 more on the M3.)
    let (m, z) = norm_top_even(q2);
    let y = rsqrt_top(m);
    // a y ≈ m 2^(32 − lz): s = m 2^(z/2 − lz − 32).
    let (m, lz) = norm_top(umul(a, y));
    let m2 = (umul(m, m) >> 32) as u32;
    let m3 = (umul(m2, m) >> 32) as u32;
    // s³ = m³ 2^(3e) = m3 2^(3e + 64).
    Cube {
        m: m3,
        e: 3 * (z as i32 / 2 - lz as i32 - 32) + 64,
    }
}

impl Cube {
    /// `k · self` in S15 DN (low by under one unit of the product's top
    /// word, in `[2²⁸, 2³²)`: 2⁻²⁸ relative; capped at [`SUM_CAP`]):
    /// [`Pf::mul_to_sum`], which takes the top word as it is (it does not
    /// need `m` normalized).
    #[inline(always)]
    pub(super) fn times(self, k: Pf) -> u64 {
        k.mul_to_sum(Pf { m: self.m, e: self.e }, 15)
    }
}

/// `a·b` of two S30 unit vectors, S30.
#[inline(always)]
pub(super) fn dot30(a: [i32; 3], b: [i32; 3]) -> i32 {
    ((wmul(a[0], b[0]) + wmul(a[1], b[1]) + wmul(a[2], b[2])) >> 30) as i32
}

/// A directional light's `n̂·l̂` for a normal `nt` and direction `l` (S30),
/// or `None` if the light lies behind the surface.
#[inline(always)]
pub(super) fn directional_w(nt: [i32; 3], l: [i32; 3]) -> Option<Pf> {
    let nl = dot30(nt, l);
    (nl > 0).then(|| Pf::new32(nl as u32, -30))
}
