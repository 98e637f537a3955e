use super::arith::{
    cos_over_r2, len_s, mul_h_words, mul_hi_64_words, mul_shr61_words, mul_shr_t, newton_words,
    norm_top_even, recip, recip_len, recip_z, rsqrt_norm, rsqrt_top, sar64, sar64_low_lt32, sat32, smul_u,
    sqrt_s44_to_s22, umul, umul_h, umul_px, wmul, wsq, zip3, Pf, RECIP_SEED, SEED, SUM_CAP, T_MAX,
};
use super::expose::{
    mul_nonneg, noisy_dn, round_c4_words, sigma_z, sigma_z16, store, vignette_dn, vignette_dn_words,
};
use super::intersect::{fine_normal, passes_beyond, Inner, MixPrim, MixShape};
use super::rays::{cos4, fill_lanes, fill_rays, undistort_k, undistort_kj, Ray, Rays, AWAY, CHUNK, NO_HIT};
use super::shade::{lobe_below, lobe_pf};
use super::{Aperture, Mix32, ALONG_S42};
use crate::num::scalar::shr_sat;
use crate::render::ClosedMean;
use crate::scene::Q;
use core::num::NonZeroU32;

/// `1/√(x · 2^e)` for `x > 0`, `e` even.
fn rsqrt(x: u64, e: i32) -> Pf {
    if x == 0 {
        return Pf::default();
    }
    let (_, y, z) = rsqrt_norm(x);
    // x 2^e = (m/2^64) 2^(64 − z + e); y ≈ (m/2^64)^(−½) · 2^30.
    Pf::new32(y, -30 - (64 - z as i32 + e) / 2)
}

/// A small deterministic generator (xorshift).
fn rng(seed: &mut u64) -> u64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    *seed
}

/// Every ray of a slope box that [`Inner::covers`] passes the
/// rectangle's own test (its pass keeps the plane's `t`), on random
/// rectangles — tilted up to grazing, near and far, small and large —
/// and boxes from a fraction of a pixel to many pixels wide; and the
/// region is not empty where the rectangle is seen well.
#[test]
fn inner_boxes_pass_the_rectangles_test() {
    let mut s = 0x1a2e_5eed_0bad_cafe;
    let mut f = |lo: f64, hi: f64| lo + (hi - lo) * (rng(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
    let (mut covered, mut rays_checked, mut frames) = (0, 0, 0);
    for _ in 0..4000 {
        // An orthonormal frame (n, u, v) from random angles; the
        // centre 0.1 to 7 U ahead, half sizes 2^-6 to 4 U.
        let [n, u, v] = random_frame(&mut f);
        let c = [f(-3.0, 3.0), f(-3.0, 3.0), f(0.1, 7.0)];
        let (hu, hv) = (f(-6.0, 2.0).exp2(), f(-6.0, 2.0).exp2());
        let (shape, n30, dist) = rect_shape([n, u, v], c, [hu, hv]);
        let prim = MixPrim {
            shape,
            material: 0,
            checker: None,
            bounds: None,
            nl: [0; crate::scene::MAX_LIGHTS],
            flat: false,
            spread: 0,
            depth: [i32::MIN, i32::MAX],
        };
        let Some(q) = Inner::of(&[prim]) else { continue };
        frames += 1;
        for _ in 0..40 {
            // A point of the rectangle, its slopes (within ±16), and a
            // box around them.
            let (a, b) = (f(-1.0, 1.0) * hu, f(-1.0, 1.0) * hv);
            let p = [0, 1, 2].map(|i| c[i] + a * u[i] + b * v[i]);
            if p[2] <= 0.0 || (p[0] / p[2]).abs() > 15.0 || (p[1] / p[2]).abs() > 15.0 {
                continue;
            }
            let half = f(-16.0, -4.0).exp2();
            let s26 = |x: f64| (x * (1u64 << 26) as f64) as i32;
            let slopes = [
                s26(p[0] / p[2] - half),
                s26(p[0] / p[2] + half),
                s26(p[1] / p[2] - half),
                s26(p[1] / p[2] + half),
            ];
            if !q.covers(slopes) {
                continue;
            }
            covered += 1;
            let [x0, x1, y0, y1] = slopes;
            for k in 0..16 {
                let (x, y) = match k {
                    0 => (x0, y0),
                    1 => (x0, y1),
                    2 => (x1, y0),
                    3 => (x1, y1),
                    _ => (
                        s26(f(x0 as f64, x1 as f64) / (1u64 << 26) as f64),
                        s26(f(y0 as f64, y1 as f64) / (1u64 << 26) as f64),
                    ),
                };
                let (x, y) = (x.clamp(x0, x1), y.clamp(y0, y1));
                let mut ray = [Ray::new::<true>(x, y, 0)];
                let expect = ray[0].plane_t::<true>(n30, dist, recip_z(n30)).map(|(t, _)| t);
                prim.shape.nearest::<true, false>(3, &mut ray, (None, [0; 4]));
                rays_checked += 1;
                assert!(
                    expect.is_some() && ray[0].t == expect.unwrap_or(0) && ray[0].hit & !AWAY == 3,
                    "a ray of a covered box fails the test: slopes {x} {y}, box {slopes:?}, c {c:?} n {n:?}"
                );
            }
        }
    }
    assert!(
        frames > 2000 && covered > 20_000,
        "{frames} rectangles, {covered} boxes covered"
    );
    std::println!("{frames} rectangles with a region, {covered} boxes covered, {rays_checked} rays");
}

/// The sphere of centre `c` and radius `r` (metres, unit `U` = 1 m) as
/// `Mix32::fill` makes it, with its centre (S24) and its `1/r` (`None`
/// where `recip_len` has none).
fn sphere_shape(c: [f64; 3], r: f64) -> Option<(MixShape, [i32; 3], (u32, u32))> {
    let q = |x: f64| Q::from_num(x);
    let c24 = c.map(|x| len_s(q(x), 0, 24));
    let r24 = len_s(q(r), 0, 24);
    let r18 = len_s(q(r), 0, 18) as u64;
    let inv_r = recip_len(q(r), 0)?;
    let shape = MixShape::Sphere {
        cz50: (c24[2] as i64) << 26,
        c: c24,
        c18: c.map(|x| len_s(q(x), 0, 18)),
        r2_24: sat32((r24 as i64 * r24 as i64) >> 24),
        r2: r18 * r18,
        r24,
        fine: false,
        inv_r,
    };
    Some((shape, c24, inv_r))
}

/// [`Mix32::hit_from`]'s sphere normal without saturation: at every hit
/// of random spheres (radius 2⁻¹⁰ to 4 U, within the content's 8 U),
/// by rays at random points of their surface and grazing their
/// silhouettes, `(p − c)/r` in S30 fits i32 — [`sar64_low`] gives the
/// saturated value — and lies below 1.5 in magnitude; and
/// [`fine_normal`]'s is a unit vector within 10 %. Both shift in words
/// ([`sar64_low_lt32`]): `recip_len`'s shift is 9 to 22 for radii from
/// 2⁻¹⁰ U to the content's 8 U.
#[test]
fn a_sphere_hits_normal_fits_without_saturation() {
    let mut s = 0x5fe3_e0a1_d00d_0001;
    let mut f = |lo: f64, hi: f64| lo + (hi - lo) * (rng(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
    let (mut hits, mut widest) = (0u32, 0f64);
    let unit = unit3;
    for r in [2f64.powi(-10), 8.0] {
        let sh = recip_len(Q::from_num(r), 0).map(|(_, sh)| sh);
        assert!(sh.is_some_and(|sh| (9..=22).contains(&sh)), "r {r}: {sh:?}");
    }
    for case in 0..3000 {
        let r = f(-10.0, 2.0).exp2();
        let c = [f(-4.0, 4.0), f(-4.0, 4.0), f(0.0, 6.0)];
        let lc = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        if lc + r > 8.0 || c[2] - r <= 0.01 {
            continue;
        }
        let Some((shape, c24, inv_r)) = sphere_shape(c, r) else {
            continue;
        };
        let (r24, c18) = match shape {
            MixShape::Sphere { r24, c18, .. } => (r24, c18),
            _ => continue,
        };
        // `fine_normal` shifts by `inv_r.1 + 6` in words, `hit_from` by
        // `inv_r.1`: both below 32 for any radius within the content's 8 U.
        assert!((9..=22).contains(&inv_r.1), "r {r}: shift {}", inv_r.1);
        for k in 0..40 {
            // A random point of the surface, or one on the silhouette
            // (perpendicular to the centre's direction) moved out or
            // in by up to 10⁻⁶ r.
            let dir = unit([f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)]);
            let u = if k % 2 == 0 {
                dir
            } else {
                let d = dir[0] * c[0] / lc + dir[1] * c[1] / lc + dir[2] * c[2] / lc;
                unit([0, 1, 2].map(|i| dir[i] - d * c[i] / lc)).map(|x| x * (1.0 + f(-1e-6, 1e-6)))
            };
            let p = [0, 1, 2].map(|i| c[i] + r * u[i]);
            if p[2] <= 0.0 || (p[0] / p[2]).abs() > 15.0 || (p[1] / p[2]).abs() > 15.0 {
                continue;
            }
            let s26 = |x: f64| (x * (1u64 << 26) as f64) as i32;
            let mut ray = [Ray::new::<true>(s26(p[0] / p[2]), s26(p[1] / p[2]), 0)];
            for exact in [false, true] {
                ray[0].t = NO_HIT;
                if exact {
                    shape.sphere_pass::<true, true>(3, &mut ray);
                } else {
                    shape.sphere_pass::<true, false>(3, &mut ray);
                }
                if ray[0].t == NO_HIT {
                    continue;
                }
                hits += 1;
                // The lobe's normal from the ray and the sphere: unit
                // within its errors (a wrapped component would not be).
                let (n, v) = fine_normal::<true, false>(&ray[0], c24, r24, inv_r, ray[0].hit & AWAY != 0);
                assert_eq!(v, Mix32::view::<true>(&ray[0]));
                let n2: f64 = n.iter().map(|&x| (x as f64 / (1u64 << 30) as f64).powi(2)).sum();
                assert!(
                    (0.9..1.1).contains(&n2),
                    "case {case}: fine normal {n:?}, r {r} c {c:?}"
                );
                let pt = ray[0].hit_point::<true, false>([0, 0]);
                for (p, c) in pt.into_iter().zip(c18) {
                    let v = smul_u(p.saturating_sub(c), inv_r.0);
                    let want = sat32(sar64(v, inv_r.1));
                    assert_eq!(
                        want,
                        sar64_low_lt32(v, inv_r.1),
                        "case {case}: r {r} c {c:?} p {p}"
                    );
                    widest = widest.max((want as f64 / (1u64 << 30) as f64).abs());
                }
            }
        }
    }
    assert!(hits > 20_000 && widest < 1.5, "{hits} hits, widest {widest}");
    std::println!("{hits} hits, widest normal component {widest:.6}");
}

/// `a` scaled to unit length.
fn unit3(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|x| x / l)
}

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// An orthonormal frame `[n, u, v]` from three random angles (`n`
/// anywhere, so tilted up to grazing).
fn random_frame(f: &mut impl FnMut(f64, f64) -> f64) -> [[f64; 3]; 3] {
    let (th, ph, ro) = (f(0.0, 3.1), f(-3.2, 3.2), f(-3.2, 3.2));
    let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
    let t0 = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = unit3(cross3(n, t0));
    let e2 = cross3(n, e1);
    let u = [0, 1, 2].map(|i| e1[i] * ro.cos() + e2[i] * ro.sin());
    [n, u, cross3(n, u)]
}

/// The rectangle of centre `c`, axes `u`, `v` and half sizes `h` (U) as
/// [`Mix32::fill`] stores it for perspective rays (the unit 1 U), with
/// its normal (S30) and `dist` (S24).
fn rect_shape(frame: [[f64; 3]; 3], c: [f64; 3], h: [f64; 2]) -> (MixShape, [i32; 3], i32) {
    rect_shape_along(frame, c, h, ALONG_S42)
}

/// [`rect_shape`] for [`Ray::along`]'s format S48 less `along` (`ALONG_S42`
/// for perspective rays, 0 for parallel ones).
fn rect_shape_along(
    [n, u, v]: [[f64; 3]; 3],
    c: [f64; 3],
    [hu, hv]: [f64; 2],
    along: u32,
) -> (MixShape, [i32; 3], i32) {
    let s30 = |a: [f64; 3]| a.map(|x| (x * (1u64 << 30) as f64).round() as i32);
    let (n30, u30, v30) = (s30(n), s30(u), s30(v));
    let s24 = |x: f64| (x * (1u64 << 24) as f64).floor() as i32;
    let c24 = c.map(s24);
    let dist = ((n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) * (1u64 << 24) as f64).round() as i32;
    let dot48 = |a: [i32; 3], b: [i32; 3]| -> i64 { a.iter().zip(b).map(|(x, y)| wmul(*x, y)).sum() };
    let shape = MixShape::Rect {
        n: n30,
        dist,
        rz: recip_z(n30),
        u: u30,
        v: v30,
        cu: dot48(c24, u30) >> (along + 6),
        cv: dot48(c24, v30) >> (along + 6),
        hu: (s24(hu) as i64) << (24 - along),
        hv: (s24(hv) as i64) << (24 - along),
    };
    (shape, n30, dist)
}

/// [`MixChecker::cell`]'s `bounded`: a ray's hit on a rectangle within
/// the content's 8 U, along any unit axis less any origin within 8 U
/// ([`Ray::along`]), lies far inside the S18 range — the shift without
/// saturation gives [`shr_sat`]'s value. Random rectangles, tilted to
/// grazing, and rays at their points and just beyond their edges (the
/// full test decides the hit).
#[test]
fn a_bounded_hit_along_any_axis_needs_no_saturation() {
    let mut s = 0x0b0d_ed00_cafe_f00d;
    let mut f = |lo: f64, hi: f64| lo + (hi - lo) * (rng(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
    let (mut hits, mut widest) = (0u32, 0i64);
    for _ in 0..3000 {
        let [n, u, v] = random_frame(&mut f);
        let c = [f(-4.0, 4.0), f(-4.0, 4.0), f(0.1, 5.0)];
        let (hu, hv) = (f(-6.0, 1.5).exp2(), f(-6.0, 1.5).exp2());
        // Within the content's 8 U: every corner.
        let corner = |a: f64, b: f64| [0, 1, 2].map(|i| c[i] + a * hu * u[i] + b * hv * v[i]);
        let len = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        if [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .iter()
            .any(|&(a, b)| len(corner(a, b)) > 8.0)
        {
            continue;
        }
        let (shape, ..) = rect_shape([n, u, v], c, [hu, hv]);
        let s30 = |a: [f64; 3]| a.map(|x| (x * (1u64 << 30) as f64).round() as i32);
        let dot48 = |a: [i32; 3], b: [i32; 3]| -> i64 { a.iter().zip(b).map(|(x, y)| wmul(*x, y)).sum() };
        for _ in 0..30 {
            // A point of the rectangle or just beyond an edge.
            let p = corner(f(-1.1, 1.1), f(-1.1, 1.1));
            if p[2] <= 0.0 || (p[0] / p[2]).abs() > 15.0 || (p[1] / p[2]).abs() > 15.0 {
                continue;
            }
            let s26 = |x: f64| (x * (1u64 << 26) as f64) as i32;
            let mut ray = [Ray::new::<true>(s26(p[0] / p[2]), s26(p[1] / p[2]), 0)];
            shape.nearest::<true, false>(3, &mut ray, (None, [0; 4]));
            if ray[0].hit & !AWAY != 3 || ray[0].t == NO_HIT {
                continue;
            }
            hits += 1;
            // A checker's axis and origin (S18, within 8 U).
            let a = unit3([f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)]);
            let o = unit3([f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)]).map(|x| x * f(0.0, 8.0));
            let (a30, o18) = (s30(a), o.map(|x| (x * (1u64 << 18) as f64).round() as i32));
            let w = ray[0].along::<true>(ray[0].t, a30) - (dot48(o18, a30) >> ALONG_S42);
            assert_eq!(
                shr_sat::<24>(w),
                (w >> 24) as i32,
                "w {w}: c {c:?} n {n:?} p {p:?}"
            );
            widest = widest.max((w >> 24).abs());
        }
    }
    // Below 2^9 U of the S18 i32's 2^13 U (S18: 2^27).
    assert!(hits > 20_000 && widest < 1 << 27, "{hits} hits, widest {widest}");
    std::println!(
        "{hits} hits, widest |w| {:.2} U",
        widest as f64 / (1u64 << 18) as f64
    );
}

/// The closed run's shaded rays by mask are those `next_shaded` visits,
/// for every run it takes (3 to 32 rays) and every mean.
#[test]
fn shaded_mask_is_next_shaded() {
    for m in [
        ClosedMean::Off,
        ClosedMean::Pairs,
        ClosedMean::Quads,
        ClosedMean::Octs,
    ] {
        for len in 3..=CHUNK {
            let (mut q, mut visited) = (0, 0u32);
            while q < len {
                visited |= 1 << q;
                q = m.next_shaded(q, len);
            }
            assert_eq!(m.shaded_mask(len), visited, "{m:?}, {len} rays");
            assert_eq!(visited.count_ones() as usize, m.shaded(len));
        }
    }
}

/// [`fill_lanes`] gives [`fill_rays`]' rays (every field), `ŷ` range and
/// outside flag, and moves `acc` as its slopes do, on random rows with
/// and without distortion and vignetting, some rays outside the field.
#[cfg(target_arch = "x86_64")]
#[test]
fn ray_lanes_are_fill_rays() {
    let mut s = 0x0fa5_7ea7_0000_0005u64;
    let mut r = |lo: i64, hi: i64| lo + (rng(&mut s) % (hi - lo + 1) as u64) as i64;
    let (mut outside_rays, mut centred) = (0, 0);
    for case in 0..4000 {
        // Steps S58 (2^-18 to 2^-4 a pixel), slopes S26 within 2 (the
        // field's u ≤ 2 at most: `limit` S20), k1, k2 S28 within ¼.
        let dx = r(1 << 40, 1 << 54);
        let mut acc = r(-(1 << 59), 1 << 59);
        let yd = r(-(3 << 25), 3 << 25) as i32;
        let yd2 = yd as i64 * yd as i64;
        let k = (case % 3 != 0).then(|| [r(-(1 << 26), 1 << 26) as i32, r(-(1 << 26), 1 << 26) as i32]);
        let limit = r(1 << 18, 1 << 21) as i32;
        let vignette = case % 2 == 0;
        // The area factor over 2^e (e 0 to 6, some below J: the frame's
        // bound is not checked here, and both forms wrap alike).
        let area = k.and_then(|_| (case % 5 < 3).then(|| r(0, 6) as u32));
        let count = r(1, CHUNK as i64) as usize;
        let (mut lanes, mut scalar) = (Rays::default(), Rays::default());
        let (Some(lanes), Some(scalar)) = (lanes.first(count), scalar.first(count)) else {
            continue;
        };
        // `fill_rays` ray by ray (`mono` false), then with `mono` where
        // `ŷ` is monotone in `|x̂_d|`: a range that holds the rays', the
        // same one unless the chunk's ends lie either side of the centre.
        let mono = k.is_none_or(|[k1, k2]| k1 >= 0 && k2 >= 0);
        let mut want = ([0; 2], false);
        let mut a2 = acc;
        // (The second pass only where `mono` holds: without it, the
        // same call again.)
        for mono in [false, true].into_iter().take(1 + usize::from(mono)) {
            a2 = acc;
            let xd = || {
                let xd = (a2 >> 32) as i32;
                a2 -= dx;
                xd
            };
            let got = match k {
                Some(k) => fill_rays::<true>(
                    scalar,
                    0,
                    xd,
                    (yd, yd2),
                    |x, y, y2| undistort_kj(k, limit, (x, y, y2), area),
                    (vignette, area.is_some(), true, mono, || {
                        undistort_k(k, limit, 0, yd, yd2).map(|(_, y)| y)
                    }),
                ),
                None => fill_rays::<true>(
                    scalar,
                    0,
                    xd,
                    (yd, yd2),
                    |x, y, _| Some((x, y, 1 << 31)),
                    (vignette, false, true, mono, || Some(yd)),
                ),
            };
            if !mono {
                want = got;
                continue;
            }
            let ([y0, y1], [w0, w1]) = (got.0, want.0);
            assert!(
                y0 <= w0 && y1 >= w1 && got.1 == want.1,
                "case {case}: {got:?} for {want:?}"
            );
            let across = scalar
                .first()
                .zip(scalar.last())
                .is_some_and(|(a, b)| (a.x ^ b.x) < 0);
            assert!(got == want || across, "case {case}: {got:?} for {want:?}");
            centred += usize::from(across && got != want);
        }
        let got = fill_lanes(lanes, &mut acc, dx, (yd, yd2), (k, limit), (vignette, area));
        assert_eq!(got, want, "case {case}");
        assert_eq!(acc, a2, "case {case}");
        for (q, (l, w)) in lanes.iter().zip(scalar.iter()).enumerate() {
            assert_eq!(format!("{l:?}"), format!("{w:?}"), "case {case} ray {q}");
            outside_rays += usize::from(w.t == 0);
        }
    }
    // (31 760 of 66 000 or so.)
    assert!(outside_rays > 1_000, "{outside_rays} rays outside the field");
    // Chunks across the centre whose range `mono` widened.
    assert!(centred > 10, "{centred} ranges widened at the centre");
}

#[test]
fn the_non_negative_product_is_the_scalar_product() {
    use crate::num::scalar::Scalar;
    let mut s = 0x5eed_0000_0000_0001;
    for _ in 0..200_000 {
        let (a, b) = (
            rng(&mut s) >> (rng(&mut s) % 64),
            rng(&mut s) >> (rng(&mut s) % 64),
        );
        // (And both below 2^16 DN: `mul_nonneg`'s 64-bit path.)
        // (The cases halve them: 2^49 − 1 is 2^16 − 2^-32 DN.)
        let small = (
            a.checked_shr((rng(&mut s) % 64 + 16) as u32).unwrap_or(0),
            b.checked_shr((rng(&mut s) % 64 + 16) as u32).unwrap_or(0),
        );
        let top = u64::MAX >> 15;
        for (a, b) in [
            (a, b),
            (a, u64::MAX),
            (a, 0),
            (a, 1 << 32),
            small,
            (small.0, top),
            (top, top),
        ] {
            let (a, b) = (Q::from_bits((a >> 1) as i64), Q::from_bits((b >> 1) as i64));
            assert_eq!(mul_nonneg(a, b), a.mul(b), "{a:?} * {b:?}");
        }
    }
}

/// [`store`] writes a chunk's words and flags as a byte (or two
/// little-endian) a pixel would, forward and reversed, for every
/// length from 0 to [`CHUNK`] (the four-a-step loop and each tail),
/// and nothing past them.
#[test]
fn stored_words_and_flags_are_each_pixels_bytes() {
    for len in 0..=CHUNK {
        let words: [u16; CHUNK] = core::array::from_fn(|q| (q as u16).wrapping_mul(0x9e37) ^ 0x5a);
        let fl: [u8; CHUNK] = core::array::from_fn(|q| (q as u8).wrapping_mul(37) | 1);
        for (b, reversed) in [(1, false), (1, true), (2, false), (2, true)] {
            let (mut out, mut flags) = ([0xeeu8; 2 * CHUNK + 2], [0xeeu8; CHUNK + 1]);
            store(
                &words[..len],
                &fl[..len],
                reversed,
                b,
                &mut out[..len * b],
                &mut flags[..len],
            );
            for q in 0..len {
                let src = if reversed { len - 1 - q } else { q };
                let want = words[src].to_le_bytes();
                assert_eq!(
                    out[q * b..(q + 1) * b],
                    want[..b],
                    "len {len} b {b} reversed {reversed} q {q}"
                );
                assert_eq!(flags[q], fl[src], "len {len} b {b} reversed {reversed} q {q}");
            }
            assert!(out[len * b..].iter().chain(&flags[len..]).all(|&v| v == 0xee));
        }
    }
}

/// [`vignette_dn`] (its in-line case below 2³², its out-of-line case
/// above) and the lanes' [`vignette_dn_words`] are the exact rounding
/// of `sum · cos⁴α`, capped: sums up to [`SUM_CAP`], `cos⁴α` up to 1.
/// (The M0's case below 2³², [`round_c4_words`]: the next test.)
#[test]
fn vignette_dn_is_the_exact_rounding() {
    let exact = |sum: u64, c4: u32, max: u32| {
        (((sum as u128 * c4 as u128 + (1 << 45)) >> 46).min(max as u128)) as u32
    };
    let mut s = 0x5eed_0dd5_0000_0042;
    for i in 0..1_000_000u32 {
        let c4 = ((rng(&mut s) as u32) >> (rng(&mut s) % 32) >> 1).max(1 << 13) | (i & 1) << 30;
        let c4 = if i % 7 == 0 { 1 << 31 } else { c4.min(1 << 31) };
        let sum = (rng(&mut s) >> (rng(&mut s) % 64)).min(SUM_CAP);
        for max in [255, 4095, 65535, 31] {
            assert_eq!(
                vignette_dn(sum, c4, max),
                exact(sum, c4, max),
                "sum {sum} c4 {c4}"
            );
            assert_eq!(
                vignette_dn_words(sum, c4).min(max),
                exact(sum, c4, max),
                "sum {sum} c4 {c4}"
            );
        }
    }
    for sum in [0, (1 << 32) - 1, 1 << 32, SUM_CAP] {
        assert_eq!(
            vignette_dn(sum, 1 << 31, 65535),
            exact(sum, 1 << 31, 65535),
            "sum {sum}"
        );
    }
}

/// The M0's rounding of a sum below 2³² times `cos⁴α` from three
/// products where the fourth's carries cannot matter: every `c4` near
/// 2³¹ and the carries' edge exhaustively, random pairs elsewhere.
#[test]
fn vignette_in_three_products_is_vignette_dn() {
    let exact = |lo: u32, c4: u32| ((lo as u64 * c4 as u64 + (1 << 45)) >> 46) as u32;
    let mut s = 0xc4c4_0000_0000_0011;
    for i in 0..2_000_000u32 {
        let c4 = if i % 4 == 0 {
            (1u32 << 31) - (rng(&mut s) as u32 % 4096)
        } else {
            (rng(&mut s) as u32) >> 1 | (i & 1) << 31 >> 1
        }
        .min(1 << 31);
        let lo = (rng(&mut s) as u32) >> (rng(&mut s) % 32);
        assert_eq!(round_c4_words(lo, c4), exact(lo, c4), "lo {lo} c4 {c4}");
    }
    // Where t's low bits lie at the edge: lo chosen so that lo c4 / 2^32
    // ends near 0x3FFF − 2^13 in its low 14 bits.
    for c4 in [1u32 << 31, (1 << 31) - 1, 0x4000_0001, 0x7654_3210, 12_345_679] {
        for k in 0..20_000u64 {
            let target = ((k << 14) | 0x1FFE) << 32;
            let lo = (target / c4 as u64).min(u32::MAX as u64) as u32;
            for d in 0..4 {
                let lo = lo.saturating_add(d);
                assert_eq!(round_c4_words(lo, c4), exact(lo, c4), "lo {lo} c4 {c4}");
            }
        }
    }
}

/// The M0's products in 32-bit words ([`mul_hi_64_words`],
/// [`mul_shr61_words`]) are the 128-bit forms the other targets
/// compute.
#[test]
fn high_words_are_the_128_bit_products() {
    let mut s = 0x4a11_0000_0000_0009;
    let ends = [0, 1, u32::MAX as u64, 1 << 32, u64::MAX - 1, u64::MAX];
    for i in 0..200_000 {
        let (a, b) = if i < 36 {
            (ends[i % 6], ends[i / 6])
        } else {
            (
                rng(&mut s) >> (rng(&mut s) % 64),
                rng(&mut s) >> (rng(&mut s) % 64),
            )
        };
        assert_eq!(
            mul_hi_64_words(a, b),
            ((a as u128 * b as u128) >> 64) as u64,
            "{a} {b}"
        );
        let y = b as u32;
        let f = a >> 2;
        assert_eq!(
            mul_shr61_words(y, f),
            ((y as u128 * f as u128) >> 61) as u64,
            "{y} {f}"
        );
    }
}

/// [`rsqrt_top`]'s Newton factor `3·2³⁰ − m y²`, taken without
/// saturation on the M3 and M4F, never wraps.
#[test]
fn rsqrt_tops_newton_factor_never_wraps() {
    // m y² rises with m under one seed: the top of each seed's range
    // of m bounds it (3·2^30 − m y² is taken without saturation).
    for idx in 0..768u32 {
        let top = ((idx + 257) << 22).wrapping_sub(1).max(1 << 30);
        let seed = SEED[idx as usize];
        let my2 = (umul_px(top, (seed as u32 * seed as u32) << 1) >> 31) as u32;
        assert!(my2 < 3 << 30, "entry {idx}: m y² {my2}");
        // The saturating form it replaced gives the same y.
        assert_eq!(
            rsqrt_top(top),
            (umul_h((3u32 << 30).saturating_sub(my2), seed) >> 15) as u32
        );
    }
}

/// [`mul_h_words`] is `⌊a b / 2^S⌋` where `recip` (`S` 14, `a < 2³¹`)
/// and `rsqrt_top` (`S` 15, `a < 3·2³⁰`) take it, for their seeds (every
/// 7th and the last), at the ends of `a` and on every 65 521st between.
#[test]
fn products_in_words_are_the_floors() {
    let a_all = |top: u32| {
        [0, 1, 0xFFFF, 0x1_0000, top - 1, top]
            .into_iter()
            .chain((0..top).step_by(65_521))
    };
    for &b in RECIP_SEED.iter().step_by(7).chain(RECIP_SEED.last()) {
        for a in a_all((1 << 31) - 1) {
            assert_eq!(
                mul_h_words::<14>(a, b) as u64,
                (a as u64 * b as u64) >> 14,
                "{a} {b}"
            );
        }
    }
    for &b in SEED.iter().step_by(7).chain(SEED.last()) {
        for a in a_all(3 << 30) {
            assert_eq!(
                mul_h_words::<15>(a, b) as u64,
                (a as u64 * b as u64) >> 15,
                "{a} {b}"
            );
        }
    }
}

/// [`rsqrt_top`] from the products' high words (and `SEED_BY_TOP`) on the
/// M3 and M4F, and [`newton_words`] on the M0, are the Newton step as written: `y² m` over 2³¹ and `f y`
/// over 2¹⁵ (every seed's `4 y²` fits a word), at both ends of each
/// seed's range of `m` and on every 4 099th `m` between.
#[test]
fn rsqrt_top_is_the_newton_step() {
    let step = |m: u32| {
        let seed = SEED[((m >> 22) - 256) as usize] as u64;
        let my2 = (m as u64 * (seed * seed * 2)) >> 31;
        ((((3u64 << 30) - my2) * seed) >> 15) as u32
    };
    assert!(SEED.iter().all(|&y| 4 * (y as u64).pow(2) < 1 << 32));
    let ends = (256..1024u32).flat_map(|t| [t << 22, (t << 22) | ((1 << 22) - 1)]);
    for m in ends.chain(((1u32 << 30)..=u32::MAX).step_by(4099)) {
        assert_eq!(rsqrt_top(m), step(m), "m {m:#x}");
        // The M0's form.
        assert_eq!(
            newton_words(m, SEED[((m >> 22) - 256) as usize]),
            step(m),
            "m {m:#x}"
        );
    }
}

/// [`sigma_z16`]'s `σ` taken from the top word of `m y` is the 64-bit
/// shift's (with its saturation) it replaced: `m y < 2⁶²` on every `m`
/// near `2³²` (where the Newton step's truncations could carry it
/// over: the top 2²⁰ exhaustively) and on random `σ²` everywhere.
#[test]
fn sigma_from_the_top_word_is_the_wide_shifts() {
    let wide = |s2: u64, z: i32| {
        if s2 == 0 {
            return 0;
        }
        let (m, y, e) = rsqrt_norm(s2);
        let s16 = (umul(m, y) >> (30 + e / 2)).min(u32::MAX as u64);
        s16 as i64 * z as i64
    };
    for m in (1u64 << 32) - (1 << 20)..1 << 32 {
        let y = rsqrt_top(m as u32);
        assert!(umul(m as u32, y) < 1 << 62, "m {m}: y {y}");
        assert_eq!(sigma_z16(m << 32, 65_536), wide(m << 32, 65_536), "m {m}");
    }
    let mut s = 0x5167_a000_0000_0003;
    for _ in 0..400_000 {
        let s2 = rng(&mut s) >> (rng(&mut s) % 64);
        let z = (rng(&mut s) % 1_200_000) as i32 - 600_000;
        assert_eq!(sigma_z16(s2, z), wide(s2, z), "s2 {s2} z {z}");
    }
    // Its normalization in words is `rsqrt_norm`'s, at every count.
    for k in 0..64 {
        for s2 in [
            1u64 << k,
            (1u64 << k) | 1,
            (2u64 << k).wrapping_sub(1),
            rng(&mut s) >> (63 - k),
        ] {
            let (m, _, e) = rsqrt_norm(s2.max(1));
            assert_eq!(norm_top_even(s2.max(1)), (m, e), "s2 {s2}");
        }
    }
}

/// Below [`lobe_below`] the exact lobe `(x 2⁻³⁰)^s` is at most 2⁻⁶⁴, so
/// its term (below 2⁻¹⁵ DN where `shade` skips it) floors to 0; at it
/// the lobe is above 2⁻⁶⁴ to within the bound's slack, and
/// [`lobe_pf`] there is no larger than the exact power.
#[test]
fn below_lobe_below_the_lobe_vanishes() {
    assert_eq!(lobe_below(0), i32::MIN);
    for s in (1..=400u16).chain([1000, 4096, 65535]) {
        let b = lobe_below(s);
        let log = |x: i32| f64::from(s) * (libm::log2(f64::from(x)) - 30.0);
        assert!((1..=1 << 30).contains(&b), "s {s}: {b}");
        if b > 1 {
            assert!(log(b - 1) <= -64.0, "s {s}: {} above", log(b - 1));
        }
        assert!(log(b) > -64.0 - 1e-6 * f64::from(s), "s {s}: {}", log(b));
        let f = lobe_pf(b - 1, s).to_f64();
        assert!(f <= libm::exp2(-64.0), "s {s}: lobe_pf {f}");
    }
}

#[test]
fn the_noisy_value_is_the_noise_stages() {
    use crate::scene::{Noise, PixelFormat};
    let mut s = 0x0dd5_eed5_0000_0007;
    // Constants from the scene's ranges and beyond them (a saturation
    // below 1 e⁻, offsets and dark noise past any full scale).
    let q = |v: u64| Q::from_bits((v >> 1) as i64);
    for _ in 0..400 {
        let noise = Noise {
            saturation_e: q(rng(&mut s) >> (rng(&mut s) % 64)),
            dark_noise_e: q(rng(&mut s) >> (rng(&mut s) % 64)),
            dark_offset_dn: q(rng(&mut s) >> (rng(&mut s) % 64)),
            seed: rng(&mut s),
        };
        for format in [
            PixelFormat::Gray8,
            PixelFormat::Gray16 { bits: 12 },
            PixelFormat::Rgb565,
        ] {
            let stage = crate::render::sensor::noise::Stage::<Q>::new(&noise, format, rng(&mut s) as u32);
            for _ in 0..200 {
                let mu = Q::from_bits(rng(&mut s) as i64 >> (rng(&mut s) % 64));
                let (p, c) = (rng(&mut s) as u32, (rng(&mut s) % 3) as usize);
                let max = format.dn_max(c) as u16;
                assert_eq!(
                    noisy_dn(stage.draw(p, c), mu, max),
                    stage.apply_with(mu, p, c, max as u32, mul_nonneg, sigma_z),
                    "{noise:?} {format:?} mu {mu:?} pixel {p} channel {c}"
                );
            }
        }
    }
}

#[test]
fn reciprocal_square_root_and_square_root_within_2_pow_minus_19() {
    let mut s = 0x0123_4567_89AB_CDEF;
    let mut worst: f64 = 0.0;
    for _ in 0..200_000 {
        let x = rng(&mut s) >> (rng(&mut s) % 64);
        if x == 0 {
            continue;
        }
        let e = 2 * (rng(&mut s) % 40) as i32 - 40;
        let got = rsqrt(x, e).to_f64();
        let want = 1.0 / ((x as f64) * 2f64.powi(e)).sqrt();
        worst = worst.max((got / want - 1.0).abs());
        let r = sqrt_s44_to_s22(x >> 2) as f64;
        let w = ((x >> 2) as f64 * 2f64.powi(-44)).sqrt() * 2f64.powi(22);
        assert!((r - w).abs() <= 1.0 + w * 2f64.powi(-19), "sqrt {x}: {r} vs {w}");
    }
    assert!(worst < 2f64.powi(-19), "rsqrt relative error {worst:e}");
    // (n·l)/r³ over lengths from 2⁻¹⁸ to 2¹³ U and n̂·l̂ from 2⁻⁸ to 1.
    let mut worst3: f64 = 0.0;
    for _ in 0..100_000 {
        let len = rng(&mut s) % 31;
        let l = [0, 1, 2].map(|_| (rng(&mut s) >> (33 + len)) as i64 - (1i64 << (30 - len)));
        let r2: u64 = l.iter().map(|v| (v * v) as u64).sum();
        let cos = 2f64.powf(-8.0 * (rng(&mut s) % 1024) as f64 / 1024.0);
        let nl = (cos * (r2 as f64).sqrt() * 2f64.powi(30)) as u64;
        if r2 == 0 || nl == 0 {
            continue;
        }
        let want = nl as f64 * 2f64.powi(-48) / (r2 as f64 * 2f64.powi(-36)).powf(1.5);
        worst3 = worst3.max((cos_over_r2(nl, r2).to_f64() / want - 1.0).abs());
    }
    assert!(
        worst3 < 3.0 * 2f64.powi(-19) + 2f64.powi(-21),
        "(n·l)/r³ relative error {worst3:e}"
    );
}

#[test]
fn reciprocal_within_2_pow_minus_21() {
    let mut s = 0x5555_1234_9876_ABCD;
    let mut worst: f64 = 0.0;
    for i in 0..300_000u32 {
        let d = if i < 1000 {
            i + 1
        } else {
            (rng(&mut s) >> (rng(&mut s) % 64)) as u32 | 1
        };
        let (r, z) = recip(NonZeroU32::new(d).unwrap());
        // (Below 2^31: `smul_r` takes it as an i32.)
        assert!(r > 1 << 30 && r < 1 << 31, "d {d}: r {r}");
        let got = r as f64 * 2f64.powi(z as i32 - 62);
        worst = worst.max((got * d as f64 - 1.0).abs());
    }
    assert!(worst < 2f64.powi(-21), "relative error {worst:e}");
}

/// [`cos4`]'s `1/a` lies below 2³¹ in its S31 form for every `a` of
/// 2²⁰ (S20: 1) and more, so its square over 2³¹ is one product's high
/// word: exhaustively where the shift is 0 (`a` below 2²¹), and the value
/// is the square's.
#[test]
fn cos4_takes_a_high_word() {
    for a in (1u32 << 20)..1 << 21 {
        let (r, z) = recip(NonZeroU32::new(a).unwrap());
        assert!(z == 11 && r < 1 << 31, "a {a}: r {r} z {z}");
        assert_eq!(cos4((r, z)) as u64, (r as u64 * r as u64) >> 31, "a {a}");
    }
    for a in [(1u32 << 21), 3 << 21, 1 << 28, (513 << 20) - 1] {
        let (r, z) = recip(NonZeroU32::new(a).unwrap());
        let inv = (r >> (11 - z)) as u64;
        assert_eq!(cos4((r, z)) as u64, (inv * inv) >> 31, "a {a}");
    }
}

/// The product `plane_t` took before [`mul_shr_t`]: saturated to the
/// i32 limits.
fn mul_shr_var(v: i32, r: u32, sh: u32) -> i32 {
    let q = (smul_u(v, r) >> 31) as i32;
    if sh >= 31 {
        q >> (sh - 31).min(31)
    } else {
        let l = 31 - sh;
        if q.unsigned_abs().leading_zeros() > l {
            q << l
        } else if q < 0 {
            i32::MIN
        } else {
            i32::MAX
        }
    }
}

/// `plane_t`'s `t`: [`mul_shr_t`] negated where `n·d < 0` (or `n_z`, for
/// parallel rays) is what negating the product saturated to the i32
/// limits, then capping at `T_MAX`, gave, on every path (shifts right
/// and left, saturated or not), for numerators up to 2³⁰·⁵.
#[test]
fn plane_t_negation_is_the_saturating_one() {
    let mut s = 0x2468_ACE0_1357_9BDF;
    let mut saturated = 0;
    for i in 0..400_000u32 {
        // |v| below 1.5 2^30 (a parallel ray's numerator; |dist| ≤
        // 2^28), r in (2^30, 2^31) (`recip`'s), the shift 44 − z or 38 − z for z
        // in 0..=31.
        let v =
            ((rng(&mut s) >> (33 + rng(&mut s) % 31)) % (3 << 29)) as i32 * if i % 2 == 0 { 1 } else { -1 };
        let r = (1u32 << 30) + 1 + (rng(&mut s) % ((1 << 30) - 1)) as u32;
        let sh = 7 + (rng(&mut s) % 38) as u32;
        for den_neg in [false, true] {
            let old = mul_shr_var(v, r, sh);
            let old = if den_neg { old.saturating_neg() } else { old };
            let sg = -(den_neg as i32);
            let new = (mul_shr_t(v, r, sh) ^ sg).wrapping_sub(sg);
            assert_eq!(old > 0, new > 0, "v {v} r {r} sh {sh} neg {den_neg}");
            if old > 0 {
                assert_eq!(old.min(T_MAX), new, "v {v} r {r} sh {sh} neg {den_neg}");
                saturated += (new == T_MAX) as u32;
            }
        }
    }
    // The saturated path is taken.
    assert!(saturated > 1000, "{saturated}");
}

#[test]
fn pseudo_float_products_and_saturation() {
    let a = Pf::new(3, 0);
    let b = Pf::new(5, -1);
    assert_eq!((a * b).to_f64(), 7.5);
    assert_eq!((a * b).to_sum(1), 15);
    assert_eq!(Pf::new(1, 40).to_sum(0), 1 << 40);
    assert_eq!(Pf::new(1, 50).to_sum(0), SUM_CAP);
    assert_eq!(a.mul_to_sum(b, 2), 30);
    assert_eq!(a.mul_to_sum(Pf::new(1, 60), 0), SUM_CAP);
    assert_eq!(a.mul_to_sum(Pf::new(1, -80), 0), 0);
    assert_eq!(Pf::new(1, -40).to_sum(0), 0);
    assert_eq!((Pf::default() * a).to_sum(15), 0);
}

/// [`Ray::plane_beyond`] says a plane is beyond a hit at `t` only where
/// [`Ray::plane_t`] gives no `t` or one above it: on random
/// denominators and heights over every leading-zero count, with `t`
/// drawn around the plane's own (ties within a few units included), on
/// both signs; and it decides most rays that are well short of the plane.
#[test]
fn plane_beyond_is_plane_t_s() {
    let mut s = 0x9e37_79b9_7f4a_7c15;
    let (mut decided, mut short) = (0u32, 0u32);
    for i in 0..400_000u32 {
        // (|n·d| < 2^29: a unit normal's, S30, on slopes within ±32.)
        let den = ((rng(&mut s) >> (rng(&mut s) % 63)) as u32 >> 3) as i32;
        let dist = ((rng(&mut s) >> (36 + rng(&mut s) % 28)) % (1 << 28)) as i32;
        let (den, dist) = match i % 4 {
            0 => (den, dist),
            1 => (-den, -dist),
            2 => (-den, dist),
            _ => (den, -dist),
        };
        // A ray whose n·d is den: n = (1, 0, 0) (S30), x̂ = 4 den (S26).
        let ray = Ray::flat(4 * den, 0);
        assert_eq!(ray.n_dot_d([1 << 30, 0, 0]), den);
        let exact = ray.plane_t::<true>([1 << 30, 0, 0], dist, (0, 0));
        // t near the plane's (±8 units, or a relative 2^-k), or anywhere.
        let base = exact.map_or(rng(&mut s) as i32 & i32::MAX, |(t, _)| t);
        let t = match rng(&mut s) % 4 {
            0 => base.saturating_add((rng(&mut s) % 17) as i32 - 8),
            1 => base.saturating_sub(((base as u64) >> (rng(&mut s) % 40)) as i32),
            2 => (rng(&mut s) >> 33) as i32,
            _ => base,
        }
        .clamp(0, NO_HIT);
        let beyond = Ray::plane_beyond(den, dist, t, Ray::beyond_limit(dist));
        if beyond {
            if let Some((tp, _)) = exact {
                assert!(tp > t, "den {den} dist {dist}: plane at {tp}, said beyond {t}");
                decided += 1;
            }
        }
        if let Some((tp, _)) = exact {
            // Well short: by 2^-10 of the plane's t and 16 units, on a plane above 2^-8
            // U (S24) that the ray does not graze (|n·d| above 2^-8).
            let seen = den.unsigned_abs() > 1 << 16 && dist.unsigned_abs() > 1 << 16;
            if seen && tp < T_MAX && (t as i64) < tp as i64 - (tp as i64 >> 10) - 16 {
                short += 1;
                assert!(beyond, "den {den} dist {dist}: plane at {tp}, {t} undecided");
            }
        }
    }
    assert!(decided > 10_000 && short > 1_000, "{decided} {short}");
}

/// A perspective ray's hit on a rectangle, as a texture coordinate
/// ([`Ray::along`] less the origin's, floored to S18 U as
/// [`MixChecker::cell`] takes it), against the exact coordinate of the
/// same ray (its S26 slopes) on the exact plane: within the bound the
/// planner's `HitError` gives the fast arithmetic (`planner.rs`: `(|â·d|
/// ε_t + ε_a)/w + |â·d| ε_w/(|dist| w²) + (|â·d| + 1/2 + 2⁻⁵) 2⁻¹⁸ U`,
/// `ε_t = 2⁻²¹ + 2⁻²⁴ U/|dist|`, `ε_w = ε_a = 2⁻²⁴`, `w = n̂·d/dist`) on
/// every ray, and on average within half of it, which the planner takes
/// as the mean error. Random rectangles within the content's 8 U, tilted
/// to grazing. The origin's term is computed here as `Mix32::fill`
/// computes it (a change there must be made here too).
#[test]
fn a_hit_s_texture_coordinate_is_within_the_planner_s_hit_error() {
    let mut s = 0x0b0d_ed00_cafe_f00d;
    let mut f = |lo: f64, hi: f64| lo + (hi - lo) * (rng(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
    let ld = |k: i32| libm::ldexp(1.0, k);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let s30 = |a: [f64; 3]| a.map(|x| (x * (1u64 << 30) as f64).round() as i32);
    let dot48 = |a: [i32; 3], b: [i32; 3]| -> i64 { a.iter().zip(b).map(|(x, y)| wmul(*x, y)).sum() };
    let (mut n_rays, mut sum_err, mut sum_mean, mut worst) = (0u32, 0.0, 0.0, 0.0f64);
    for _ in 0..3000 {
        let [n, u, v] = random_frame(&mut f);
        let c = [f(-4.0, 4.0), f(-4.0, 4.0), f(0.1, 5.0)];
        let (hu, hv) = (f(-6.0, 1.5).exp2(), f(-6.0, 1.5).exp2());
        let corner = |a: f64, b: f64| [0, 1, 2].map(|i| c[i] + a * hu * u[i] + b * hv * v[i]);
        if [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .iter()
            .any(|&(a, b)| dot(corner(a, b), corner(a, b)) > 64.0)
        {
            continue;
        }
        let (shape, ..) = rect_shape([n, u, v], c, [hu, hv]);
        // The checker's axis, in the plane, from the centre (S24, as
        // `Mix32::fill` stores it).
        let a = unit3([0, 1, 2].map(|i| u[i] * f(-1.0, 1.0) + v[i] * f(-1.0, 1.0)));
        let a30 = s30(a);
        let ou =
            (dot48(c.map(|x| (x * (1u64 << 24) as f64).floor() as i32), a30) >> (ALONG_S42 + 6)) - (1 << 23);
        for _ in 0..30 {
            let p = corner(f(-0.9, 0.9), f(-0.9, 0.9));
            if p[2] <= 0.0 || (p[0] / p[2]).abs() > 2.0 || (p[1] / p[2]).abs() > 2.0 {
                continue;
            }
            let s26 = |x: f64| (x * (1u64 << 26) as f64) as i32;
            let (x26, y26) = (s26(p[0] / p[2]), s26(p[1] / p[2]));
            let mut ray = [Ray::new::<true>(x26, y26, 0)];
            shape.nearest::<true, false>(3, &mut ray, (None, [0; 4]));
            if ray[0].hit & !AWAY != 3 || ray[0].t == NO_HIT {
                continue;
            }
            let got = ((ray[0].along::<true>(ray[0].t, a30) - ou) >> 24) as f64 * ld(-18);
            let d = [x26 as f64 * ld(-26), y26 as f64 * ld(-26), 1.0];
            let dist = dot(n, c);
            let t = dist / dot(n, d);
            let exact = dot(a, [0, 1, 2].map(|i| t * d[i] - c[i]));
            let (w, ad) = ((1.0 / t).abs(), dot(a, d).abs());
            let et = ld(-21) + ld(-24) / dist.abs();
            let bound = (ad * et + ld(-24)) / w
                + ad * ld(-24) / (dist.abs() * w * w)
                + (ad + 0.5 + 1.0 / 32.0) * ld(-18);
            let e = (got - exact).abs();
            worst = worst.max(e / bound);
            sum_err += e;
            sum_mean += bound / 2.0;
            n_rays += 1;
        }
    }
    std::println!(
        "{n_rays} rays: |error| up to {worst:.3} of the bound; mean {:.3} 2⁻¹⁸ U against a mean of half the bound, {:.3}",
        sum_err / n_rays as f64 * 262_144.0,
        sum_mean / n_rays as f64 * 262_144.0
    );
    assert!(n_rays > 20_000, "{n_rays}");
    assert!(worst <= 1.0, "{worst}");
    assert!(sum_err <= sum_mean, "{sum_err} against {sum_mean}");
}

/// A disc's or rectangle's boundary, as the fast test reads it, moves by
/// at most the planner's bound ([`crate::planner::error_model::fast_boundary_m`]): for
/// each ray, the distance from the disc's centre (`√` of the test's
/// `|p − c|²`, less its radius) or the rectangle's margins (`|p·a − c_a| −
/// h`, S42) against the exact ones of the same ray (its S26 slopes, or its
/// S18 origin) on the exact shape, and the bound with this ray's in-plane
/// part, `t` and `1/|n̂·d|`. Random shapes within the content's 8 U, half
/// of them facing the camera to within 0.3 rad (a distant target's case),
/// the rest at any angle up to grazing; perspective and parallel rays at
/// points near their boundaries. The shapes are stored as `Mix32::fill`
/// stores them (a change there must be made here too).
#[test]
fn a_flat_shape_s_boundary_moves_within_the_planner_s_bound() {
    let mut s = 0xb0d7_da7e_5eed_1234;
    let mut f = |lo: f64, hi: f64| lo + (hi - lo) * (rng(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
    let ld = |k: i32| libm::ldexp(1.0, k);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let s30 = |a: [f64; 3]| a.map(|x| (x * ld(30)).round() as i32);
    let s24 = |x: f64| (x * ld(24)).floor() as i32;
    let (mut n_rays, mut worst, mut sum_ratio) = (0u32, 0.0f64, 0.0);
    for case in 0..6000 {
        let [n, u, v] = if case % 2 == 0 {
            random_frame(&mut f)
        } else {
            let (th, ph) = (f(0.0, 0.3), f(-3.2, 3.2));
            let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), -th.cos()];
            let e1 = unit3(cross3(n, [0.0, 1.0, 0.0]));
            [n, e1, cross3(n, e1)]
        };
        let persp = case % 3 != 0;
        let disc = case % 4 < 2;
        let c = [f(-2.0, 2.0), f(-2.0, 2.0), f(0.1, 7.5)];
        let (hu, hv) = (f(-7.0, 0.0).exp2(), f(-7.0, 0.0).exp2());
        let r = if disc { hu } else { (hu * hu + hv * hv).sqrt() };
        let lc = dot(c, c).sqrt();
        if lc + r > 8.0 {
            continue;
        }
        // `Mix32::fill`'s shapes, `along`'s format S42 (perspective) or S48.
        let along = if persp { ALONG_S42 } else { 0 };
        let (rect, n30, dist24) = rect_shape_along([n, u, v], c, [hu, hv], along);
        let (u30, v30) = (s30(u), s30(v));
        let dist = dot(n, c);
        let shape = if disc {
            let r24 = s24(r) as u64;
            MixShape::Disc {
                n: n30,
                dist: dist24,
                rz: recip_z(n30),
                c24: c.map(s24),
                r2: r24 * r24,
            }
        } else {
            rect
        };
        for _ in 0..20 {
            // A point near the boundary, within 1 % of it.
            let (a, b) = if disc {
                let phi = f(-3.2, 3.2);
                let rho = r * f(0.99, 1.01);
                (rho * phi.cos(), rho * phi.sin())
            } else if f(0.0, 1.0) < 0.5 {
                (hu * f(0.99, 1.01) * f(-1.0, 1.0).signum(), hv * f(-1.0, 1.0))
            } else {
                (hu * f(-1.0, 1.0), hv * f(0.99, 1.01) * f(-1.0, 1.0).signum())
            };
            let p = [0, 1, 2].map(|i| c[i] + a * u[i] + b * v[i]);
            if p[2] <= 0.0 {
                continue;
            }
            // The ray as the core holds it, and its exact direction and
            // start.
            let (ray, d, o) = if persp {
                if (p[0] / p[2]).abs() > 2.0 || (p[1] / p[2]).abs() > 2.0 {
                    continue;
                }
                let s26 = |x: f64| (x * ld(26)) as i32;
                let (x26, y26) = (s26(p[0] / p[2]), s26(p[1] / p[2]));
                let d = [x26 as f64 * ld(-26), y26 as f64 * ld(-26), 1.0];
                (Ray::new::<true>(x26, y26, 0), d, [0.0; 3])
            } else {
                let mut ray = Ray::new::<false>(0, 0, 0);
                (ray.ox, ray.oy) = ((p[0] * ld(18)) as i32, (p[1] * ld(18)) as i32);
                let o = [ray.ox as f64 * ld(-18), ray.oy as f64 * ld(-18), 0.0];
                (ray, [0.0, 0.0, 1.0], o)
            };
            let hit = if persp {
                ray.plane_t::<true>(n30, dist24, recip_z(n30))
            } else {
                ray.plane_t::<false>(n30, dist24, recip_z(n30))
            };
            let Some((t, _)) = hit else {
                continue;
            };
            let nd = dot(n, d);
            let te = (dist - dot(n, o)) / nd;
            if te <= 0.0 {
                continue;
            }
            let pe = [0, 1, 2].map(|i| o[i] + te * d[i] - c[i]);
            // (got, exact) margins: positive outside.
            let margins: heapless::Vec<(f64, f64), 2> = match shape {
                MixShape::Disc { c24, r2, .. } => {
                    let q = if persp {
                        ray.point24::<true>(t)
                    } else {
                        ray.point24::<false>(t)
                    };
                    let d2: u64 = zip3(q, c24, |p, c| wsq(p.saturating_sub(c))).iter().sum();
                    let got = ((d2 as f64).sqrt() - (r2 as f64).sqrt()) * ld(-24);
                    heapless::Vec::from_slice(&[(got, dot(pe, pe).sqrt() - r)]).unwrap_or_default()
                }
                MixShape::Rect {
                    cu,
                    cv,
                    hu: hu42,
                    hv: hv42,
                    ..
                } => {
                    let unit = ld(-(24 + 24 - along as i32));
                    let m = |ax: [i32; 3], ca: i64, h: i64, a: [f64; 3], he: f64| {
                        let w = if persp {
                            ray.along::<true>(t, ax)
                        } else {
                            ray.along::<false>(t, ax)
                        };
                        (((w - ca).abs() - h) as f64 * unit, dot(pe, a).abs() - he)
                    };
                    heapless::Vec::from_slice(&[m(u30, cu, hu42, u, hu), m(v30, cv, hv42, v, hv)])
                        .unwrap_or_default()
                }
                _ => unreachable!(),
            };
            let sd = (dot(d, d) - nd * nd).max(0.0).sqrt();
            let bound = crate::planner::error_model::fast_boundary_m(
                1.0,
                sd,
                dot(d, d).sqrt(),
                te,
                1.0 / nd.abs(),
                r,
            );
            for (got, exact) in margins {
                let ratio = (got - exact).abs() / bound;
                assert!(
                    ratio <= 1.0,
                    "case {case} (disc {disc}, perspective {persp}): margin {got:e} against {exact:e}, bound {bound:e}"
                );
                worst = worst.max(ratio);
                sum_ratio += ratio;
                n_rays += 1;
            }
        }
    }
    std::println!(
        "{n_rays} margins: |error| up to {worst:.3} of the bound, {:.3} on average",
        sum_ratio / n_rays as f64
    );
    assert!(n_rays > 100_000, "{n_rays}");
}

/// `Aperture::slope_off` in 64-bit products is the 128-bit expression it
/// replaced, at the ends of both ranges and on random values.
#[test]
fn aperture_slope_offsets_are_the_128_bit_ones() {
    let exact = |a: i32, inv: i64| {
        let v = (a as i128 * inv as i128 + (1 << 37)) >> 38;
        v.clamp(i32::MIN as i128, i32::MAX as i128) as i32
    };
    let ends_a = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX];
    let ends_inv = [
        0,
        1,
        (1 << 32) - 1,
        1 << 32,
        (1 << 38) - 1,
        1 << 40,
        i64::MAX - 1,
        i64::MAX,
    ];
    let mut seed = 7;
    let mut cases: heapless::Vec<(i32, i64), 4096> = heapless::Vec::new();
    for a in ends_a {
        for inv in ends_inv {
            let _ = cases.push((a, inv));
        }
    }
    while !cases.is_full() {
        let (x, y) = (rng(&mut seed), rng(&mut seed));
        // Random magnitudes: inv below 2^(y mod 64).
        let _ = cases.push((x as i32 >> (x >> 59), (y >> 1 >> (y >> 58)) as i64));
    }
    for (a, inv) in cases {
        let ap = Aperture {
            m: 64,
            up: 0,
            r24: 0,
            inv_z40: inv,
            z18: 0,
        };
        assert_eq!(ap.slope_off(a), exact(a, inv), "a {a}, inv {inv}");
    }
}

/// A sphere the aperture loop spares for a pixel ([`aperture::sphere_reach`],
/// [`passes_beyond`]) is met by none of its aperture rays: random spheres
/// (radius 2⁻⁸ to 1 U, wholly ahead of the lens) and apertures (radius 1
/// to 50 mm, focused at 0.2 to 8 U), chief rays passing the centre from
/// inside the sphere to past the reach, and for each pattern size every
/// point's ray made as [`Mix32::line_d`] makes it (`A` in S24 and S18 U,
/// the slope offset [`Aperture::slope_off`]) and traced by the sphere's
/// exact pass in the frame moved to `A` ([`MixShape::moved`]). Also that
/// the reach is not loose: some chief ray past 90 % of its margin over the
/// radius has a ray that hits.
#[test]
fn a_spared_sphere_is_met_by_no_aperture_ray() {
    let mut s = 0x0a9e_4f17_5e4e_0001;
    let mut f = |lo: f64, hi: f64| lo + (hi - lo) * (rng(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
    let q = |x: f64| Q::from_num(x);
    let (mut spared, mut hit, mut near) = (0u32, 0u32, 0f64);
    for case in 0..400 {
        let rho = f(-8.0, 0.0).exp2();
        let c = [f(-2.0, 2.0), f(-2.0, 2.0), f(0.3, 6.0)];
        let lc = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let (r, z) = (f(0.001, 0.05), f(0.2, 8.0));
        if lc + rho > 8.0 || c[2] - rho <= 0.05 {
            continue;
        }
        let (rq, zq) = (q(r), q(z));
        let reach = super::aperture::sphere_reach(c[2], rho, (rq.to_num::<f64>(), zq.to_num::<f64>()), 0);
        if reach == 0 {
            continue;
        }
        let Some((shape, c24, _)) = sphere_shape(c, rho) else {
            continue;
        };
        let reach_u = reach as f64 / (1u64 << 24) as f64;
        for _ in 0..8 {
            // A chief ray through the point at distance `d` from the
            // centre, perpendicular to it: from inside the sphere to 20 %
            // past the reach.
            let d = f(0.5 * rho, 1.2 * reach_u);
            let dir = unit3([f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)]);
            let k = (dir[0] * c[0] + dir[1] * c[1] + dir[2] * c[2]) / lc;
            let w = unit3([0, 1, 2].map(|i| dir[i] - k * c[i] / lc));
            let p = [0, 1, 2].map(|i| c[i] + d * w[i]);
            if p[2] <= 0.0 || (p[0] / p[2]).abs() > 15.0 || (p[1] / p[2]).abs() > 15.0 {
                continue;
            }
            let s26 = |x: f64| (x * (1u64 << 26) as f64).round() as i32;
            let (x, y) = (s26(p[0] / p[2]), s26(p[1] / p[2]));
            let beyond = passes_beyond(x, y, c24, reach);
            let mut any = false;
            for m in crate::render::sensor::defocus::SIZES {
                // `2⁴⁰ U/Z̃` by one division (`Aperture::new` normalizes
                // first: within a unit of it, which the reach's margins
                // cover as they cover the offset's rounding).
                let ap = Aperture {
                    m,
                    up: crate::render::sensor::defocus::shift(m) - 17,
                    r24: len_s(rq, 0, 24),
                    inv_z40: ((1u128 << 72) / zq.to_bits() as u128) as i64,
                    z18: len_s(zq, 0, 18),
                };
                for u in crate::render::sensor::defocus::SPIRAL.iter().take(m as usize) {
                    let a24 = u.map(|v| sat32(((i64::from(v) << ap.up) * ap.r24 as i64 + (1 << 14)) >> 15));
                    let a = a24.map(|v| sat32((v as i64 + 32) >> 6));
                    let off = a24.map(|v| ap.slope_off(v));
                    let mut ray = [Ray::flat(x.saturating_sub(off[0]), y.saturating_sub(off[1]))];
                    shape
                        .moved(a, a24)
                        .nearest::<true, true>(0, &mut ray, (None, [0; 4]));
                    any |= ray[0].t != NO_HIT;
                }
            }
            assert!(
                !(beyond && any),
                "case {case}: an aperture ray meets a spared sphere (c {c:?}, r {rho}, aperture {r} at {z}, d {d})"
            );
            if beyond {
                spared += 1;
            }
            if any {
                hit += 1;
                // How far past the radius the farthest chief ray with a
                // hit lies, as a share of the reach's margin over it.
                let dist = d * lc / (lc * lc + d * d).sqrt();
                near = near.max((dist - rho) / (reach_u - rho));
            }
        }
    }
    std::println!(
        "{spared} chief rays spared, {hit} with a hit; the farthest hit {near:.3} of the reach's margin"
    );
    assert!(spared > 200 && hit > 600, "{spared} spared, {hit} hit");
    assert!(
        near > 0.9,
        "the reach is loose: hits reach {near:.3} of its margin"
    );
}
